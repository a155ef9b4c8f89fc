#include "skidimm/log_io.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>

#include "core/temp_files.h"
#include "skidimm/errors.h"
#include "skidimm/imm.h"

namespace skidimm {
namespace {

using skidimm_test::read_file;
using skidimm_test::test_directory;
using skidimm_test::write_file;
using ::testing::HasSubstr;

const std::string kHuskyDir = std::string(SKIDIMM_SHARED_DATA_DIR) + "/husky_ice";

BankConfig simple_bank() {
  BankConfig c;
  c.state_names = {"V", "omega"};
  c.input_names = {"phi_dot_L", "phi_dot_R"};
  c.measurement.names = {"V", "omega"};
  c.columns.time = "t";
  c.columns.inputs = {"left", "right"};
  c.columns.measurements = {"v", "w"};
  return c;
}

template <typename F>
void expect_log_error(F&& f, std::initializer_list<std::string> parts) {
  try {
    f();
    ADD_FAILURE() << "expected a LogError";
  } catch (const LogError& e) {
    for (const std::string& part : parts) EXPECT_THAT(e.what(), HasSubstr(part));
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

TEST(CsvReader, WrongFieldCountNamesTheLine) {
  const auto file = write_file(test_directory() / "bad.csv", "a,b\n1,2\n3\n");
  CsvReader reader(file);
  std::vector<std::string> fields;
  reader.next(&fields);
  expect_log_error([&] { reader.next(&fields); }, {"bad.csv:3: expected 2 fields like the header, got 1"});
}

TEST(LogReader, ReadsSamplesWithMissingMeasurementsAsNaN) {
  const auto file = write_file(test_directory() / "log.csv", "t,left,right,v,w\n0,1,2,0.5,\n0.1,1,2,nan,0.2\n");
  LogReader reader(simple_bank(), {file});
  LogSample s;
  ASSERT_TRUE(reader.next(&s));
  EXPECT_EQ(s.u, Eigen::Vector2d(1, 2));
  EXPECT_EQ(s.z[0], 0.5);
  EXPECT_TRUE(std::isnan(s.z[1]));
  ASSERT_TRUE(reader.next(&s));
  EXPECT_TRUE(std::isnan(s.z[0]));
  EXPECT_EQ(s.row, 2);
  EXPECT_FALSE(reader.next(&s));
}

TEST(LogReader, MissingColumnNamesTheBankFieldAndWhatIsThere) {
  const auto file = write_file(test_directory() / "log.csv", "t,left,rigth,v,w\n0,1,2,3,4\n");
  expect_log_error(
      [&] { LogReader(simple_bank(), {file}); },
      {"log.csv:1: no column 'right' (the bank's columns.inputs.phi_dot_R)", "columns present: t, left, rigth, v, w"});
}

TEST(LogReader, ABinaryFileGivesAShortPrintableError) {
  std::string garbage(3000, '\0');
  for (std::size_t i = 0; i < garbage.size(); ++i) garbage[i] = static_cast<char>((i * 37 + 11) % 256);
  const auto file = write_file(test_directory() / "binary.csv", garbage);
  try {
    LogReader(simple_bank(), {file});
    FAIL();
  } catch (const LogError& e) {
    const std::string message = e.what();
    EXPECT_THAT(message, HasSubstr("no column 't'"));
    EXPECT_LT(message.size(), 700u);
    for (unsigned char c : message.substr(message.find("present:"))) EXPECT_TRUE(c >= 32 && c < 127) << int(c);
  }
}

TEST(LogReader, NonNumericCellNamesLineAndColumn) {
  const auto file = write_file(test_directory() / "log.csv", "t,left,right,v,w\n0,1,2,3,4\n0.1,1,fast,3,4\n");
  LogReader reader(simple_bank(), {file});
  LogSample s;
  reader.next(&s);
  expect_log_error([&] { reader.next(&s); }, {"log.csv:3: column 'right': expected a number, got 'fast'"});
}

TEST(LogReader, MissingInputIsAnError) {
  const auto file = write_file(test_directory() / "log.csv", "t,left,right,v,w\n0,,2,3,4\n");
  LogReader reader(simple_bank(), {file});
  LogSample s;
  expect_log_error([&] { reader.next(&s); }, {"log.csv:2: column 'left': value missing (required)"});
}

TEST(LogReader, TimeMustIncreaseStrictly) {
  const auto file = write_file(test_directory() / "log.csv", "t,left,right,v,w\n0,1,2,3,4\n0.5,1,2,3,4\n0.5,1,2,3,4\n");
  LogReader reader(simple_bank(), {file});
  LogSample s;
  reader.next(&s);
  reader.next(&s);
  expect_log_error([&] { reader.next(&s); },
                   {"log.csv:4: column 't': time must increase strictly, but 0.5 follows 0.5"});
}

TEST(LogReader, SideBySideFilesMustMatchRowForRow) {
  const auto dir = test_directory();
  const auto a = write_file(dir / "a.csv", "t,left,right\n0,1,2\n0.1,1,2\n");
  const auto b = write_file(dir / "b.csv", "v,w\n3,4\n");
  LogReader reader(simple_bank(), {a, b});
  LogSample s;
  ASSERT_TRUE(reader.next(&s));
  EXPECT_EQ(s.z, Eigen::Vector2d(3, 4));
  expect_log_error([&] { reader.next(&s); }, {"must match row for row", "b.csv ended after 1 data rows"});
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

// The real Husky ice logs: odometry/IMU/GPS in TSyn_NN.csv and the raw ROS
// joint-state export (a quoted list column, epoch times) in joint_states_NN.csv,
// read side by side, irregularly sampled (first steps below a millisecond).
TEST(RealHuskyData, AllElevenRunsReadSideBySideAndRunThroughAnLtcBank) {
  if (!std::filesystem::exists(kHuskyDir)) GTEST_SKIP() << "no shared data at " << kHuskyDir;
  const std::string bank_file = std::string(SKIDIMM_SOURCE_DIR) + "/tests/fixtures/banks/husky_ice_ltc.yaml";
  for (int run = 1; run <= 11; ++run) {
    char suffix[8];
    std::snprintf(suffix, sizeof(suffix), "%02d.csv", run);
    Imm imm = Imm::from_yaml(bank_file, {SKIDIMM_PLUGIN_DIR});
    LogReader reader(imm.config(), {kHuskyDir + "/TSyn_" + suffix, kHuskyDir + "/joint_states_" + suffix});
    LogSample s;
    long rows = 0;
    double smallest_dt = 1.0, last_t = -1.0;
    while (reader.next(&s)) {
      if (last_t >= 0.0) smallest_dt = std::min(smallest_dt, s.t - last_t);
      last_t = s.t;
      const ImmEstimate& e = imm.step(s.t, s.u, s.z);
      ASSERT_EQ(e.status, StepStatus::kUpdated) << "run " << run << " row " << s.row;
      ASSERT_TRUE(e.state.allFinite() && e.mode_probabilities.allFinite()) << "run " << run << " row " << s.row;
      ASSERT_NEAR(e.mode_probabilities.sum(), 1.0, 1e-12);
      ++rows;
    }
    // One sample per data line of the file, counted independently.
    std::ifstream tsyn(kHuskyDir + "/TSyn_" + suffix);
    const long lines = std::count(std::istreambuf_iterator<char>(tsyn), std::istreambuf_iterator<char>(), '\n');
    EXPECT_EQ(rows, lines - 1) << "run " << run;
    EXPECT_LT(smallest_dt, 1e-3) << "run " << run << ": the irregular first steps were not read";
  }
}

}  // namespace
}  // namespace skidimm
