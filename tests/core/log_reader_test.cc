#include "skidimm/log_reader.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>

#include "core/temp_files.h"
#include "skidimm/errors.h"
#include "skidimm/imm.h"
#include "skidimm/log_io.h"

namespace skidimm {
namespace {

using skidimm_test::test_directory;
using skidimm_test::write_file;
using ::testing::HasSubstr;

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
  expect_error([] { parse_log_spec("=a.csv"); }, {"empty label"});
  expect_error([] { parse_log_spec("ice=+"); }, {"no file given"});
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
}

TEST(LogReader, AFileWithoutTheTimeColumnSaysHowToJoinByRows) {
  const auto dir = test_directory();
  const auto a = write_file(dir / "a.csv", "t,left,right\n0,1,2\n");
  const auto b = write_file(dir / "b.csv", "v,w\n3,4\n");
  expect_error([&] { LogReader(simple_bank(), {a, b}); },
               {"b.csv:1: no time column 't'", "sampling.join: rows"});
}

TEST(LogReader, ColumnProblemsAreNamedBeforeAnyRowIsRead) {
  const TwoRateLog log = two_rate_log();
  BankConfig bank = two_rate_bank();
  bank.columns.inputs[0] = "velR - velLeft";
  expect_error([&] { LogReader(bank, {log.wheels, log.gyro}); },
               {"no column 'velLeft' (the bank's columns.inputs.dv)", "columns present: time, velL, velR, cur"});
  bank = two_rate_bank();
  bank.columns.inputs[1] = "abs(velL +* velR)";
  expect_error([&] { LogReader(bank, {log.wheels, log.gyro}); },
               {"bank.yaml: columns.inputs.speed: cannot parse \"abs(velL +* velR)\"", "Unexpected operator"});
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
  expect_error([&] { LogReader(bank, {log.wheels, log.gyro}, bank.sampling); },
               {"uses column 'cur' outside mean(), std() or rms()"});
  bank.columns.measurements[0] = "mean(std(wz))";
  expect_error([&] { LogReader(bank, {log.wheels, log.gyro}, bank.sampling); }, {"of another aggregate"});
  // The same column in two files is ambiguous.
  const auto other = write_file(log.wheels.parent_path() / "other.csv", "time,wz\n0,1\n");
  expect_error([&] { LogReader(two_rate_bank(), {log.wheels, log.gyro, other}); },
               {"column 'wz'", "is also in", "must be in one file of the log"});
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

TEST(LogReader, NonNumericCellNamesLineAndColumn) {
  const auto file = write_file(test_directory() / "log.csv", "t,left,right,v,w\n0,1,2,3,4\n0.1,1,fast,3,4\n");
  LogReader reader(simple_bank(), {file});
  LogSample s;
  reader.next(&s);
  expect_error([&] { reader.next(&s); },
               {"log.csv:3: column 3 ('right'): expected a finite number (or an empty cell, nan or NA for none), got "
                "'fast'"});
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

TEST(LogReader, TimeMustIncreaseStrictly) {
  const auto file = write_file(test_directory() / "log.csv", "t,left,right,v,w\n0,1,2,3,4\n0.5,1,2,3,4\n0.5,1,2,3,4\n");
  LogReader reader(simple_bank(), {file});
  LogSample s;
  ASSERT_TRUE(reader.next(&s));
  ASSERT_TRUE(reader.next(&s)) << "every step before the bad row is delivered";
  expect_error([&] { reader.next(&s); }, {"log.csv:4: column 't': time must increase strictly, but 0.5 follows 0.5"});
}

TEST(LogReader, ABinaryFileGivesAShortPrintableError) {
  std::string garbage(3000, '\0');
  for (std::size_t i = 0; i < garbage.size(); ++i) garbage[i] = static_cast<char>((i * 37 + 11) % 256);
  const auto file = write_file(test_directory() / "binary.csv", garbage);
  const std::string message = expect_error([&] { LogReader(simple_bank(), {file}); }, {"no time column 't'"});
  EXPECT_LT(message.size(), 900u);
  for (unsigned char c : message.substr(message.find("present:"))) EXPECT_TRUE(c >= 32 && c < 127) << int(c);
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
