#include "skidimm/io/csv.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>

#include "core/temp_files.h"
#include "skidimm/errors.h"

namespace skidimm {
namespace {

using skidimm_test::read_file;
using skidimm_test::test_directory;
using skidimm_test::write_file;
using ::testing::HasSubstr;

template <typename F>
void expect_log_error(F&& f, std::initializer_list<std::string> parts) {
  try {
    f();
    ADD_FAILURE() << "expected a LogError";
  } catch (const LogError& e) {
    for (const std::string& part : parts) EXPECT_THAT(e.what(), HasSubstr(part));
  }
}

void expect_long_line(const std::filesystem::path& file, long line) {
  try {
    CsvReader reader(file);
    std::vector<std::string> fields;
    while (reader.next(&fields)) {
    }
    ADD_FAILURE() << file << ": no error";
  } catch (const LogError& e) {
    EXPECT_THAT(e.what(), HasSubstr(file.filename().string() + ":" + std::to_string(line) +
                                    ": a line longer than 1048576 bytes: not a CSV log"));
  }
}

TEST(CsvReader, HandlesQuotesEscapesCrlfAndBlankLines) {
  const auto file = write_file(test_directory() / "q.csv",
                               "a,name,b\r\n1,\"['x', 'y']\",2\r\n\r\n3,\"say \"\"hi\"\"\",4\n5,\"two\nlines\",6\n");
  CsvReader reader(file);
  EXPECT_EQ(reader.header(), (std::vector<std::string>{"a", "name", "b"}));
  std::vector<std::string> fields;
  ASSERT_TRUE(reader.next(&fields));
  EXPECT_EQ(fields[1], "['x', 'y']");
  EXPECT_EQ(reader.line(), 2);
  ASSERT_TRUE(reader.next(&fields));
  EXPECT_EQ(fields[1], "say \"hi\"");
  EXPECT_EQ(reader.line(), 4);
  ASSERT_TRUE(reader.next(&fields));
  EXPECT_EQ(fields[1], "two\nlines");
  EXPECT_EQ(fields[2], "6");
  EXPECT_FALSE(reader.next(&fields));
}

// Lines ended by CR alone read as one line; said as such (it was "column
// '0' appears twice in the header"). A quoted header name across CR LF is
// a name, not that.
TEST(CsvReader, LinesEndedByACarriageReturnAloneAreSaid) {
  const auto file = write_file(test_directory() / "cr.csv", "t,a\r0,1\r1,2\r");
  try {
    CsvReader reader(file);
    ADD_FAILURE() << "read a file of CR line endings";
  } catch (const LogError& e) {
    EXPECT_THAT(e.what(), HasSubstr("cr.csv:1: its lines end in a carriage return alone (CR, not LF or CR LF)"));
  }
  CsvReader quoted(write_file(test_directory() / "quoted.csv", "t,\"two\r\nlines\"\r\n0,1\r\n"));
  EXPECT_EQ(quoted.header(), (std::vector<std::string>{"t", "two\nlines"})) << "CR LF read as a line end";
  // A lone CR quoted in a header followed by rows is a name with a CR in it.
  CsvReader lone(write_file(test_directory() / "lone.csv", "t,\"note\rx\"\n0,1\n"));
  EXPECT_EQ(lone.header(), (std::vector<std::string>{"t", "note\rx"}));
  // Past the longest line a reader takes (1 MiB), the same: said as CR line endings, not as a long line.
  std::string big = "t,a\r";
  while (big.size() < (3u << 20)) big += "0.123456789,1.23456789\r";
  try {
    CsvReader reader(write_file(test_directory() / "big_cr.csv", big));
    ADD_FAILURE() << "read a file of CR line endings";
  } catch (const LogError& e) {
    EXPECT_THAT(e.what(), HasSubstr("big_cr.csv:1: its lines end in a carriage return alone"));
  }
}

// Every way a header can be refused closes the file: a reader that throws
// from its constructor has no destructor to do it.
TEST(CsvReader, ARefusedHeaderLeavesNoFileOpen) {
  auto open_descriptors = [] {
    return std::distance(std::filesystem::directory_iterator("/proc/self/fd"), std::filesystem::directory_iterator());
  };
  const std::vector<std::string> headers = {"", "t,\"unterminated\n0,1\n", "t,a,a\n0,1,2\n"};
  for (std::size_t h = 0; h < headers.size(); ++h) {
    const auto file = write_file(test_directory() / ("header_" + std::to_string(h) + ".csv"), headers[h]);
    const auto before = open_descriptors();
    for (int i = 0; i < 50; ++i) EXPECT_THROW(CsvReader reader(file), LogError) << headers[h];
    EXPECT_EQ(open_descriptors(), before) << "header " << h << " leaked descriptors";
  }
}

TEST(CsvReader, ALineLongerThanTheCapIsRefusedNamingIt) {
  const auto dir = test_directory();
  const std::string megabyte_and_more((1 << 20) + 10, 'x');
  expect_long_line(write_file(dir / "header.csv", megabyte_and_more + "\n"), 1);
  expect_long_line(write_file(dir / "row.csv", "a,b\n1,2\n" + megabyte_and_more + ",1\n3,4\n"), 3);
  expect_long_line(write_file(dir / "last.csv", "a,b\n1,2\n" + megabyte_and_more), 3);
  expect_long_line(write_file(dir / "nul.csv", "a,b\n" + std::string((1 << 20) + 10, '\0')), 2);
  // A quoted field spanning lines counts as one record.
  std::string lines = "a,b\n1,\"";
  for (int i = 0; i < 20000; ++i) lines += "a quoted line of about sixty characters, on and on and on\n";
  expect_long_line(write_file(dir / "quoted.csv", lines + "\"\n"), 2);
  // Just under the cap is a line like any other.
  CsvReader reader(write_file(dir / "under.csv", "a,b\n1," + std::string((1 << 20) - 10, '7') + "\n"));
  std::vector<std::string> fields;
  ASSERT_TRUE(reader.next(&fields));
  EXPECT_EQ(fields[1].size(), (1u << 20) - 10);
}

TEST(CsvReader, AHeaderOfManyColumnsIsCheckedForDuplicatesInLinearTime) {
  std::string header;
  for (int c = 0; c < 100000; ++c) header += (c ? ",c" : "c") + std::to_string(c);
  const auto dir = test_directory();
  CsvReader wide(write_file(dir / "wide.csv", header + "\n"));
  EXPECT_EQ(wide.header().size(), 100000u);
  EXPECT_EQ(wide.column("c99999"), 99999);
  try {
    CsvReader twice(write_file(dir / "twice.csv", header + ",c5\n"));
    ADD_FAILURE() << "a duplicate column was accepted";
  } catch (const LogError& e) {
    EXPECT_THAT(e.what(), HasSubstr("twice.csv:1: column 'c5' appears twice in the header"));
  }
}

TEST(CsvReader, WrongFieldCountNamesTheLine) {
  const auto file = write_file(test_directory() / "bad.csv", "a,b\n1,2\n3\n");
  CsvReader reader(file);
  std::vector<std::string> fields;
  reader.next(&fields);
  expect_log_error([&] { reader.next(&fields); }, {"bad.csv:3: expected 2 fields like the header, got 1"});
}

TEST(CsvWriter, WritesPartialThenRenamesOnCommit) {
  const auto dir = test_directory();
  {
    CsvWriter writer(dir / "out.csv", {"a", "b"});
    writer.write_row({"1", "x,y"});
    EXPECT_FALSE(std::filesystem::exists(dir / "out.csv"));
    writer.commit();
  }
  EXPECT_EQ(read_file(dir / "out.csv"), "a,b\n1,\"x,y\"\n");
  EXPECT_FALSE(std::filesystem::exists(dir / "out.csv.partial"));
  {
    CsvWriter abandoned(dir / "never.csv", {"a"});
    abandoned.write_row({"1"});
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "never.csv"));
  EXPECT_EQ(read_file(dir / "never.csv.partial"), "a\n1\n");
}

TEST(CsvWriter, FormatRoundTripsExactly) {
  for (double v : {0.1, 1.0 / 3.0, 1e-300, -2.5e17, 0.0}) EXPECT_EQ(std::stod(CsvWriter::format(v)), v);
  EXPECT_EQ(CsvWriter::format(0.25), "0.25");
  EXPECT_EQ(CsvWriter::format(std::nan("")), "nan");
}

}  // namespace
}  // namespace skidimm
