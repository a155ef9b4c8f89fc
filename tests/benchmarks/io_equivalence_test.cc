// The fast paths against what they replaced: the CSV reader
// against the original line-by-line reader, the writer's bytes against the
// original string-per-cell writer, the number text against std::to_chars and
// std::from_chars, and the .npy output read back. (Performance-related
// correctness; the timings are in the benchmarks next to this file.)
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "core/temp_files.h"
#include "number_text.h"
#include "skidimm/errors.h"
#include "skidimm/io/csv.h"
#include "skidimm/io/estimates_writer.h"

namespace skidimm {
namespace {

using skidimm_test::read_file;
using skidimm_test::test_directory;
using skidimm_test::write_file;

// ---------------------------------------------------------------- numbers

std::string standard_text(double v) {
  char b[64];
  return std::string(b, std::to_chars(b, b + sizeof(b), v).ptr);
}

std::string fast_text(double v) {
  char b[64];
  return std::string(b, number_text::shortest_to_chars(b, b + sizeof(b), v));
}

TEST(NumberText, ShortestTextIsStdToCharsCharacterForCharacter) {
  std::mt19937_64 rng(11);
  std::uniform_int_distribution<long> mantissa(0, 999999999);
  std::uniform_int_distribution<int> exponent(-25, 16);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  std::vector<double> values = {0.0, -0.0, 1.0, -1.0, 0.1, 1e-9, 1e-300, 9.999999999999999e-301, 1e-301,
                                9007199254740991.0, 9007199254740992.0, 9007199254740993.0, 1e22, 1e23,
                                std::numeric_limits<double>::denorm_min(), std::numeric_limits<double>::max(),
                                std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
  for (int p = -300; p <= 22; ++p) {
    const double power = std::pow(10.0, p);
    values.insert(values.end(), {power, std::nextafter(power, 0.0), std::nextafter(power, 1e308), 5.0 * power,
                                 2.5 * power, 1.5 * power});
  }
  for (int k = 0; k < 1000000; ++k) {
    std::uint64_t bits = rng();
    double v;
    std::memcpy(&v, &bits, sizeof(v));
    if (std::isfinite(v)) values.push_back(v);
    const double m = static_cast<double>(mantissa(rng));  // one draw per statement: the same
    const int e1 = exponent(rng);                          // values whatever the compiler
    values.push_back(m * std::pow(10.0, e1));
    const double f = uniform(rng);
    const int e2 = exponent(rng);
    values.push_back(f * std::pow(10.0, e2));
    values.push_back(static_cast<double>(k) * 0.001);
  }
  long checked = 0;
  for (double v : values) {
    for (double s : {v, -v}) {
      ASSERT_EQ(fast_text(s), standard_text(s)) << "bits of the value: " << standard_text(s);
      ++checked;
    }
  }
  EXPECT_GT(checked, 8000000);
}

// The eight-digit blocks the shortest text is written with, against
// snprintf: every value whose digits are all one digit, every power of ten
// and its neighbours, and a stride through the rest (all 10^8 values were
// checked once when it was written; that takes seconds, too long here).
TEST(NumberText, EightDigitBlocksAreSnprintfsDigits) {
  std::vector<std::uint32_t> values;
  for (std::uint32_t d = 0; d <= 9; ++d) values.push_back(d * 11111111u);
  for (std::uint32_t power = 1; power <= 10000000u; power *= 10) {
    values.insert(values.end(), {power - 1, power, power + 1, 9 * power, 10 * power - 1});
  }
  for (std::uint32_t x = 0; x < 100000000u; x += 997) values.push_back(x);
  for (const std::uint32_t x : values) {
    char fast[8], expected[16];
    number_text::internal::write_eight_digits(x, fast);
    std::snprintf(expected, sizeof expected, "%08u", x);
    ASSERT_EQ(std::string(fast, 8), std::string(expected, 8)) << x;
  }
}

TEST(NumberText, PlainDecimalsParseToFromCharsValueBitForBit) {
  std::mt19937_64 rng(12);
  long fast = 0;
  for (int k = 0; k < 2000000; ++k) {
    std::string s;
    if (rng() % 2) s += '-';
    const int integer_digits = static_cast<int>(rng() % 9), fraction_digits = static_cast<int>(rng() % 20);
    for (int i = 0; i < integer_digits; ++i) s += static_cast<char>('0' + rng() % 10);
    if (rng() % 4 != 0) {
      s += '.';
      for (int i = 0; i < fraction_digits; ++i) s += static_cast<char>('0' + rng() % 10);
    }
    if (rng() % 50 == 0) s += "e5";
    double a = 0.0, b = 0.0;
    const bool parsed = number_text::parse_plain_decimal(s, &a);
    const auto r = std::from_chars(s.data(), s.data() + s.size(), b);
    const bool standard = r.ec == std::errc() && r.ptr == s.data() + s.size();
    if (!parsed) continue;  // the caller falls back to from_chars
    ++fast;
    ASSERT_TRUE(standard) << s;
    ASSERT_EQ(std::memcmp(&a, &b, sizeof(a)), 0) << s;
  }
  EXPECT_GT(fast, 1000000);
  for (const char* s : {"", "-", ".", "-.", "nan", "inf", "1e5", "0x10", "1.2.3", " 1", "1 ", "+1"}) {
    double v = 0.0;
    EXPECT_FALSE(number_text::parse_plain_decimal(s, &v)) << s;
  }
}

// ---------------------------------------------------------------- reader

// The reader before the fast paths, line by line with std::getline (log_io.cc at
// caad34e), as a reference.
class OriginalReader {
 public:
  explicit OriginalReader(const std::filesystem::path& path) : in_(path, std::ios::binary) {}
  bool next(std::vector<std::string>* fields) {
    fields->clear();
    std::string line;
    while (true) {
      if (!std::getline(in_, line)) return false;
      line_ = next_line_++;
      bytes_read_ += line.size() + 1;
      if (!line.empty() && line.back() == '\r') line.pop_back();
      if (!line.empty()) break;
    }
    std::string field;
    bool in_quotes = false;
    std::size_t i = 0;
    while (true) {
      if (i == line.size()) {
        if (!in_quotes) break;
        std::string more;
        if (!std::getline(in_, more)) throw LogError("", line_, "unterminated quoted field");
        ++next_line_;
        bytes_read_ += more.size() + 1;
        if (!more.empty() && more.back() == '\r') more.pop_back();
        field += '\n';
        line = more;
        i = 0;
        continue;
      }
      const char c = line[i++];
      if (in_quotes) {
        if (c == '"') {
          if (i < line.size() && line[i] == '"') {
            field += '"';
            ++i;
          } else {
            in_quotes = false;
          }
        } else {
          field += c;
        }
      } else if (c == '"') {
        in_quotes = true;
      } else if (c == ',') {
        fields->push_back(std::move(field));
        field.clear();
      } else {
        field += c;
      }
    }
    fields->push_back(std::move(field));
    return true;
  }
  long line() const { return line_; }
  std::uintmax_t bytes_read() const { return bytes_read_; }

 private:
  std::ifstream in_;
  long line_ = 0, next_line_ = 1;
  std::uintmax_t bytes_read_ = 0;
};

// Random CSV text with everything the format allows: quotes, escaped
// quotes, commas and line breaks inside quotes, CRLF, blank lines, a '"' in
// the middle of a field, long lines past the reader's 64 KiB block, no final
// line break.
std::string random_csv(std::mt19937_64& rng, int columns, int rows) {
  static const char kAlphabet[] = "abc0123456789.-+e ,\"\r\n\t";
  auto cell = [&]() {
    std::string s;
    const int kind = static_cast<int>(rng() % 10);
    const int length = kind == 9 && rng() % 20 == 0 ? 70000 + static_cast<int>(rng() % 1000) : static_cast<int>(rng() % 8);
    if (kind < 5) {
      for (int i = 0; i < length; ++i) s += "0123456789.-"[rng() % 12];
    } else if (kind < 8) {
      s += '"';
      for (int i = 0; i < length; ++i) {
        const char c = kAlphabet[rng() % (sizeof(kAlphabet) - 1)];
        s += c;
        if (c == '"') s += '"';
      }
      s += '"';
    } else {
      for (int i = 0; i < length; ++i) s += "xyz0 \t\r"[rng() % 7];
      if (rng() % 3 == 0) s += "a\"b\"c";
    }
    return s;
  };
  std::string text;
  for (int c = 0; c < columns; ++c) text += (c ? "," : "") + std::string("h") + std::to_string(c);
  text += "\n";
  for (int r = 0; r < rows; ++r) {
    if (rng() % 10 == 0) text += rng() % 2 ? "\n" : "\r\n";
    for (int c = 0; c < columns; ++c) text += (c ? "," : "") + cell();
    if (r + 1 < rows || rng() % 2) text += rng() % 3 == 0 ? "\r\n" : "\n";
  }
  return text;
}

TEST(CsvReader, ReadsEveryRowLikeTheOriginalReader) {
  const auto dir = test_directory();
  std::mt19937_64 rng(5);
  int compared = 0;
  for (int file = 0; file < 300; ++file) {
    const auto path = write_file(dir / ("f" + std::to_string(file) + ".csv"), random_csv(rng, 1 + file % 6, 200));
    OriginalReader original(path);
    std::vector<std::string> expected, header;
    original.next(&header);
    CsvReader reader(path);
    ASSERT_EQ(reader.header(), header);
    std::vector<std::string> fields;
    while (true) {
      bool original_ok = false, original_threw = false, threw = false, ok = false;
      long error_line = 0;
      try {
        original_ok = original.next(&expected);
      } catch (const LogError& e) {
        original_threw = true;
      }
      try {
        ok = reader.next(&fields);
      } catch (const LogError& e) {
        threw = true;
        error_line = reader.line();
      }
      if (!original_threw && original_ok && expected.size() != header.size()) {
        // The original threw for a wrong field count after reading the row.
        ASSERT_TRUE(threw) << path << " line " << original.line();
        ASSERT_EQ(error_line, original.line());
        break;
      }
      ASSERT_EQ(threw, original_threw) << path << " line " << original.line();
      if (threw) break;
      ASSERT_EQ(ok, original_ok) << path;
      if (!ok) break;
      ASSERT_EQ(fields, expected) << path << " line " << original.line();
      ASSERT_EQ(reader.line(), original.line()) << path;
      ASSERT_EQ(reader.bytes_read(), original.bytes_read()) << path;
      ++compared;
    }
  }
  EXPECT_GT(compared, 5000);
}

TEST(CsvReader, FieldViewsAreTheFieldsAndErrorsNameTheirLine) {
  const auto dir = test_directory();
  const auto path = write_file(dir / "a.csv", "a,b,c\n1,2,3\r\n\n4,\"x,\"\"y\"\"\nz\",6\n7,8\n");
  CsvReader reader(path);
  ASSERT_TRUE(reader.next_row());
  EXPECT_EQ(reader.field(2), "3");
  EXPECT_EQ(reader.line(), 2);
  ASSERT_TRUE(reader.next_row());
  EXPECT_EQ(reader.field(1), "x,\"y\"\nz");
  EXPECT_EQ(reader.line(), 4);
  try {
    reader.next_row();
    ADD_FAILURE() << "expected a LogError";
  } catch (const LogError& e) {
    EXPECT_NE(std::string(e.what()).find("a.csv:6: expected 3 fields like the header, got 2"), std::string::npos)
        << e.what();
  }
}

// ---------------------------------------------------------------- writer

// What EstimatesWriter wrote before the fast paths: a string per cell, quoted when
// needed, through CsvWriter::write_row.
std::string original_cell(double v) {
  if (std::isnan(v)) return "nan";
  return standard_text(v);
}

std::string original_quoted(const std::string& cell) {
  if (cell.find_first_of(",\"\n") == std::string::npos) return cell;
  std::string out = "\"";
  for (char c : cell) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + "\"";
}

BankConfig two_mode_config() {
  BankConfig c;
  c.state_names = {"V", "omega"};
  c.modes.resize(2);
  c.modes[0].name = "asphalt";
  c.modes[1].name = "grass, wet";  // a name that needs quotes
  return c;
}

TEST(EstimatesWriter, CsvIsByteForByteTheOriginalFormat) {
  const auto dir = test_directory();
  const BankConfig config = two_mode_config();
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> uniform(-2.0, 2.0);
  const double specials[] = {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(),
                             -std::numeric_limits<double>::infinity(), -0.0, 0.0, 1e-300, 5e-324, 1e300, 1e-9,
                             123456789012345678.0};
  std::string expected;
  {
    std::vector<std::string> header = EstimatesWriter::header(config, true);
    for (std::size_t i = 0; i < header.size(); ++i) expected += (i ? "," : "") + original_quoted(header[i]);
    expected += "\n";
  }
  {
    EstimatesWriter writer(dir / "new.csv", config, true);
    ImmEstimate e;
    e.mode_probabilities.resize(2);
    e.state.resize(2);
    e.covariance.resize(2, 2);
    const char* decisions[] = {"asphalt", "unknown", "grass, wet"};
    const char* truths[] = {"", "asphalt", "say \"hi\"", "two\nlines"};
    for (int k = 0; k < 5000; ++k) {
      const double t = 0.01 * k;
      for (int j = 0; j < 2; ++j) e.mode_probabilities[j] = std::abs(uniform(rng));
      for (int i = 0; i < 2; ++i) {
        e.state[i] = k % 7 == 0 ? specials[(k / 7 + i) % 10] : uniform(rng) * std::pow(10.0, k % 30 - 15);
        e.covariance(i, i) = std::abs(uniform(rng)) * 1e-4;
      }
      e.most_likely_mode = k % 2;
      e.status = static_cast<StepStatus>(k % 5);
      const std::string decision = decisions[k % 3], truth = truths[k % 4];
      writer.write(t, e, decision, truth);
      std::vector<std::string> cells{original_cell(t)};
      for (int j = 0; j < 2; ++j) cells.push_back(original_cell(e.mode_probabilities[j]));
      for (int i = 0; i < 2; ++i) cells.push_back(original_cell(e.state[i]));
      for (int i = 0; i < 2; ++i) cells.push_back(original_cell(e.covariance(i, i)));
      cells.push_back(config.modes[static_cast<std::size_t>(e.most_likely_mode)].name);
      cells.push_back(decision);
      cells.push_back(truth);
      cells.push_back(to_string(e.status));
      cells.push_back("");  // reason: no mode failed or gated
      for (std::size_t i = 0; i < cells.size(); ++i) expected += (i ? "," : "") + original_quoted(cells[i]);
      expected += "\n";
    }
    writer.commit();
  }
  EXPECT_EQ(read_file(dir / "new.csv"), expected);
}

// A minimal .npy reader: the header's Python literal, then records.
struct Npy {
  std::string header;
  std::string data;
  long rows = 0;
};

Npy read_npy(const std::filesystem::path& path) {
  const std::string bytes = read_file(path);
  Npy npy;
  EXPECT_EQ(bytes.substr(0, 6), "\x93NUMPY");
  const int major = bytes[6];
  const std::size_t length = major == 1 ? static_cast<unsigned char>(bytes[8]) | static_cast<unsigned char>(bytes[9]) << 8
                                        : static_cast<std::size_t>(static_cast<unsigned char>(bytes[8]) |
                                                                   static_cast<unsigned char>(bytes[9]) << 8 |
                                                                   static_cast<unsigned char>(bytes[10]) << 16);
  const std::size_t offset = major == 1 ? 10 : 12;
  npy.header = bytes.substr(offset, length);
  EXPECT_EQ((offset + length) % 64, 0u);
  EXPECT_EQ(npy.header.back(), '\n');
  npy.data = bytes.substr(offset + length);
  const auto shape = npy.header.find("'shape': (");
  npy.rows = std::stol(npy.header.substr(shape + 10));
  return npy;
}

TEST(EstimatesWriter, NpyHoldsTheExactValuesTheTextColumnsAndReasonCodes) {
  const auto dir = test_directory();
  const BankConfig config = two_mode_config();
  ImmEstimate e;
  e.mode_probabilities = Eigen::Vector2d(0.25, 0.75);
  e.state = Eigen::Vector2d(1.0 / 3.0, -2.5e-17);
  e.covariance = Eigen::Matrix2d::Identity() * 0.1;
  e.most_likely_mode = 1;
  e.status = StepStatus::kAllModesRejected;
  e.failure_reasons = {"", ""};
  {
    EstimatesWriter writer(dir / "out.npy", config, true);
    for (int k = 0; k < 2500; ++k) {
      // Rows 0, 3, 6, ...: no reason; the others gated with NIS 25.5 or 26.5.
      e.mode_failures = {ModeFailure::kNone, k % 3 == 0 ? ModeFailure::kNone : ModeFailure::kGated};
      e.nis = Eigen::Vector2d(1.0, 24.5 + k % 3);
      writer.write(0.01 * k, e, k % 2 ? "grass, wet" : "unknown", "asphalt");
    }
    writer.commit();
  }
  const Npy npy = read_npy(dir / "out.npy");
  EXPECT_NE(npy.header.find("{'descr': [('t', '<f8'), ('mu_asphalt', '<f8'), ('mu_grass, wet', '<f8'), ('V', '<f8'), "
                            "('omega', '<f8'), ('var_V', '<f8'), ('var_omega', '<f8'), ('mode', 'S10'), "
                            "('decision', 'S10'), ('truth_mode', 'S64'), ('status', 'S18'), ('reason_code', '<u4')], "
                            "'fortran_order': False"),
            std::string::npos)
      << npy.header;
  EXPECT_EQ(npy.rows, 2500);
  const std::size_t record = 7 * 8 + 10 + 10 + 64 + 18 + 4;
  ASSERT_EQ(npy.data.size(), record * 2500);
  for (int k : {0, 1, 2, 3, 2499}) {
    const char* r = npy.data.data() + record * static_cast<std::size_t>(k);
    double values[7];
    std::memcpy(values, r, sizeof(values));
    EXPECT_EQ(values[0], 0.01 * k);
    EXPECT_EQ(values[1], 0.25);
    EXPECT_EQ(values[3], 1.0 / 3.0);
    EXPECT_EQ(values[4], -2.5e-17);
    EXPECT_EQ(values[5], 0.1);
    EXPECT_EQ(std::string(r + 56, 10), std::string("grass, wet"));
    EXPECT_EQ(std::string(r + 66, 10), k % 2 ? std::string("grass, wet") : std::string("unknown\0\0\0", 10));
    EXPECT_EQ(std::string(r + 76, 7), "asphalt");
    EXPECT_EQ(std::string(r + 140, 18), "all_modes_rejected");
    std::uint32_t code = 0;
    std::memcpy(&code, r + 158, 4);
    EXPECT_EQ(code, static_cast<std::uint32_t>(k % 3)) << "row " << k;  // in the order first seen
  }
  EXPECT_EQ(EstimatesWriter::reasons_path(dir / "out.npy"), dir / "out.reasons.json");
  EXPECT_EQ(read_file(dir / "out.reasons.json"),
            "[\n\"\",\n\"grass, wet: gated (NIS 25.5)\",\n\"grass, wet: gated (NIS 26.5)\"\n]\n");
}

// The table read by a JSON parser nobody here wrote (yaml-cpp reads JSON):
// quotes, backslashes, control characters, UTF-8 and bytes that are not UTF-8.
TEST(EstimatesWriter, NpyReasonTableIsJsonForAnyBytesAPluginThrows) {
  const auto dir = test_directory();
  const std::string message = std::string("predict \"x\" \\ failed\n\ttab \x01 caf\xc3\xa9 \xff\xc3 end");
  ImmEstimate e;
  e.mode_probabilities = Eigen::Vector2d(0.5, 0.5);
  e.state = Eigen::Vector2d(1.0, 2.0);
  e.covariance = Eigen::Matrix2d::Identity();
  e.mode_failures = {ModeFailure::kModel, ModeFailure::kNone};
  e.failure_reasons = {message, ""};
  e.nis = Eigen::Vector2d(0.0, 0.0);
  {
    EstimatesWriter writer(dir / "odd.npy", two_mode_config(), false);
    writer.write(0.0, e, "unknown", "");
    writer.commit();
  }
  const YAML::Node table = YAML::LoadFile((dir / "odd.reasons.json").string());
  ASSERT_TRUE(table.IsSequence());
  ASSERT_EQ(table.size(), 2u);
  EXPECT_EQ(table[0].as<std::string>(), "");
  // Valid UTF-8 kept; 0xff and the cut sequence 0xc3 as the code points of the same value.
  EXPECT_EQ(table[1].as<std::string>(), "asphalt: model failed, reset: predict \"x\" \\ failed\n\ttab \x01 caf\xc3\xa9 "
                                        "\xc3\xbf\xc3\x83 end");
}

TEST(EstimatesWriter, AnInterruptedNpyIsLoadableWithTheRowsSoFarAndTheirReasons) {
  const auto dir = test_directory();
  const BankConfig config = two_mode_config();
  ImmEstimate e;
  e.mode_probabilities = Eigen::Vector2d(0.5, 0.5);
  e.state = Eigen::Vector2d(1.0, 2.0);
  e.covariance = Eigen::Matrix2d::Identity();
  e.mode_failures = {ModeFailure::kDiverged, ModeFailure::kNone};
  e.failure_reasons = {"", ""};
  {
    EstimatesWriter writer(dir / "cut.npy", config, false);
    for (int k = 0; k < 1234; ++k) writer.write(k, e, "unknown", "");
    // destroyed without commit(), as when a later row fails
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "cut.npy"));
  EXPECT_FALSE(std::filesystem::exists(dir / "cut.reasons.json"));
  const Npy npy = read_npy(dir / "cut.npy.partial");
  EXPECT_EQ(npy.rows, 1234);
  EXPECT_EQ(npy.data.size(), static_cast<std::size_t>(1234) * (7 * 8 + 10 + 10 + 18 + 4));
  EXPECT_EQ(npy.header.find("truth_mode"), std::string::npos);
  EXPECT_EQ(read_file(dir / "cut.reasons.json.partial"), "[\n\"\",\n\"asphalt: diverged, reset\"\n]\n");
}

// Past the first 65536 distinct texts, new ones are appended without being
// remembered: a repeat then gets a new code, which still maps to its text.
TEST(EstimatesWriter, NpyReasonCodesStayCorrectPastTheRememberedTexts) {
  const auto dir = test_directory();
  ImmEstimate e;
  e.mode_probabilities = Eigen::Vector2d(0.5, 0.5);
  e.state = Eigen::Vector2d(1.0, 2.0);
  e.covariance = Eigen::Matrix2d::Identity();
  e.mode_failures = {ModeFailure::kModel, ModeFailure::kNone};
  e.failure_reasons = {"", ""};
  e.nis = Eigen::Vector2d(0.0, 0.0);
  const int distinct = 70000;
  {
    EstimatesWriter writer(dir / "many.npy", two_mode_config(), false);
    for (int k = 0; k < 2 * distinct; ++k) {
      e.failure_reasons[0] = "case " + std::to_string(k % distinct);
      writer.write(k, e, "unknown", "");
    }
    writer.commit();
  }
  const Npy npy = read_npy(dir / "many.npy");
  const YAML::Node table = YAML::LoadFile((dir / "many.reasons.json").string());
  const std::size_t record = 7 * 8 + 10 + 10 + 18 + 4;
  ASSERT_EQ(npy.data.size(), record * 2 * distinct);
  std::uint32_t largest = 0;
  for (int k = 0; k < 2 * distinct; k += 997) {
    std::uint32_t code = 0;
    std::memcpy(&code, npy.data.data() + record * static_cast<std::size_t>(k) + record - 4, 4);
    ASSERT_LT(code, table.size());
    EXPECT_EQ(table[code].as<std::string>(), "asphalt: model failed, reset: case " + std::to_string(k % distinct))
        << "row " << k;
    largest = std::max(largest, code);
  }
  EXPECT_GT(largest, static_cast<std::uint32_t>(distinct));  // repeats past the remembered ones got new codes
}

TEST(EstimatesWriter, ATruthLabelTooLongForItsNpyColumnIsAnError) {
  const auto dir = test_directory();
  EstimatesWriter writer(dir / "long.npy", two_mode_config(), true);
  ImmEstimate e;
  e.mode_probabilities = Eigen::Vector2d(0.5, 0.5);
  e.state = Eigen::Vector2d(1.0, 2.0);
  e.covariance = Eigen::Matrix2d::Identity();
  try {
    writer.write(0.0, e, "unknown", std::string(65, 'x'));
    FAIL() << "no error";
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find("long.npy.partial: row 1: the truth label 'xxx"), std::string::npos)
        << error.what();
  }
}

}  // namespace
}  // namespace skidimm
