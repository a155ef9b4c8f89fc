#include "skidimm/io/log_reader.h"

#include <fcntl.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <functional>
#include <future>
#include <iterator>
#include <thread>

#include "core/temp_files.h"
#include "skidimm/engine/imm.h"
#include "skidimm/errors.h"
#include "skidimm/io/csv.h"

namespace skidimm {
namespace {

using skidimm_test::test_directory;
using skidimm_test::write_file;
using ::testing::HasSubstr;
using ::testing::Not;

const std::string kHuskyDir = std::string(SKIDIMM_SHARED_DATA_DIR) + "/husky_ice";
const std::string kBorealDir = std::string(SKIDIMM_SHARED_DATA_DIR) + "/borealtc";

BankConfig simple_bank() {
  BankConfig c;
  c.file = "bank.yaml";
  c.state_names = {"V", "omega"};
  c.input_names = {"phi_dot_L", "phi_dot_R"};
  c.measurement.names = {"V", "omega"};
  c.columns.time = "t";
  c.columns.inputs = {"left", "right"};
  c.columns.measurements = {"v", "w"};
  return c;
}

template <typename F>
std::string expect_error(F&& f, std::initializer_list<std::string> parts) {
  try {
    f();
    ADD_FAILURE() << "expected an error";
  } catch (const Error& e) {
    for (const std::string& part : parts) EXPECT_THAT(e.what(), HasSubstr(part));
    return e.what();
  }
  return "";
}

std::vector<LogSample> read_all(LogReader& reader) {
  std::vector<LogSample> out;
  LogSample s;
  while (reader.next(&s)) out.push_back(s);
  return out;
}

// Reads until `reader` throws, expecting each of `parts` in the error: how
// many steps it delivered before, and the error's message.
struct StepsBeforeError {
  long steps = 0;
  std::string message;
};
StepsBeforeError read_until_error(LogReader& reader, std::initializer_list<std::string> parts) {
  StepsBeforeError out;
  LogSample s;
  out.message = expect_error(
      [&] {
        while (reader.next(&s)) ++out.steps;
      },
      parts);
  return out;
}

constexpr double kTight = 1e-12;

TEST(LogSpec, ParsesLabelsFilesAndOffsets) {
  const LogSpec a = parse_log_spec("ice=run/pro_01.csv+run/imu_01.csv@-0.025");
  EXPECT_EQ(a.label, "ice");
  ASSERT_EQ(a.files.size(), 2u);
  EXPECT_EQ(a.files[0].path, "run/pro_01.csv");
  EXPECT_EQ(a.files[0].time_offset, 0.0);
  EXPECT_EQ(a.files[1].path, "run/imu_01.csv");
  EXPECT_EQ(a.files[1].time_offset, -0.025);
  EXPECT_EQ(a.name(), "pro_01.csv+imu_01.csv");
  EXPECT_EQ(parse_log_spec("x.csv@+2").files[0].time_offset, 2.0);
  EXPECT_TRUE(parse_log_spec("log.csv").label.empty());
  // A file whose name has '=' or '@' is that file.
  const auto odd = write_file(test_directory() / "speed=2@night.csv", "t\n");
  const LogSpec b = parse_log_spec(odd.string());
  EXPECT_TRUE(b.label.empty());
  EXPECT_EQ(b.files[0].path, odd);
  expect_error([] { parse_log_spec("a.csv@soon"); }, {"'soon' after '@' is not a time offset in seconds"});
  // Unix times are offsets a log may need; 1e17 s left rows 16 s apart at best.
  EXPECT_EQ(parse_log_spec("x.csv@-1700000000.25").files[0].time_offset, -1700000000.25);
  expect_error(
      [] { parse_log_spec("a.csv@1e17"); },
      {"the time offset 1e17 s is larger in size than 1e11 s, where times lose the precision to keep rows apart"});
  expect_error([] { parse_log_spec("=a.csv"); }, {"empty label"});
  expect_error([] { parse_log_spec("ice=+"); }, {"no file given"});
  // A label after the files: the order that works is said.
  const auto dir = test_directory();
  const std::string pro = write_file(dir / "pro.csv", "t\n").string(),
                    imu = write_file(dir / "imu.csv", "t\n").string();
  expect_error([&] { parse_log_spec(pro + "+" + imu + "=ice"); },
               {"'" + imu + "=ice' is no file; a label goes before the files: 'ice=" + pro + "+" + imu + "'"});
  // Not where the part before '=' is a directory, or a label was given first.
  EXPECT_EQ(parse_log_spec(pro + "+" + dir.string() + "=x/imu.csv").files.size(), 2u);
  EXPECT_EQ(parse_log_spec("snow=" + pro + "+" + imu + "=ice").label, "snow");
}

// Tables name a log by its files' names, and logs whose names would be the
// same by as many of their last folders as tell them apart.
TEST(LogSpec, DistinctNamesAddFoldersOnlyWhereNamesWouldBeTheSame) {
  const std::vector<LogSpec> logs = {
      parse_log_spec("ICE=data/ICE/pro_04.csv+data/ICE/imu_04.csv"),
      parse_log_spec("SNOW=data/SNOW/pro_04.csv+data/SNOW/imu_04.csv"),
      parse_log_spec("SNOW=data/SNOW/pro_05.csv+data/SNOW/imu_05.csv"),
      parse_log_spec("a/day1/run.csv"),
      parse_log_spec("b/day1/run.csv"),
      parse_log_spec("run.csv"),
      parse_log_spec("/abs/x.csv"),
      parse_log_spec("/abs/x.csv"),
  };
  std::vector<const LogSpec*> specs;
  for (const LogSpec& log : logs) specs.push_back(&log);
  const std::vector<std::string> names = distinct_names(specs);
  ASSERT_EQ(names.size(), logs.size());
  EXPECT_EQ(names[0], "ICE/pro_04.csv+ICE/imu_04.csv");
  EXPECT_EQ(names[1], "SNOW/pro_04.csv+SNOW/imu_04.csv");
  EXPECT_EQ(names[2], "pro_05.csv+imu_05.csv");  // no other log of that name
  EXPECT_EQ(names[3], "a/day1/run.csv");         // day1/ alone would not tell them apart
  EXPECT_EQ(names[4], "b/day1/run.csv");
  EXPECT_EQ(names[5], "run.csv");  // all of its path
  // The same file twice: its whole path, the most there is to tell.
  EXPECT_EQ(names[6], "/abs/x.csv");
  EXPECT_EQ(names[7], "/abs/x.csv");
  EXPECT_TRUE(distinct_names({}).empty());
}

TEST(LogReader, OneFileEveryRowAStepMissingMeasurementsNaN) {
  const auto file = write_file(test_directory() / "log.csv", "t,left,right,v,w\n0,1,2,0.5,\n0.1,1,2,nan,0.2\n");
  LogReader reader(simple_bank(), {file});
  const auto s = read_all(reader);
  ASSERT_EQ(s.size(), 2u);
  EXPECT_EQ(s[0].u, Eigen::Vector2d(1, 2));
  EXPECT_EQ(s[0].z[0], 0.5);
  EXPECT_TRUE(std::isnan(s[0].z[1]));
  EXPECT_TRUE(std::isnan(s[1].z[0]));
  EXPECT_EQ(s[1].z[1], 0.2);
  EXPECT_EQ(s[1].row, 2);
}

TEST(LogReader, EmptyInputCellsHoldTheLatestValue) {
  // One file of two rates: inputs on every other row only.
  const auto file = write_file(test_directory() / "log.csv",
                               "t,left,right,v,w\n"
                               "0,1,2,,\n"
                               "0.05,,,0.3,\n"
                               "0.1,3,4,,0.7\n"
                               "0.15,,,0.4,\n");
  LogReader reader(simple_bank(), {file});
  const auto s = read_all(reader);
  ASSERT_EQ(s.size(), 4u);
  EXPECT_EQ(s[1].u, Eigen::Vector2d(1, 2));  // held
  EXPECT_EQ(s[1].z[0], 0.3);
  EXPECT_EQ(s[2].u, Eigen::Vector2d(3, 4));
  EXPECT_EQ(s[3].u, Eigen::Vector2d(3, 4));
  EXPECT_TRUE(std::isnan(s[0].z[0]) && std::isnan(s[0].z[1]));
}

TEST(LogReader, RowsBeforeEveryInputIsKnownAreNotStepsAndAreCounted) {
  const auto file = write_file(test_directory() / "log.csv",
                               "t,left,right,v,w\n"
                               "0,,2,0.1,0.1\n"  // left unknown yet
                               "0.1,1,,0.2,\n"   // now both known: the first step
                               "0.2,1,2,0.3,\n");
  LogReader reader(simple_bank(), {file});
  const auto s = read_all(reader);
  ASSERT_EQ(s.size(), 2u);
  EXPECT_DOUBLE_EQ(s[0].t, 0.1);
  EXPECT_EQ(s[0].u, Eigen::Vector2d(1, 2));
  EXPECT_EQ(s[0].z[0], 0.2);
  EXPECT_EQ(reader.stats().dropped_before_start, 2);
  EXPECT_THAT(reader.describe_stats(simple_bank()), HasSubstr("2 measurement value(s) came before every input"));
}

// Wheel speeds at 1/0.15 s in one file, a gyro at 100 Hz in another.
struct TwoRateLog {
  std::filesystem::path wheels, gyro;
};
TwoRateLog two_rate_log() {
  const auto dir = test_directory();
  std::string wheels = "time,velL,velR,cur\n", gyro = "time,wz\n";
  for (int k = 0; k <= 4; ++k) {
    wheels += std::to_string(0.15 * k) + "," + std::to_string(0.1 * k) + "," + std::to_string(0.2 * k) + "," +
              std::to_string(10 + k) + "\n";
  }
  for (int k = 0; k <= 60; ++k) gyro += std::to_string(0.01 * k) + "," + std::to_string(0.001 * k) + "\n";
  return {write_file(dir / "wheels.csv", wheels), write_file(dir / "gyro.csv", gyro)};
}

BankConfig two_rate_bank() {
  BankConfig c;
  c.file = "bank.yaml";
  c.state_names = {"omega", "current"};
  c.input_names = {"dv", "speed"};
  c.measurement.names = {"omega", "current"};
  c.columns.time = "time";
  c.columns.inputs = {"velR - velL", "abs(velL + velR) / 2"};
  c.columns.measurements = {"wz", "cur"};
  return c;
}

TEST(LogReader, FilesMergeByTimeWithInputsHeldAndMeasurementsWhenTheyArrive) {
  const TwoRateLog log = two_rate_log();
  LogReader reader(two_rate_bank(), {log.wheels, log.gyro});
  const auto s = read_all(reader);
  // A step at every time stamp of either file, until the wheels (the inputs) end at 0.6 s.
  ASSERT_EQ(s.size(), 61u);
  for (std::size_t k = 0; k < s.size(); ++k) {
    EXPECT_NEAR(s[k].t, 0.01 * static_cast<double>(k), kTight);
    EXPECT_NEAR(s[k].z[0], 0.001 * static_cast<double>(k), kTight);  // the gyro every step
    const int wheel_row = static_cast<int>(std::floor(s[k].t / 0.15 + 1e-9));
    EXPECT_NEAR(s[k].u[0], 0.1 * wheel_row, kTight) << "dv held from the wheel row at or before t = " << s[k].t;
    EXPECT_NEAR(s[k].u[1], 0.15 * wheel_row, kTight);
    const bool wheel_row_now = std::abs(s[k].t - 0.15 * wheel_row) < 1e-9;
    EXPECT_EQ(std::isnan(s[k].z[1]), !wheel_row_now) << "the current only at its own rows, t = " << s[k].t;
  }
  EXPECT_EQ(reader.stats().rows, (std::vector<long>{5, 61}));
}

TEST(LogReader, AFixedRateAggregatesOrTakesTheLastValueOfEachStep) {
  const TwoRateLog log = two_rate_log();
  BankConfig bank = two_rate_bank();
  bank.measurement.names = {"omega", "current", "omega_std", "omega_rms"};
  bank.columns.measurements = {"mean(wz)", "cur", "log(std(wz))", "rms(1000 * wz)"};
  SamplingConfig sampling;
  sampling.rate = 10.0;
  LogReader reader(bank, {log.wheels, log.gyro}, sampling);
  const auto s = read_all(reader);
  // Steps at 0, 0.1, ..., 0.6 s.
  ASSERT_EQ(s.size(), 7u);
  EXPECT_EQ(s[0].z[0], 0.0);  // only the row at t = 0 in the first step
  EXPECT_TRUE(std::isnan(s[0].z[2])) << "std of one value is missing";
  for (std::size_t k = 1; k < s.size(); ++k) {
    EXPECT_NEAR(s[k].t, 0.1 * static_cast<double>(k), kTight);
    // Rows k*10-9 .. k*10 (t in (0.1(k-1), 0.1k]): wz = 0.001 i.
    double mean = 0.0, squares = 0.0;
    for (int i = static_cast<int>(k) * 10 - 9; i <= static_cast<int>(k) * 10; ++i) {
      mean += 0.001 * i / 10.0;
      squares += (1.0 * i) * (1.0 * i) / 10.0;
    }
    EXPECT_NEAR(s[k].z[0], mean, 1e-12);
    // The sample standard deviation of ten equally spaced values 0.001 apart.
    EXPECT_NEAR(s[k].z[2], std::log(0.001 * std::sqrt(55.0 / 6.0)), 1e-9);
    EXPECT_NEAR(s[k].z[3], std::sqrt(squares), 1e-9);
  }
  // The current: wheel rows at 0.15 (step 0.2), 0.3 (0.3), 0.45 (0.5), 0.6 (0.6).
  EXPECT_EQ(s[2].z[1], 11.0);
  EXPECT_EQ(s[3].z[1], 12.0);
  EXPECT_TRUE(std::isnan(s[4].z[1]));
  EXPECT_EQ(s[5].z[1], 13.0);
}

// diff_std(x): the sample standard deviation of the changes between a
// step's consecutive rows. A gyro drifting by 0.001 a row and shaking by
// +-0.01 about the drift changes by 0.021 and -0.019 in turn: over ten rows,
// nine changes, five of one and four of the other, whose sample standard
// deviation is 0.04 sqrt((5 * 16 + 4 * 25) / 81 / 8) by hand. A row left
// out (empty) joins the changes on either side. A steady drift, which
// std(x) counts, changes by as much at every row: none of it is in
// diff_std(x).
TEST(LogReader, DiffStdIsTheSpreadOfTheChangesFromRowToRow) {
  const auto dir = test_directory();
  std::string wheels = "time,velL,velR,cur\n", gyro = "time,wz\n";
  for (int k = 0; k <= 4; ++k) wheels += std::to_string(0.15 * k) + ",0.1,0.2,10\n";
  for (int i = 0; i <= 60; ++i) {
    const double wz = 0.001 * i + (i % 2 == 0 ? 0.01 : -0.01);
    gyro += std::to_string(0.01 * i) + "," + (i == 35 ? std::string() : std::to_string(wz)) + "\n";
  }
  BankConfig bank = two_rate_bank();
  bank.measurement.names = {"shake", "spread"};
  bank.columns.measurements = {"diff_std(wz)", "std(wz)"};
  {
    const TwoRateLog drift = two_rate_log();  // wz = 0.001 i
    SamplingConfig at_10_hz;
    at_10_hz.rate = 10.0;
    LogReader drifting(bank, {drift.wheels, drift.gyro}, at_10_hz);
    const auto steps = read_all(drifting);
    ASSERT_EQ(steps.size(), 7u);
    EXPECT_NEAR(steps[3].z[0], 0.0, 1e-15);
    EXPECT_NEAR(steps[3].z[1], 0.001 * std::sqrt(55.0 / 6.0), 1e-12);
  }
  SamplingConfig sampling;
  sampling.rate = 10.0;
  LogReader reader(bank, {write_file(dir / "wheels.csv", wheels), write_file(dir / "gyro.csv", gyro)}, sampling);
  const auto s = read_all(reader);
  ASSERT_EQ(s.size(), 7u);
  EXPECT_TRUE(std::isnan(s[0].z[0])) << "one row, no change";
  const double by_hand = 0.04 * std::sqrt((5.0 * 16.0 + 4.0 * 25.0) / 81.0 / 8.0);
  for (const std::size_t k : {1u, 2u, 3u, 5u, 6u}) EXPECT_NEAR(s[k].z[0], by_hand, 1e-12) << "step at t = " << s[k].t;
  // Step 4 (rows 31..40) without row 35: the change from 34 to 36 is the
  // drift of two rows, 0.002; the others as before, four of each sign.
  std::vector<double> changes;
  for (int i = 32; i <= 40; ++i) {
    if (i == 35) continue;
    const int from = i == 36 ? 34 : i - 1;
    changes.push_back(0.001 * (i - from) + (i % 2 == 0 ? 0.01 : -0.01) - (from % 2 == 0 ? 0.01 : -0.01));
  }
  double mean = 0.0, m2 = 0.0;
  for (const double c : changes) mean += c / static_cast<double>(changes.size());
  for (const double c : changes) m2 += (c - mean) * (c - mean);
  EXPECT_NEAR(s[4].z[0], std::sqrt(m2 / static_cast<double>(changes.size() - 1)), 1e-12);
}

TEST(LogReader, SeveralValuesInOneStepKeepTheLastAndAreCounted) {
  const TwoRateLog log = two_rate_log();
  SamplingConfig sampling;
  sampling.rate = 10.0;
  LogReader reader(two_rate_bank(), {log.wheels, log.gyro}, sampling);
  const auto s = read_all(reader);
  ASSERT_EQ(s.size(), 7u);
  EXPECT_NEAR(s[3].z[0], 0.030, kTight);  // rows at 0.21 .. 0.30: the last
  EXPECT_EQ(reader.stats().superseded[0], 6 * 9);
  EXPECT_THAT(reader.describe_stats(two_rate_bank()),
              HasSubstr("measurement 'omega': 54 value(s) were replaced by a later one in the same step"));
}

TEST(LogReader, ATimeOffsetShiftsOneFile) {
  const TwoRateLog log = two_rate_log();
  LogReader reader(two_rate_bank(), {LogFile(log.wheels), LogFile(log.gyro, 0.005)});
  const auto s = read_all(reader);
  ASSERT_GT(s.size(), 3u);
  EXPECT_NEAR(s[1].t, 0.005, kTight);  // the gyro's first row, shifted
  EXPECT_NEAR(s[1].z[0], 0.0, kTight);
  EXPECT_TRUE(std::isnan(s[0].z[0]));  // t = 0: the wheels only
}

TEST(LogReader, RowsAfterTheInputsEndAreNotUsed) {
  const auto dir = test_directory();
  const auto wheels = write_file(dir / "w.csv", "time,velL,velR,cur\n0,0,0,1\n0.1,0,0,1\n");
  const auto gyro = write_file(dir / "g.csv", "time,wz\n0.05,1\n0.1,2\n0.15,3\n0.2,4\n");
  LogReader reader(two_rate_bank(), {wheels, gyro});
  const auto s = read_all(reader);
  ASSERT_EQ(s.size(), 3u);
  EXPECT_EQ(s.back().t, 0.1);
  EXPECT_EQ(reader.stats().dropped_after_end, 2);
}

// At 1 Hz the wheels (the inputs) end at 1.9 s, before the grid's step at
// 2 s: the rows gathered for it are not used, and the summary says so; they
// were counted as values replaced within a step, which the filter never saw.
// A file whose rows all fell in that step is not used at all: an error, where
// the rows counted as used.
TEST(LogReader, RowsGatheredForAGridStepPastTheInputsAreCountedAsNotUsed) {
  const auto dir = test_directory();
  const auto wheels =
      write_file(dir / "w.csv", "time,velL,velR,cur\n0,0,0,1\n0.5,0,0,1\n1,0,0,1\n1.5,0,0,1\n1.9,0,0,1\n");
  const auto gyro = write_file(dir / "g.csv", "time,wz\n0.2,1\n1.4,2\n1.6,3\n");
  BankConfig bank = two_rate_bank();
  bank.sampling.rate = 1.0;
  LogReader reader(bank, {wheels, gyro}, bank.sampling);
  const auto s = read_all(reader);
  ASSERT_EQ(s.size(), 2u);
  EXPECT_EQ(s.back().t, 1.0);
  EXPECT_EQ(reader.stats().dropped_last_step, 4) << "the wheels at 1.5 and 1.9 s, the gyro at 1.4 and 1.6 s";
  EXPECT_EQ(reader.stats().superseded[0], 0) << "the gyro's 1.4 s was replaced in a step never taken";
  EXPECT_THAT(reader.describe_stats(bank),
              HasSubstr("4 row(s) after the last step (t = 1 s) were not used: the grid's next step, t = 2 s, is past "
                        "the last row of the inputs (t = 1.9 s)"));
  const auto late = write_file(dir / "late.csv", "time,wz\n1.2,1\n1.4,2\n");
  LogReader unused(bank, {wheels, late}, bank.sampling);
  expect_error(
      [&] { read_all(unused); },
      {"late.csv: none of its 2 row(s) was used: its rows start at t = 1.2 s, after the log's last step at t = "
       "1 s: the grid's next step, t = 2 s, is past the last row of the inputs (t = 1.9 s)"});
}

// A fixed rate steps through gaps in the log: a wrong time stamp (1e9, or
// 1e300) or a long pause must not make it write steps until the disk is full.
TEST(LogReader, AFixedRateRefusesAGapLongerThanMaxGapNamingTheRowAndTheLimit) {
  for (const std::string& jump : {std::string("1e9"), std::string("1e300")}) {
    const auto dir = test_directory();
    const auto file =
        write_file(dir / "log.csv", "t,left,right,v,w\n0,1,2,3,4\n0.1,1,2,3,4\n0.2,1,2,3,4\n" + jump + ",1,2,3,4\n");
    BankConfig bank = simple_bank();
    bank.sampling.rate = 100.0;
    LogReader reader(bank, {file}, bank.sampling);
    const StepsBeforeError read =
        read_until_error(reader, {"log.csv:5: column 't': the log has no row from t = 0.2 to ",
                                  "longer than sampling.max_gap (10 s)", "sampling.skip_gaps: true"});
    EXPECT_EQ(read.steps, 21) << "every step up to the gap is delivered: 0 .. 0.2 s at 100 Hz";
    EXPECT_LT(read.message.size(), 600u);
  }
}

// Rows a day or more apart, or already the log's first rows a long gap
// apart, are more likely stamped in ns, us or ms than a pause: the error
// asks before it offers to skip such gaps, and names columns.time_unit.
TEST(LogReader, AGapOfADayOrMoreAsksWhetherTheStampsAreInSeconds) {
  const std::string asked =
      "Are the time stamps in seconds? (columns.time_unit: ms, us or ns reads them in another unit) If a time "
      "stamp is wrong";
  const auto nanoseconds = write_file(test_directory() / "log.csv",
                                      "t,left,right,v,w\n0,1,2,3,4\n0.1,1,2,3,4\n10000000,1,2,3,4\n20000000,1,2,3,4\n");
  LogReader reader(simple_bank(), {nanoseconds});
  read_until_error(reader, {"a gap of 9999999.9 s", asked});
  // An IMU at 50 Hz stamped in ms: its first rows are 20 "s" apart.
  const auto milliseconds =
      write_file(test_directory() / "log.csv", "t,left,right,v,w\n0,1,2,3,4\n20,1,2,3,4\n40,1,2,3,4\n");
  LogReader ms(simple_bank(), {milliseconds});
  read_until_error(ms, {"a gap of 20 s", asked});
  // Unix time in ms: both ends written alike, not 1.7e+12 beside 1700000000154.
  const auto unix_ms =
      write_file(test_directory() / "log.csv", "t,left,right,v,w\n1700000000000,1,2,3,4\n1700000000154,1,2,3,4\n");
  LogReader epoch(simple_bank(), {unix_ms});
  read_until_error(epoch, {"no row from t = 1700000000000 to 1700000000154 s, a gap of 154 s", asked});
  const auto paused = write_file(test_directory() / "log.csv",
                                 "t,left,right,v,w\n0,1,2,3,4\n0.1,1,2,3,4\n0.2,1,2,3,4\n100.2,1,2,3,4\n");
  LogReader pause(simple_bank(), {paused});
  const StepsBeforeError read = read_until_error(pause, {"a gap of 100 s"});
  EXPECT_THAT(read.message, Not(HasSubstr("seconds?")));
}

// columns.time_unit: a log stamped in ms (or us, ns) gives the steps, times
// in seconds, of the same log stamped in seconds, bit for bit where the
// stamps convert exactly; another unit is an error naming the file's line.
TEST(LogReader, ATimeColumnInAnotherUnitIsReadInSeconds) {
  const auto dir = test_directory();
  const auto seconds = write_file(dir / "s.csv", "t,left,right,v,w\n0,1,2,3,4\n0.25,1,2,3,4\n0.5,2,3,4,5\n1,3,4,5,6\n");
  const auto milliseconds =
      write_file(dir / "ms.csv", "t,left,right,v,w\n0,1,2,3,4\n250,1,2,3,4\n500,2,3,4,5\n1000,3,4,5,6\n");
  LogReader in_seconds(simple_bank(), {seconds});
  BankConfig bank = simple_bank();
  bank.columns.time_units_per_second = 1e3;
  bank.columns.time_unit_name = "ms";
  LogReader in_ms(bank, {milliseconds});
  const auto a = read_all(in_seconds);
  const auto b = read_all(in_ms);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].t, b[k].t) << k;
    EXPECT_EQ(a[k].u, b[k].u) << k;
  }
  const auto bad = write_file(dir / "bad.csv", "t,left,right,v,w\n0,1,2,3,4\nx,1,2,3,4\n");
  LogReader bad_reader(bank, {bad});
  read_until_error(bad_reader, {"bad.csv:3", "a finite time in ms (columns.time_unit)"});
}

TEST(LogReader, SkipGapsRestartsTheGridAfterAGapAndSaysSo) {
  const auto file = write_file(test_directory() / "log.csv",
                               "t,left,right,v,w\n0,1,2,3,4\n0.5,1,2,3,4\n10000000,5,6,7,8\n10000000.5,5,6,7,8\n");
  BankConfig bank = simple_bank();
  bank.sampling.rate = 2.0;
  bank.sampling.skip_gaps = true;
  LogReader reader(bank, {file}, bank.sampling);
  const auto s = read_all(reader);
  ASSERT_EQ(s.size(), 4u);
  EXPECT_EQ(s[1].t, 0.5);
  EXPECT_EQ(s[2].t, 1e7) << "the grid restarts at the row after the gap";
  EXPECT_EQ(s[2].u, Eigen::Vector2d(5, 6));
  EXPECT_EQ(s[3].t, 1e7 + 0.5);
  EXPECT_EQ(reader.stats().gaps_skipped, 1);
  EXPECT_THAT(reader.describe_stats(bank),
              HasSubstr("1 gap(s) without rows longer than sampling.max_gap (10 s) were skipped, 9999999.5 s in all"));
  // Rows 0.5 s apart on a 2 Hz grid leave no step inside a gap of 0.4 s.
  bank.sampling.skip_gaps = false;
  bank.sampling.max_gap = 0.4;
  LogReader strict(bank, {file}, bank.sampling);
  expect_error([&] { read_all(strict); }, {"log.csv:4:", "sampling.max_gap (0.4 s)"});
}

// Stepping at every time stamp, a wrong one (1e308 for the last row) is one
// step, but the row before it would stand for the whole gap in every
// time-weighted score: eval printed a perfect one. The same limit, and the
// same way out.
TEST(LogReader, StepsAtTheTimeStampsRefuseAGapLongerThanMaxGapToo) {
  const auto file =
      write_file(test_directory() / "log.csv", "t,left,right,v,w\n0,1,2,3,4\n0.1,1,2,3,4\n1e308,1,2,3,4\n");
  BankConfig bank = simple_bank();
  ASSERT_EQ(bank.sampling.rate, 0.0);
  {
    LogReader reader(bank, {file}, bank.sampling);
    const StepsBeforeError read =
        read_until_error(reader, {"log.csv:4: column 't': the log has no row from t = 0.1 to 1e+308 s",
                                  "the filter would cross it in one step, and the row before it would stand for the "
                                  "whole gap",
                                  "sampling.skip_gaps: true in the bank to step across such gaps"});
    EXPECT_EQ(read.steps, 2) << "every step before the gap is delivered";
  }
  bank.sampling.skip_gaps = true;
  LogReader reader(bank, {file}, bank.sampling);
  const auto s = read_all(reader);
  ASSERT_EQ(s.size(), 3u);
  EXPECT_EQ(s[2].t, 1e308);
  EXPECT_THAT(reader.describe_stats(bank), HasSubstr("1 gap(s) without rows longer than sampling.max_gap (10 s) were "
                                                     "crossed, 1e+308 s in all: the filter crossed each in one step"));
}

TEST(LogReader, AGridFarFasterThanTheLogsRowsIsRefused) {
  // 8 s at 100 Hz, filtered at 1e6 Hz: 8 million steps for 800 rows.
  std::string text = "t,left,right,v,w\n";
  for (int k = 0; k < 800; ++k) text += std::to_string(0.01 * k) + ",1,2,3,4\n";
  const auto file = write_file(test_directory() / "log.csv", text);
  BankConfig bank = simple_bank();
  bank.sampling.rate = 1e6;
  LogReader reader(bank, {file}, bank.sampling);
  const StepsBeforeError read = read_until_error(
      reader,
      {"log.csv: the filter's rate, 1e+06 Hz (sampling.rate or --rate)", "at most 1000 steps per row", "about 100 Hz"});
  EXPECT_LE(read.steps, 1000 * 3) << "refused within the first rows, not after 8 million steps";
  // 1e4 Hz on the same rows is 100 steps per row: allowed.
  bank.sampling.rate = 1e4;
  LogReader fine(bank, {file}, bank.sampling);
  EXPECT_EQ(read_all(fine).size(), 79901u);
  // Exactly 1000 steps per row, ending with the log: allowed.
  bank.sampling.rate = 1000;
  LogReader exact(bank,
                  {write_file(file.parent_path() / "two_rows.csv", "t,left,right,v,w\n0,1,2,3,4\n1.999,1,2,3,4\n")},
                  bank.sampling);
  EXPECT_EQ(read_all(exact).size(), 2000u);
}

TEST(LogReader, TheRateIsChecked) {
  const auto file = write_file(test_directory() / "log.csv", "t,left,right,v,w\n0,1,2,3,4\n");
  for (double rate : {-1.0, std::nan(""), 1e300, 2e6}) {
    SamplingConfig sampling;
    sampling.rate = rate;
    expect_error([&] { LogReader(simple_bank(), {file}, sampling); }, {"must be in Hz, > 0 and at most 1e6"});
  }
  SamplingConfig sampling;
  sampling.max_gap = 0.0;
  expect_error([&] { LogReader(simple_bank(), {file}, sampling); }, {"sampling.max_gap must be a time in seconds"});
}

// Silent data loss: a file that gives nothing is an error naming it.
TEST(LogReader, AHeaderOnlyFileIsAnErrorNamingItAndItsColumns) {
  const TwoRateLog log = two_rate_log();
  const auto empty_gyro = write_file(log.gyro.parent_path() / "empty_gyro.csv", "time,wz\n");
  LogReader reader(two_rate_bank(), {log.wheels, empty_gyro});
  LogSample s;
  expect_error([&] { reader.next(&s); },
               {"empty_gyro.csv:1: the file has a header but no data rows", "its columns wz, which the bank uses"});
  const auto empty = write_file(log.gyro.parent_path() / "empty.csv", "t,left,right,v,w\r\n");
  LogReader alone(simple_bank(), {empty});
  expect_error([&] { alone.next(&s); }, {"empty.csv:1: the file has a header but no data rows"});
}

// A wrong stamp past the inputs' end (the gyro's line 32 at 57 s where the
// wheels end at 0.6 s) ended the log there, and the gyro's rows after it,
// back at 0.31 s, were only counted as rows after the end: a run lost half
// its IMU with exit 0. Each file's time increases strictly, read or used.
TEST(LogReader, AStampPastTheEndFollowedByOneInsideItIsAnError) {
  const TwoRateLog log = two_rate_log();
  std::string gyro = skidimm_test::read_file(log.gyro);
  const std::string row = std::to_string(0.01 * 30) + ",";
  const std::size_t at = gyro.find("\n" + row);
  ASSERT_NE(at, std::string::npos);
  gyro.replace(at + 1, row.size(), "57,");
  write_file(log.gyro, gyro);
  LogReader reader(two_rate_bank(), {log.wheels, log.gyro});
  const StepsBeforeError read =
      read_until_error(reader, {"gyro.csv:33: column 'time': time must increase strictly, but 0.31 follows 57"});
  EXPECT_EQ(read.steps, 33) << "the steps up to the wheels' end (0.6 s) are delivered, then the error";
}

TEST(LogReader, AFileNoneOfWhoseRowsIsUsedIsAnErrorNamingItAndWhere) {
  const TwoRateLog log = two_rate_log();
  // An offset of 1e6 s: the gyro's rows all come after the wheels end.
  LogReader late(two_rate_bank(), {LogFile(log.wheels), LogFile(log.gyro, 1e6)});
  const StepsBeforeError read = read_until_error(
      late, {"gyro.csv: none of its", "row(s) was used: its rows start at t = 1e+06 s (with its offset of 1e+06 s)",
             "after the log's last step at t = 0.6 s", "FILE@OFFSET"});
  EXPECT_EQ(read.steps, 5) << "the steps of the wheels are delivered first";
  // An offset of -1e6 s: all before the first step.
  LogReader early(two_rate_bank(), {LogFile(log.wheels), LogFile(log.gyro, -1e6)});
  expect_error([&] { read_all(early); }, {"gyro.csv: none of its 61 row(s) was used: its rows end at t = -999999.4 s",
                                          "before the log's first step at t = 0 s"});
  // The same with a fixed rate.
  SamplingConfig sampling;
  sampling.rate = 10;
  LogReader gridded(two_rate_bank(), {LogFile(log.wheels), LogFile(log.gyro, 1e6)}, sampling);
  expect_error([&] { read_all(gridded); }, {"gyro.csv: none of its 61 row(s) was used"});
  // A file whose values are held (here the truth) is used by a row before the first step.
  BankConfig with_truth = two_rate_bank();
  with_truth.columns.truth_mode = "mode";
  const auto truth = write_file(log.wheels.parent_path() / "truth.csv", "time,mode\n-5,ice\n");
  LogReader held(with_truth, {log.wheels, log.gyro, truth});
  const auto held_steps = read_all(held);
  ASSERT_EQ(held_steps.size(), 61u);
  EXPECT_EQ(held_steps.back().truth_mode, "ice");
}

TEST(LogReader, AMeasurementNeverPresentIsSaid) {
  const auto file = write_file(test_directory() / "log.csv", "t,left,right,v,w\n0,1,2,,4\n0.1,1,2,,5\n");
  LogReader reader(simple_bank(), {file});
  EXPECT_EQ(read_all(reader).size(), 2u);
  EXPECT_EQ(reader.stats().measured, (std::vector<long>{0, 2}));
  EXPECT_THAT(reader.describe_stats(simple_bank()), HasSubstr("measurement 'V' (\"v\") had no value at any step"));
}

// Wheels at 20 Hz for 20 s and a gyro at 100 Hz, each written by `keep`
// (which rows of each file to write), on a 2 Hz grid of two_rate_bank()'s
// measurements averaged.
TwoRateLog twenty_seconds(const std::function<bool(double)>& keep_wheel, const std::function<bool(double)>& keep_gyro) {
  const auto dir = test_directory();
  std::string wheels = "time,velL,velR,cur\n", gyro = "time,wz\n";
  for (int k = 0; k <= 400; ++k) {
    const double t = 0.05 * k;
    if (keep_wheel(t)) wheels += std::to_string(t) + ",0.5,0.6,10\n";
  }
  for (int k = 0; k <= 2000; ++k) {
    const double t = 0.01 * k;
    if (keep_gyro(t)) gyro += std::to_string(t) + ",0.1\n";
  }
  return {write_file(dir / "wheels.csv", wheels), write_file(dir / "gyro.csv", gyro)};
}

BankConfig averaged_two_rate_bank() {
  BankConfig bank = two_rate_bank();
  bank.columns.measurements = {"mean(wz)", "mean(cur)"};
  bank.sampling.rate = 2.0;
  return bank;
}

// A sensor that stops, or pauses, while the others go on leaves its
// measurement without values for a stretch far longer than it usually does:
// said, with the longest stretch, by the summary and by unmeasured() (which
// eval and validate --check print). The wheels' current, every step, is not.
TEST(LogReader, AMeasurementThatStopsWhileTheOthersGoOnIsSaid) {
  const TwoRateLog log = twenty_seconds([](double) { return true; },
                                        [](double t) { return !(t > 5.001 && t < 9.999) && t < 15.001; });
  const BankConfig bank = averaged_two_rate_bank();
  LogReader reader(bank, {log.wheels, log.gyro}, bank.sampling);
  ASSERT_EQ(read_all(reader).size(), 41u);  // 0, 0.5, ..., 20 s
  // Steps 5.5 .. 9.5 (9) and 15.5 .. 20 (10) have no gyro row.
  EXPECT_EQ(reader.stats().measured, (std::vector<long>{41 - 19, 41}));
  const std::string line =
      "measurement 'omega' (\"mean(wz)\") had no value from t = 15.5 to 20 s (10 steps in a row, to the log's last "
      "step; 19 of 41 steps without one in all)";
  EXPECT_THAT(reader.describe_stats(bank), HasSubstr(line + ": its filters were not corrected by it there"));
  EXPECT_EQ(reader.unmeasured(bank), std::vector<std::string>{line});
  EXPECT_THAT(reader.describe_stats(bank), Not(HasSubstr("'current'")));

  // Two measurements of the file that stopped: one line.
  BankConfig two = bank;
  two.measurement.names.push_back("omega_rms");
  two.columns.measurements.push_back("rms(wz)");
  LogReader both(two, {log.wheels, log.gyro}, two.sampling);
  read_all(both);
  EXPECT_THAT(both.describe_stats(two),
              HasSubstr("measurements 'omega' (\"mean(wz)\") and 'omega_rms' (\"rms(wz)\") had no value from t = "
                        "15.5 to 20 s (10 steps in a row, to the log's last step; 19 of 41 steps without a value in "
                        "all): the filters were not corrected by them there"));
  EXPECT_EQ(both.unmeasured(two).size(), 1u);

  // Four steps without (under five) are not named; nor is a slow sensor's
  // own spacing: the gyro once a second, every second step.
  for (const auto& keep_gyro : std::vector<std::function<bool(double)>>{
           [](double t) { return !(t > 5.001 && t < 6.999); },
           [](double t) { return std::abs(t - std::round(t)) < 1e-6; }}) {
    const TwoRateLog other = twenty_seconds([](double) { return true; }, keep_gyro);
    LogReader quiet(bank, {other.wheels, other.gyro}, bank.sampling);
    read_all(quiet);
    EXPECT_LT(quiet.stats().measured[0], 41);
    EXPECT_TRUE(quiet.unmeasured(bank).empty()) << quiet.describe_stats(bank);
  }
}

// A file of inputs without rows for longer than sampling.max_gap while the
// other file goes on (so the log has no gap) held its inputs there: said.
TEST(LogReader, AFileOfInputsWithoutRowsLongerThanMaxGapIsSaid) {
  const TwoRateLog log =
      twenty_seconds([](double t) { return !(t > 3.001 && t < 14.999); }, [](double) { return true; });
  const BankConfig bank = averaged_two_rate_bank();
  LogReader reader(bank, {log.wheels, log.gyro}, bank.sampling);
  ASSERT_EQ(read_all(reader).size(), 41u);
  EXPECT_THAT(reader.describe_stats(bank),
              HasSubstr("wheels.csv had no row from t = 3 to 15 s (12 s, longer than sampling.max_gap) while the "
                        "log's other rows went on: the inputs it gives were held at their last values there"));
  // A shorter hole is a slower sensor's business.
  const TwoRateLog shorter =
      twenty_seconds([](double t) { return !(t > 3.001 && t < 12.999); }, [](double) { return true; });
  LogReader quiet(bank, {shorter.wheels, shorter.gyro}, bank.sampling);
  read_all(quiet);
  EXPECT_THAT(quiet.describe_stats(bank), Not(HasSubstr("had no row")));
  // Both files paused together (skip_gaps): a gap of the log, not a hole of one file.
  BankConfig skipping = bank;
  skipping.sampling.skip_gaps = true;
  // The wheels' last row before it at 2.95 s, the gyro's at 3 s.
  const TwoRateLog both = twenty_seconds([](double t) { return !(t > 2.951 && t < 14.999); },
                                         [](double t) { return !(t > 3.001 && t < 14.999); });
  LogReader skipped(skipping, {both.wheels, both.gyro}, skipping.sampling);
  read_all(skipped);
  EXPECT_EQ(skipped.stats().gaps_skipped, 1);
  EXPECT_THAT(skipped.describe_stats(skipping), Not(HasSubstr("had no row")));
}

// A file that fails partway (a time that goes back) stops before the rows the
// next step gathers from it were all read: that step is not delivered, the
// error is, and every step before it was.
TEST(LogReader, AStepAFailedFileMayLackRowsOfIsNotDelivered) {
  const TwoRateLog log = twenty_seconds([](double) { return true; }, [](double) { return true; });
  std::string gyro = "time,wz\n";
  for (const double t : {1.8, 1.9, 1.99, 2.01, 2.0, 2.02}) gyro += std::to_string(t) + ",0.1\n";
  const auto swapped = write_file(log.wheels.parent_path() / "swapped.csv", gyro);
  const BankConfig bank = averaged_two_rate_bank();
  LogReader reader(bank, {log.wheels, swapped}, bank.sampling);
  const StepsBeforeError read =
      read_until_error(reader, {"swapped.csv:6: column 'time': time must increase strictly"});
  // Steps 0 .. 2 s; the step at 2.5 s would have averaged the row at 2.01 s alone.
  EXPECT_EQ(read.steps, 5);
}

TEST(LogReader, TruthAndTrueStatesAreHeldBetweenTheirFilesRows) {
  // The truth comes with the wheel file's rows; the sensor file's rows between them keep it.
  BankConfig bank = simple_bank();
  bank.columns.truth_mode = "mode";
  const auto dir = test_directory();
  const auto wheels = write_file(dir / "wheels.csv", "t,left,right,mode,true_V\n0,1,2,ice,0.5\n0.2,1,2,snow,\n");
  const auto sensors = write_file(dir / "sensors.csv", "t,v,w\n0.1,3,4\n0.15,3,4\n0.2,3,4\n");
  LogReader reader(bank, {wheels, sensors});
  ASSERT_TRUE(reader.has_truth());
  ASSERT_TRUE(reader.has_true_states());
  const auto s = read_all(reader);
  ASSERT_EQ(s.size(), 4u);
  EXPECT_EQ(s[1].truth_mode, "ice");
  EXPECT_EQ(s[2].truth_mode, "ice");
  EXPECT_EQ(s[3].truth_mode, "snow");
  EXPECT_EQ(s[3].true_state[0], 0.5) << "an empty true_<state> cell keeps the last value";
  EXPECT_TRUE(std::isnan(s[1].true_state[1]));
}

TEST(LogReader, ABlankTruthCellIsUnlabelledUnlessTheBankCarriesIt) {
  BankConfig bank = simple_bank();
  bank.columns.truth_mode = "mode";
  const auto file = write_file(test_directory() / "log.csv", "t,left,right,v,w,mode\n0,1,2,,,ice\n0.1,1,2,,,\n");
  LogReader unlabelled(bank, {file});
  const auto s = read_all(unlabelled);
  ASSERT_EQ(s.size(), 2u);
  EXPECT_EQ(s[0].truth_mode, "ice");
  EXPECT_EQ(s[1].truth_mode, "") << "a blank truth cell is no label, not the last one";
  bank.columns.carry_truth = true;  // columns.truth_blank: carry
  LogReader carried(bank, {file});
  EXPECT_EQ(read_all(carried)[1].truth_mode, "ice");
}

TEST(LogReader, SideBySideFilesMustMatchRowForRow) {
  const auto dir = test_directory();
  const auto a = write_file(dir / "a.csv", "t,left,right\n0,1,2\n0.1,1,2\n");
  const auto b = write_file(dir / "b.csv", "v,w\n3,4\n");
  BankConfig bank = simple_bank();
  bank.sampling.join = SamplingConfig::Join::kRows;
  LogReader reader(bank, {a, b});
  LogSample s;
  ASSERT_TRUE(reader.next(&s));
  EXPECT_EQ(s.z, Eigen::Vector2d(3, 4));
  expect_error([&] { reader.next(&s); }, {"a.csv:3", "must match row for row", "b.csv has ended"});
  // An offset on the file without the time was ignored; on the timed one it shifts every row.
  expect_error(
      [&] {
        LogReader(bank, {a, LogFile(b, 5.0)});
      },
      {"b.csv: an offset (@5) on a file without the log's time: with sampling.join: rows every file takes "
       "the time of " +
       a.string() + ", so put the offset there"});
  LogReader shifted(bank, {LogFile(a, 5.0), b});
  ASSERT_TRUE(shifted.next(&s));
  EXPECT_EQ(s.t, 5.0);
}

TEST(LogReader, AFileWithoutTheTimeColumnSaysHowToJoinByRows) {
  const auto dir = test_directory();
  const auto a = write_file(dir / "a.csv", "t,left,right\n0,1,2\n");
  const auto b = write_file(dir / "b.csv", "v,w\n3,4\n");
  expect_error([&] { LogReader(simple_bank(), {a, b}); },
               {"b.csv:1: no time column 't'", "sampling.join: rows"});
  // A multi-rate log whose second file stamps under its own name: that it needs the bank's column and unit.
  const auto imu = write_file(dir / "imu.csv", "t_ns,w\n0,4\n");
  expect_error(
      [&] {
        LogReader(simple_bank(), {a, imu});
      },
      {"imu.csv:1: no time column 't'",
       "the one the bank names in the unit it reads (columns.time, "
       "columns.time_unit): a file that stamps under another name or unit "
       "needs that column renamed or converted"});
  // One file alone: no word of joining files.
  const std::string alone = expect_error([&] { LogReader(simple_bank(), {imu}); }, {"no time column 't'"});
  EXPECT_EQ(alone.find("sampling.join"), std::string::npos) << alone;
}

TEST(LogReader, ColumnProblemsAreNamedBeforeAnyRowIsRead) {
  const TwoRateLog log = two_rate_log();
  BankConfig bank = two_rate_bank();
  bank.columns.inputs[0] = "velR - velLeft";
  expect_error([&] { LogReader(bank, {log.wheels, log.gyro}); },
               {"no column 'velLeft' (the bank's columns.inputs.dv)", "columns present: time, velL, velR, cur"});
  // Each file's columns named by the file (an IMU column was reported missing
  // from the wheels' file in one list of both), and a name with a space at
  // either end quoted, where ", velL" hid it.
  bank = two_rate_bank();
  bank.columns.measurements[0] = "wzz";
  expect_error(
      [&] {
        LogReader(bank, {log.wheels, log.gyro});
      },
      {"no column 'wzz' (the bank's columns.measurements.omega) in any file of the log; columns present: "
       "time, velL, velR, cur (wheels.csv); time, wz (gyro.csv)"});
  const auto spaced = write_file(log.wheels.parent_path() / "spaced.csv", "time, velL, velR,cur\n0,1,2,3\n");
  expect_error(
      [&] {
        LogReader(two_rate_bank(), {spaced, log.gyro});
      },
      {"columns present: time, ' velL', ' velR', cur (spaced.csv)"});
  bank = two_rate_bank();
  bank.columns.inputs[1] = "abs(velL +* velR)";
  expect_error(
      [&] {
        LogReader(bank, {log.wheels, log.gyro});
      },
      {"bank.yaml: columns.inputs.speed: cannot parse \"abs(velL +* velR)\": Unexpected operator \"*\" "
       "found at character 11"});
  bank.columns.inputs[1] = "abs(velL + velR))";
  expect_error(
      [&] {
        LogReader(bank, {log.wheels, log.gyro});
      },
      {"bank.yaml: columns.inputs.speed: cannot parse \"abs(velL + velR))\": a ')' without its '(' at "
       "character 17"});
  bank = two_rate_bank();
  bank.columns.measurements[0] = "wz - cur";
  expect_error([&] { LogReader(bank, {log.wheels, log.gyro}); },
               {"columns.measurements.omega", "uses columns of different files", "wz (gyro.csv)", "cur (wheels.csv)"});
  bank = two_rate_bank();
  bank.columns.measurements[0] = "mean(wz)";
  expect_error([&] { LogReader(bank, {log.wheels, log.gyro}); },
               {"columns.measurements.omega", "needs a fixed step: set sampling.rate"});
  bank.sampling.rate = 10;
  bank.columns.measurements[0] = "mean(wz) + cur";
  expect_error(
      [&] {
        LogReader(bank, {log.wheels, log.gyro}, bank.sampling);
      },
      {"uses column 'cur' outside mean(), std(), rms() or diff_std()"});
  bank.columns.measurements[0] = "mean(std(wz))";
  expect_error(
      [&] {
        LogReader(bank, {log.wheels, log.gyro}, bank.sampling);
      },
      {"bank.yaml: columns.measurements.omega", "std() inside mean()"});
  // The same column in two files is ambiguous.
  const auto other = write_file(log.wheels.parent_path() / "other.csv", "time,wz\n0,1\n");
  expect_error([&] { LogReader(two_rate_bank(), {log.wheels, log.gyro, other}); },
               {"column 'wz'", "is also in", "must be in one file of the log"});
}

// Expressions are a closed language (expression.h): what muparser would
// otherwise accept (an assignment, a list, a NUL ending the text early) or
// the reader's own names for its aggregates are refused, naming the bank
// file and the field, quoting at most a short excerpt.
TEST(LogReader, ExpressionsOutsideTheLanguageAreRefusedNamingFileAndField) {
  const TwoRateLog log = two_rate_log();
  const struct {
    bool measurement;
    std::string text;
    std::string says;
  } cases[] = {
      {false, "velL = 3", "assignment ('=')"},
      {false, "velL, velR", "a ',' outside the arguments of min() or max()"},
      {false, std::string("velL\0+1", 7), "a control character (byte 0)"},
      {false, "velL * _pi", "names starting with '_' are reserved"},
      {true, "mean(wz) + _skidimm_step99", "'_skidimm_step99': names starting with '_' are reserved"},
      {true, "mean(wz) + _call0", "names starting with '_' are reserved"},
      {true, "mean((wz)", "unbalanced parentheses"},
      {true, "sum(wz, wz)", "unknown function 'sum'"},
  };
  for (const auto& c : cases) {
    BankConfig bank = two_rate_bank();
    bank.sampling.rate = 10;
    (c.measurement ? bank.columns.measurements[0] : bank.columns.inputs[0]) = c.text;
    const std::string field = c.measurement ? "columns.measurements.omega" : "columns.inputs.dv";
    expect_error([&] { LogReader(bank, {log.wheels, log.gyro}, bank.sampling); }, {"bank.yaml: " + field, c.says});
  }
  // A name alone is a column, with '_' or not: a missing one is said so.
  BankConfig internal = two_rate_bank();
  internal.columns.measurements[0] = "_skidimm_stepX";
  expect_error(
      [&] {
        LogReader(internal, {log.wheels, log.gyro});
      },
      {"no column '_skidimm_stepX' (the bank's columns.measurements.omega)"});
  // A 10 MB expression: refused by its length, quoted by a short excerpt.
  BankConfig bank = two_rate_bank();
  bank.columns.inputs[0] = "velL" + std::string(10'000'000, '+');
  const std::string message = expect_error(
      [&] {
        LogReader(bank, {log.wheels, log.gyro});
      },
      {"bank.yaml: columns.inputs.dv", "more than an expression may have"});
  EXPECT_LT(message.size(), 300u);
}

TEST(LogReader, AnAggregateMayTakeAColumnWhoseNameIsNoIdentifier) {
  const auto dir = test_directory();
  const auto wheels = write_file(dir / "w.csv", "time,velL,velR,cur\n0,0,0,1\n0.1,0,0,1\n0.2,0,0,1\n");
  const auto imu = write_file(dir / "i.csv", "time,imu.wz\n0.05,1\n0.1,3\n0.15,5\n0.2,7\n");
  BankConfig bank = two_rate_bank();
  bank.columns.measurements[0] = "2 * mean(imu.wz)";
  bank.sampling.rate = 10;
  LogReader reader(bank, {wheels, imu}, bank.sampling);
  const auto s = read_all(reader);
  ASSERT_EQ(s.size(), 3u);
  EXPECT_EQ(s[1].z[0], 4.0);
  EXPECT_EQ(s[2].z[0], 12.0);
}

TEST(LogReader, ANonFiniteInputNamesItsExpressionAndValues) {
  BankConfig bank = simple_bank();
  bank.columns.inputs[0] = "1 / left";
  const auto file = write_file(test_directory() / "log.csv", "t,left,right,v,w\n0,1,2,,\n0.1,0,2,,\n");
  LogReader reader(bank, {file});
  LogSample s;
  ASSERT_TRUE(reader.next(&s));
  expect_error([&] { reader.next(&s); },
               {"log.csv", "input 'phi_dot_L' = \"1 / left\" is not finite at t = 0.1", "left = 0"});
}

TEST(LogReader, ANonFiniteMeasurementIsMissingAndCounted) {
  BankConfig bank = simple_bank();
  bank.columns.measurements[0] = "log(v)";
  const auto file = write_file(test_directory() / "log.csv", "t,left,right,v,w\n0,1,2,0,\n0.1,1,2,1,\n");
  LogReader reader(bank, {file});
  const auto s = read_all(reader);
  ASSERT_EQ(s.size(), 2u);
  EXPECT_TRUE(std::isnan(s[0].z[0]));
  EXPECT_EQ(s[1].z[0], 0.0);
  EXPECT_EQ(reader.stats().not_finite[0], 1);
}

// Rows whose cell an aggregate cannot take (empty, nan) are left out of it,
// and a step left with too few rows has no value: both are counted and said,
// where a dropped sensor axis would otherwise pass unnoticed. A step with no
// rows of the file at all is not counted (a slower sensor says nothing of
// its cells).
TEST(LogReader, RowsLeftOutOfAnAggregateAreCountedAndSaid) {
  BankConfig bank = simple_bank();
  bank.columns.measurements = {"mean(v)", "log(std(w))"};
  // Steps of 0.1 s (the rows after 0 up to 0.1 form the step at 0.1): v is nan
  // in every row of the step at 0.2 and in one row of the step at 0.3; w is
  // empty in one row of the step at 0.3, where std() still has two rows.
  std::string text = "t,left,right,v,w\n";
  const std::vector<std::string> v{"1", "2", "3", "nan", "nan", "nan", "4", "nan", "6"};
  const std::vector<std::string> w{"1", "2", "4", "1", "2", "4", "1", "", "4"};
  const std::vector<std::string> t{"0.04", "0.07", "0.1", "0.14", "0.17", "0.2", "0.24", "0.27", "0.3"};
  text += "0,1,2,0,0\n";
  for (std::size_t r = 0; r < v.size(); ++r) text += t[r] + ",1,2," + v[r] + "," + w[r] + "\n";
  const auto file = write_file(test_directory() / "log.csv", text);
  SamplingConfig sampling;
  sampling.rate = 10.0;
  LogReader reader(bank, {file}, sampling);
  const auto s = read_all(reader);
  ASSERT_EQ(s.size(), 4u);
  EXPECT_EQ(s[1].z[0], 2.0);
  EXPECT_TRUE(std::isnan(s[2].z[0])) << "every v of the step is nan";
  EXPECT_EQ(s[3].z[0], 5.0) << "the mean of the two v that are numbers";
  EXPECT_NEAR(s[3].z[1], std::log(std::sqrt(4.5)), 1e-12) << "std of w = 1 and 4";
  EXPECT_EQ(reader.stats().left_out_of_aggregates, (std::vector<long>{4, 1}));
  EXPECT_EQ(reader.stats().steps_without_enough_rows, (std::vector<long>{1, 0}));
  const std::string said = reader.describe_stats(bank);
  EXPECT_THAT(said, HasSubstr("measurement 'V' (\"mean(v)\"): 4 row value(s) were left out of its aggregates (an "
                              "empty or nan cell, or not finite inside mean/std/rms); 1 step(s) were left with too few "
                              "rows and count as missing"));
  EXPECT_THAT(said, HasSubstr("measurement 'omega' (\"log(std(w))\"): 1 row value(s) were left out of its "
                              "aggregates (an empty or nan cell, or not finite inside mean/std/rms)\n"));
}

TEST(LogReader, NonNumericCellNamesLineAndColumn) {
  const auto file = write_file(test_directory() / "log.csv", "t,left,right,v,w\n0,1,2,3,4\n0.1,1,fast,3,4\n");
  LogReader reader(simple_bank(), {file});
  LogSample s;
  reader.next(&s);
  expect_error([&] { reader.next(&s); },
               {"log.csv:3: column 3 ('right'): expected a finite number (or an empty cell, nan or NA for none), got "
                "'fast'"});
}

// A leading '+' is a sign, once: "+-1" was read as -1.
TEST(LogReader, APlusSignIsReadOnceAndTwoSignsAreNotANumber) {
  const auto dir = test_directory();
  LogReader reader(simple_bank(), {write_file(dir / "log.csv", "t,left,right,v,w\n0,1,2,+3.5,4\n0.1,1,2,+-1,4\n")});
  LogSample s;
  ASSERT_TRUE(reader.next(&s));
  EXPECT_EQ(s.z[0], 3.5);
  expect_error([&] { reader.next(&s); }, {"log.csv:3: column 4 ('v'): expected a finite number", "got '+-1'"});
  for (const std::string cell : {"++1", "+", "-+1"}) {
    LogReader twice(simple_bank(), {write_file(dir / "twice.csv", "t,left,right,v,w\n0,1,2," + cell + ",4\n")});
    LogSample first;
    expect_error([&] { twice.next(&first); }, {"got '" + cell + "'"});
  }
}

TEST(LogReader, SubnormalCellsAreReadAsTheNearestDoubleAndOverflowIsAnError) {
  const auto dir = test_directory();
  LogReader reader(simple_bank(), {write_file(dir / "log.csv", "t,left,right,v,w\n0,1,2,1e-320,4\n0.1,1,2,1e400,4\n")});
  LogSample s;
  ASSERT_TRUE(reader.next(&s));
  EXPECT_EQ(s.z[0], 1e-320);
  EXPECT_GT(s.z[0], 0.0) << "subnormal, not flushed to zero";
  expect_error([&] { reader.next(&s); }, {"log.csv:3: column 4 ('v'): expected a finite number", "got '1e400'"});
}

TEST(LogReader, ReadsAPipeAsItArrivesAndStandardInputByDash) {
  int fds[2];
  ASSERT_EQ(::pipe(fds), 0);
  const std::string head = "t,left,right,v,w\n0,1,2,3,4\n";
  ASSERT_EQ(::write(fds[1], head.data(), head.size()), static_cast<ssize_t>(head.size()));
  // The write end stays open: the reader must give the first step without
  // waiting for a second row (it reads the next row only when asked).
  LogReader reader(simple_bank(), {"/dev/fd/" + std::to_string(fds[0])});
  LogSample s;
  ASSERT_TRUE(reader.next(&s));
  EXPECT_EQ(s.t, 0.0);
  const std::string rest = "0.1,1,2,5,4\n";
  ASSERT_EQ(::write(fds[1], rest.data(), rest.size()), static_cast<ssize_t>(rest.size()));
  ::close(fds[1]);
  ASSERT_TRUE(reader.next(&s));
  EXPECT_EQ(s.z[0], 5.0);
  EXPECT_FALSE(reader.next(&s));
  ::close(fds[0]);
  EXPECT_FALSE(is_rereadable("-"));
  EXPECT_FALSE(is_rereadable("/dev/stdin"));
  EXPECT_TRUE(is_standard_input("-"));
  expect_error([&] { LogReader twice(simple_bank(), {"-", "-"}); },
               {"standard input ('-') can be one file of a log, not several"});
}

// A writer that opens both FIFOs of a two-file log before writing to either
// (as a recorder streaming two sensors does) is read: the log waits for
// neither FIFO's header while the writer waits for the other FIFO's reader.
// Should the reader wait after all, the test opens the second FIFO itself
// after 20 s so that nothing hangs, and fails.
TEST(LogReader, FifosTheirWriterOpensTogetherAreRead) {
  const TwoRateLog files = two_rate_log();
  const auto dir = files.wheels.parent_path();
  const std::filesystem::path wheels = dir / "wheels.fifo", gyro = dir / "gyro.fifo";
  ASSERT_EQ(::mkfifo(wheels.c_str(), 0600), 0);
  ASSERT_EQ(::mkfifo(gyro.c_str(), 0600), 0);
  const auto text = [](const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  const std::string wheel_rows = text(files.wheels), gyro_rows = text(files.gyro);
  std::thread writer([&] {
    const int a = ::open(wheels.c_str(), O_WRONLY);
    const int b = ::open(gyro.c_str(), O_WRONLY);
    if (a >= 0) {
      EXPECT_EQ(::write(a, wheel_rows.data(), wheel_rows.size()), static_cast<ssize_t>(wheel_rows.size()));
    }
    if (b >= 0) {
      EXPECT_EQ(::write(b, gyro_rows.data(), gyro_rows.size()), static_cast<ssize_t>(gyro_rows.size()));
    }
    if (a >= 0) ::close(a);
    if (b >= 0) ::close(b);
  });
  auto steps = std::async(std::launch::async, [&] {
    LogReader reader(two_rate_bank(), {wheels, gyro});
    return read_all(reader).size();
  });
  if (steps.wait_for(std::chrono::seconds(20)) != std::future_status::ready) {
    ADD_FAILURE() << "the reader waited for a header its writer could not write";
    // A reader of the second FIFO lets the writer on; a writer that opens and
    // closes it lets the log's own open of it return (and read it empty).
    const int unblock = ::open(gyro.c_str(), O_RDONLY | O_NONBLOCK);
    writer.join();
    while (steps.wait_for(std::chrono::milliseconds(100)) != std::future_status::ready) {
      const int w = ::open(gyro.c_str(), O_WRONLY | O_NONBLOCK);
      if (w >= 0) ::close(w);
    }
    if (unblock >= 0) ::close(unblock);
    return;
  }
  writer.join();
  LogReader from_files(two_rate_bank(), {files.wheels, files.gyro});
  EXPECT_EQ(steps.get(), read_all(from_files).size());
}

TEST(LogReader, TimeMustIncreaseStrictly) {
  const auto file = write_file(test_directory() / "log.csv", "t,left,right,v,w\n0,1,2,3,4\n0.5,1,2,3,4\n0.5,1,2,3,4\n");
  LogReader reader(simple_bank(), {file});
  LogSample s;
  ASSERT_TRUE(reader.next(&s));
  ASSERT_TRUE(reader.next(&s)) << "every step before the bad row is delivered";
  expect_error([&] { reader.next(&s); }, {"log.csv:4: column 't': time must increase strictly, but 0.5 follows 0.5"});
}

// A row written twice, or a stamp out of order, is an error that says how to
// leave such rows out; with sampling.skip_out_of_order the reader gives the
// steps of the file without them, and counts them.
TEST(LogReader, RowsOutOfOrderAreLeftOutWhenTheBankSaysSo) {
  const std::string header = "t,left,right,v,w\n";
  const std::string clean_rows = "0,1,2,3,4\n0.5,1,2,3,4\n1,5,6,7,8\n1.5,1,2,3,4\n";
  const auto dir = test_directory();
  const auto messy = write_file(dir / "messy.csv", header +
                                                       "0,1,2,3,4\n0.5,1,2,3,4\n0.5,1,2,3,4\n"
                                                       "0.2,9,9,9,9\n1,5,6,7,8\n1.5,1,2,3,4\n");
  const auto clean = write_file(dir / "clean.csv", header + clean_rows);
  BankConfig bank = simple_bank();
  LogReader strict(bank, {messy}, bank.sampling);
  read_until_error(strict, {"messy.csv:4: column 't': time must increase strictly, but 0.5 follows 0.5. If the row "
                            "repeats an earlier one or was written out of order, sampling.skip_out_of_order: true in "
                            "the bank leaves out each row whose time is not after its file's last"});
  bank.sampling.skip_out_of_order = true;
  LogReader lenient(bank, {messy}, bank.sampling);
  LogReader reference(bank, {clean}, bank.sampling);
  const auto read = read_all(lenient);
  const auto expected = read_all(reference);
  ASSERT_EQ(read.size(), expected.size());
  for (std::size_t k = 0; k < read.size(); ++k) {
    EXPECT_EQ(read[k].t, expected[k].t);
    EXPECT_EQ(read[k].u, expected[k].u);
    EXPECT_EQ(read[k].z, expected[k].z);
  }
  EXPECT_EQ(lenient.stats().out_of_order_skipped, 2);
  EXPECT_THAT(lenient.describe_stats(bank),
              HasSubstr("2 row(s) whose time was not after their file's last row were left out "
                        "(sampling.skip_out_of_order), the first at "));
  EXPECT_THAT(lenient.describe_stats(bank), HasSubstr("messy.csv:4: t = 0.5 after 0.5"));
  EXPECT_EQ(reference.describe_stats(bank).find("out of order"), std::string::npos);
}

TEST(LogReader, ABinaryFileGivesAShortPrintableError) {
  std::string garbage(3000, '\0');
  for (std::size_t i = 0; i < garbage.size(); ++i) garbage[i] = static_cast<char>((i * 37 + 11) % 256);
  const auto file = write_file(test_directory() / "binary.csv", garbage);
  const std::string message = expect_error([&] { LogReader(simple_bank(), {file}); }, {"no time column 't'"});
  EXPECT_LT(message.size(), 900u);
  for (unsigned char c : message.substr(message.find("present:"))) EXPECT_TRUE(c >= 32 && c < 127) << int(c);
}

// A spreadsheet's export with ';' or tabs between values reads as one
// column: the error says the file is not comma-separated, in a log's first
// file (its time column) and in a second one (a column it should hold). A
// header that only holds a ';' (a note above the header, a column named
// with one) is no such file.
TEST(LogReader, AFileSeparatedByAnotherCharacterIsSaidToBeSo) {
  const auto dir = test_directory();
  const auto semicolons = write_file(dir / "semicolons.csv", "t;left;right;v;w\n0;1;2;3;4\n0,5;1;2;3;4\n");
  expect_error([&] { LogReader(simple_bank(), {semicolons}); },
               {"semicolons.csv:1: no time column 't'",
                ". Its header holds 't' between ';': the file is not comma-separated, which is what skidimm "
                "reads; write it with commas between values and points as decimal marks"});
  const auto tabs = write_file(dir / "tabs.csv", "\"t\"\t\"left\"\tright\tv\tw\n0\t1\t2\t3\t4\n");
  expect_error([&] { LogReader(simple_bank(), {tabs}); }, {"Its header holds 't' between tabs"});
  // A ';'-separated header with a comma in one of its names reads as two columns.
  const auto comma = write_file(dir / "comma.csv", "t;left;right;v;w;note, free text\n0;1;2;3;4;a\n");
  expect_error([&] { LogReader(simple_bank(), {comma}); }, {"Its header holds 't' between ';'"});
  const auto excel = write_file(dir / "excel.csv", "sep=;\nt;left;right;v;w\n0;1;2;3;4\n");
  expect_error([&] { LogReader(simple_bank(), {excel}); },
               {"Its first line, 'sep=;', is a spreadsheet's separator line"});
  const auto excel_commas = write_file(dir / "excel_commas.csv", "sep=,\nt,left,right,v,w\n0,1,2,3,4\n");
  expect_error([&] { LogReader(simple_bank(), {excel_commas}); },
               {"Its first line, 'sep=,', is a spreadsheet's separator line, not the header: delete that line"});
  // Joined row for row, the second file's columns are missing, not its time.
  BankConfig rows = simple_bank();
  rows.sampling.join = SamplingConfig::Join::kRows;
  const auto wheels = write_file(dir / "wheels.csv", "t,left,right\n0,1,2\n0.5,1,2\n");
  const auto odometry = write_file(dir / "odometry.csv", "v;w\n3;4\n3;4\n");
  expect_error(
      [&] {
        LogReader(rows, {wheels, odometry});
      },
      {"no column 'v'", "Its header holds 'v' between ';'", "(odometry.csv)"});
  // A header that holds ';' without the column: no hint.
  for (const std::string header : {"time", "# recorded 2024-05-01; robot husky", "time;left"}) {
    const auto file = write_file(dir / "other.csv", header + "\n0\n");
    const std::string message = expect_error([&] { LogReader(simple_bank(), {file}); }, {"no time column 't'"});
    EXPECT_EQ(message.find("not comma-separated"), std::string::npos) << message;
  }
  const auto named = write_file(dir / "named.csv", "v;w\n3\n3\n");
  const std::string message = expect_error([&] { LogReader(rows, {wheels, named}); }, {"no column 'v'"});
  EXPECT_NE(message.find("Its header holds 'v' between ';'"), std::string::npos) << message;
  const auto odd = write_file(dir / "odd.csv", "om;ega\n3\n3\n");
  const std::string unrelated = expect_error([&] { LogReader(rows, {wheels, odd}); }, {"no column 'v'"});
  EXPECT_EQ(unrelated.find("not comma-separated"), std::string::npos) << unrelated;
}

// A robot's sensors logged a file each: one of a run's files read alone
// lacks the others' columns, and the error names the file beside it that has
// the missing one, and how to read the two together (a folder of such runs
// read file by file). Only a file of the same run number: not another run's,
// not one whose number only ends the same.
TEST(LogReader, AColumnInAnotherFileOfTheSameRunIsPointedTo) {
  // A folder of run 07's wheels and `partner`, beside other runs' odometry.
  const auto folder_with = [](const std::string& name, const std::string& partner, const std::string& header) {
    const auto dir = test_directory() / name;
    std::filesystem::create_directories(dir);
    write_file(dir / partner, header + "\n0,3,4\n0.5,3,4\n");
    write_file(dir / "odometry_107.csv", "t,v,w\n0,3,4\n");
    write_file(dir / "odometry_08.csv", "t,v,w\n0,3,4\n");
    return write_file(dir / "wheels_07.csv", "t,left,right\n0,1,2\n0.5,1,2\n");
  };
  const auto wheels = folder_with("split_runs", "odometry_07.csv", "t,v,w");
  const std::string folder = wheels.parent_path().string() + "/";
  expect_error([&] { LogReader(simple_bank(), {wheels}); },
               {"wheels_07.csv:1: no column 'v'",
                ". odometry_07.csv beside it has column 'v': name a run's files together, '" + folder +
                    "wheels_07.csv+" + folder + "odometry_07.csv' (every run of the folder: '" + folder +
                    "wheels_*.csv+" + folder + "odometry_*.csv')"});
  // The run's other file lacks the column too: nothing to point to.
  const auto lone = folder_with("alone", "imu_07.csv", "t,ax,ay");
  const std::string message = expect_error([&] { LogReader(simple_bank(), {lone}); }, {"no column 'v'"});
  EXPECT_EQ(message.find("beside it"), std::string::npos) << message;
}

// A log in which an input never has a value gives no step: the reader names
// the column (a header alone was already refused, as a file with no rows).
TEST(LogReader, AnInputWithoutAValueInAnyRowIsNamed) {
  const auto dir = test_directory();
  const auto file = write_file(dir / "empty_right.csv", "t,left,right,v,w\n0,1,,3,4\n0.5,1,,3,4\n");
  LogSample s;
  LogReader reader(simple_bank(), {file});
  expect_error([&] { reader.next(&s); },
               {"empty_right.csv: no step: column 'right' (input phi_dot_R) had no value in any of the log's 2 "
                "row(s), and a step needs every input"});
  // A column two inputs read is named once, with both (one name inside the other).
  BankConfig both = simple_bank();
  both.input_names = {"turnx", "turn"};
  both.columns.inputs = {"right", "right * 2"};
  LogReader shared(both, {file});
  expect_error([&] { shared.next(&s); }, {"no step: column 'right' (inputs turnx, turn) had no value"});
  const auto header = write_file(dir / "header.csv", "t,left,right,v,w\n");
  LogReader empty(simple_bank(), {header});
  expect_error([&] { empty.next(&s); }, {"header.csv:1: the file has a header but no data rows"});
}

// A driver that leaves header.stamp unset writes 0 in every message: the
// error says so and how to read the bag's log time instead. Other repeated
// times get no such hint.
TEST(LogReader, UnsetStampsAreSaidToBeSo) {
  const auto dir = test_directory();
  BankConfig bank = simple_bank();
  bank.columns.time = "header.stamp";
  const auto zero = write_file(dir / "zero.csv", "header.stamp,left,right,v,w\n0,1,2,3,4\n0,1,2,3,4\n");
  LogSample s;
  LogReader reader(bank, {zero});
  expect_error([&] { read_all(reader); },
               {"time must increase strictly, but 0 follows 0 (the topic's header.stamp is unset, 0, in its messages: "
                "columns.time: log_time reads when the bag recorded each)"});
  const auto repeated = write_file(dir / "repeated.csv", "header.stamp,left,right,v,w\n1,1,2,3,4\n1,1,2,3,4\n");
  LogReader other(bank, {repeated});
  const std::string message = expect_error([&] { read_all(other); }, {"but 1 follows 1"});
  EXPECT_EQ(message.find("unset"), std::string::npos) << message;
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

// BorealTC: wheel speeds and currents at 6.5 Hz, the IMU at 100 Hz, one clock.
TEST(RealBorealTcData, MultiRateRunsMergeAtTheImuRateAndAverageAtAFixedRate) {
  const std::string dir = kBorealDir + "/ICE";
  if (!std::filesystem::exists(dir)) GTEST_SKIP() << "no shared data at " << dir;
  BankConfig bank;
  bank.file = "bank.yaml";
  bank.state_names = {"omega", "current"};
  bank.input_names = {"dv"};
  bank.measurement.names = {"omega", "current"};
  bank.columns.time = "time";
  bank.columns.inputs = {"velR - velL"};
  bank.columns.measurements = {"wz", "curL + curR"};
  LogReader events(bank, {dir + "/pro_02.csv", dir + "/imu_02.csv"});
  const auto s = read_all(events);
  long gyro = 0, current = 0;
  for (const LogSample& x : s) {
    gyro += !std::isnan(x.z[0]);
    current += !std::isnan(x.z[1]);
  }
  // Every current row (366 of them, 2/13 s apart) and every IMU row within the wheels' span arrive.
  EXPECT_EQ(current, 366);
  EXPECT_GT(gyro, 5500);
  EXPECT_EQ(events.stats().rows[0], 366);

  bank.columns.measurements = {"mean(wz)", "mean(curL + curR)"};
  SamplingConfig two_hertz;
  two_hertz.rate = 2.0;
  LogReader averaged(bank, {dir + "/pro_02.csv", dir + "/imu_02.csv"}, two_hertz);
  const auto a = read_all(averaged);
  EXPECT_NEAR(static_cast<double>(a.size()), 56.15 * 2.0, 2.0);
  long complete = 0;
  for (std::size_t k = 1; k < a.size(); ++k) complete += a[k].z.allFinite();
  EXPECT_EQ(complete, static_cast<long>(a.size()) - 1) << "every 0.5 s step has gyro and current rows";
}

}  // namespace
}  // namespace skidimm
