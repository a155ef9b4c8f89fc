#include "skidimm/io/live_log.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "core/temp_files.h"
#include "skidimm/config/bank.h"
#include "skidimm/errors.h"
#include "skidimm/io/log_reader.h"

namespace skidimm {
namespace {
namespace live_log_test {

using skidimm_test::test_directory;
using skidimm_test::write_file;
using ::testing::HasSubstr;

const std::string kBorealDir = std::string(SKIDIMM_SHARED_DATA_DIR) + "/borealtc";

// A table as a program would push it: its header and its rows as numbers.
struct Table {
  std::string name;
  std::vector<std::string> columns;
  std::vector<std::vector<double>> rows;
};

Table read_csv(const std::string& name, const std::filesystem::path& file) {
  std::ifstream in(file);
  Table t{name, {}, {}};
  std::string line;
  std::getline(in, line);
  std::stringstream header(line);
  for (std::string cell; std::getline(header, cell, ',');) t.columns.push_back(cell);
  while (std::getline(in, line)) {
    std::vector<double> row;
    std::stringstream cells(line);
    for (std::string cell; std::getline(cells, cell, ',');) {
      row.push_back(cell.empty() ? std::nan("") : std::strtod(cell.c_str(), nullptr));
    }
    row.resize(t.columns.size(), std::nan(""));  // a trailing empty cell
    t.rows.push_back(row);
  }
  return t;
}

std::string csv_text(const Table& t) {
  std::ostringstream out;
  out.precision(17);
  for (std::size_t c = 0; c < t.columns.size(); ++c) out << (c ? "," : "") << t.columns[c];
  out << "\n";
  for (const auto& row : t.rows) {
    for (std::size_t c = 0; c < row.size(); ++c) {
      out << (c ? "," : "");
      if (!std::isnan(row[c])) out << row[c];
    }
    out << "\n";
  }
  return out.str();
}

std::vector<LogSample> read_files(const BankConfig& bank, const std::vector<LogFile>& files) {
  LogReader reader(bank, files);
  std::vector<LogSample> out;
  for (LogSample s; reader.next(&s);) out.push_back(s);
  return out;
}

// Bit for bit, a NaN equal to a NaN.
bool same(double a, double b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

void expect_same_steps(const std::vector<LogSample>& live, const std::vector<LogSample>& files) {
  ASSERT_EQ(live.size(), files.size());
  for (std::size_t k = 0; k < live.size(); ++k) {
    ASSERT_EQ(live[k].t, files[k].t) << "step " << k;
    ASSERT_EQ(live[k].u.size(), files[k].u.size());
    for (Eigen::Index i = 0; i < live[k].u.size(); ++i) ASSERT_TRUE(same(live[k].u[i], files[k].u[i])) << k;
    ASSERT_EQ(live[k].z.size(), files[k].z.size());
    for (Eigen::Index i = 0; i < live[k].z.size(); ++i) {
      ASSERT_TRUE(same(live[k].z[i], files[k].z[i])) << "step " << k << " measurement " << i;
    }
    ASSERT_EQ(live[k].row, files[k].row);
  }
}

LiveTable live_table(const Table& t) { return {t.name, t.columns, 0.0}; }

std::vector<LiveTable> live_tables(const std::vector<Table>& tables) {
  std::vector<LiveTable> out;
  for (const Table& t : tables) out.push_back(live_table(t));
  return out;
}

// Pushes the tables' rows in the order `order` gives (a table index per row
// pushed), taking the steps after every push; checks, as it goes, that no
// step is given before every open table has a row after it.
std::vector<LogSample> push_in_order(const BankConfig& bank, const std::vector<Table>& tables,
                                     const std::vector<int>& order) {
  LiveLog live(bank, live_tables(tables));
  std::vector<std::size_t> next_row(tables.size(), 0);
  std::vector<LogSample> out;
  for (const int k : order) {
    const Table& t = tables[static_cast<std::size_t>(k)];
    live.push(k, t.rows[next_row[static_cast<std::size_t>(k)]++]);
    for (LogSample s; live.next(&s);) {
      for (std::size_t j = 0; j < tables.size(); ++j) {
        const std::size_t pushed = next_row[j];
        // A row at or after the step must have been pushed (after it, but at the first step).
        EXPECT_TRUE(pushed > 0 && tables[j].rows[pushed - 1][0] >= s.t)
            << "step at t = " << s.t << " given before a row of " << tables[j].name << " after it";
      }
      out.push_back(s);
    }
  }
  live.close();
  for (LogSample s; live.next(&s);) out.push_back(s);
  EXPECT_TRUE(live.ended());
  return out;
}

// Row k of every table in time order (ties: the first table first).
std::vector<int> merged_by_time(const std::vector<Table>& tables) {
  std::vector<int> order;
  std::vector<std::size_t> at(tables.size(), 0);
  for (;;) {
    int best = -1;
    for (std::size_t j = 0; j < tables.size(); ++j) {
      if (at[j] < tables[j].rows.size() &&
          (best < 0 || tables[j].rows[at[j]][0] < tables[static_cast<std::size_t>(best)].rows[at[best]][0])) {
        best = static_cast<int>(j);
      }
    }
    if (best < 0) return order;
    order.push_back(best);
    ++at[static_cast<std::size_t>(best)];
  }
}

// Chunks of random length from random tables: sensors whose rows reach the
// program late and in bursts.
std::vector<int> in_random_bursts(const std::vector<Table>& tables, unsigned seed) {
  std::mt19937 random(seed);
  std::vector<std::size_t> left;
  for (const Table& t : tables) left.push_back(t.rows.size());
  std::vector<int> order;
  for (;;) {
    std::vector<int> open;
    for (std::size_t j = 0; j < tables.size(); ++j) {
      if (left[j] > 0) open.push_back(static_cast<int>(j));
    }
    if (open.empty()) return order;
    const int j = open[std::uniform_int_distribution<std::size_t>(0, open.size() - 1)(random)];
    const std::size_t burst = std::min<std::size_t>(left[static_cast<std::size_t>(j)],
                                                    std::uniform_int_distribution<std::size_t>(1, 200)(random));
    for (std::size_t r = 0; r < burst; ++r) order.push_back(j);
    left[static_cast<std::size_t>(j)] -= burst;
  }
}

std::vector<int> one_table_after_the_other(const std::vector<Table>& tables) {
  std::vector<int> order;
  for (std::size_t j = 0; j < tables.size(); ++j) order.insert(order.end(), tables[j].rows.size(), static_cast<int>(j));
  return order;
}

// A two-sensor log: wheels at 10 Hz (inputs and a measurement), a gyro at
// 100 Hz averaged over each 0.25 s step, an empty cell and a late start.
std::vector<Table> two_sensors() {
  Table wheels{"wheels", {"t", "left", "right", "v"}, {}};
  Table gyro{"gyro", {"t", "w"}, {}};
  for (int k = 0; k < 60; ++k) {
    const double t = 0.13 + 0.1 * k;
    wheels.rows.push_back({t, std::sin(t), std::cos(t), k == 7 ? std::nan("") : 0.5 * t});
  }
  for (int k = 0; k < 640; ++k) {
    const double t = 0.005 + 0.01 * k;
    gyro.rows.push_back({t, std::sin(3.0 * t) + 0.001 * (k % 7)});
  }
  return {wheels, gyro};
}

BankConfig two_sensor_bank() {
  BankConfig c;
  c.file = "bank.yaml";
  c.state_names = {"V", "omega"};
  c.input_names = {"phi_dot_L", "phi_dot_R"};
  c.measurement.names = {"V", "omega", "shake"};
  c.columns.time = "t";
  c.columns.inputs = {"left", "right"};
  c.columns.measurements = {"v", "mean(w)", "log(std(w))"};
  c.sampling.rate = 4.0;
  return c;
}

TEST(LiveLog, GivesTheStepsTheReaderGivesForTheSameRowsInFilesInAnyOrderOfTables) {
  const std::vector<Table> tables = two_sensors();
  const BankConfig bank = two_sensor_bank();
  const std::filesystem::path dir = test_directory();
  write_file(dir / "wheels.csv", csv_text(tables[0]));
  write_file(dir / "gyro.csv", csv_text(tables[1]));
  const auto files = read_files(bank, {(dir / "wheels.csv").string(), (dir / "gyro.csv").string()});
  ASSERT_GT(files.size(), 20u);

  expect_same_steps(push_in_order(bank, tables, merged_by_time(tables)), files);
  expect_same_steps(push_in_order(bank, tables, one_table_after_the_other(tables)), files);
  for (unsigned seed = 1; seed <= 3; ++seed) {
    expect_same_steps(push_in_order(bank, tables, in_random_bursts(tables, seed)), files);
  }
  // Without a rate: a step at every time stamp, and the same statistics.
  BankConfig every_row = bank;
  every_row.sampling.rate = 0.0;
  every_row.columns.measurements = {"v", "w", "w"};
  expect_same_steps(push_in_order(every_row, tables, in_random_bursts(tables, 4)),
                    read_files(every_row, {(dir / "wheels.csv").string(), (dir / "gyro.csv").string()}));
}

TEST(LiveLog, AStepWaitsForARowAfterItOfEveryOpenTableAndCloseReleasesIt) {
  const std::vector<Table> tables = two_sensors();
  LiveLog live(two_sensor_bank(), live_tables(tables));
  LogSample s;
  for (int k = 0; k < 20; ++k) live.push(0, tables[0].rows[static_cast<std::size_t>(k)]);  // wheels to t = 2.03
  EXPECT_FALSE(live.next(&s)) << "no gyro row yet";
  EXPECT_FALSE(live.ended());
  EXPECT_EQ(live.waiting_for().table, 1);
  EXPECT_EQ(live.waiting_for().rows, 0);
  for (int k = 0; k < 50; ++k) live.push(1, tables[1].rows[static_cast<std::size_t>(k)]);  // gyro to t = 0.495
  std::vector<double> times;
  while (live.next(&s)) times.push_back(s.t);
  // The first step at the first wheel row (0.13), then every 0.25 s while a gyro row after it has come.
  ASSERT_EQ(times.size(), 2u);
  EXPECT_DOUBLE_EQ(times[0], 0.13);
  EXPECT_DOUBLE_EQ(times[1], 0.38);
  // The step at 0.63 waits for a gyro row after it: the gyro's last was at 0.495.
  EXPECT_EQ(live.waiting_for().table, 1);
  EXPECT_EQ(live.waiting_for().rows, 50);
  EXPECT_DOUBLE_EQ(live.waiting_for().last_time, 0.495);
  live.close(1);  // the gyro has ended: the wheels alone complete the steps
  while (live.next(&s)) times.push_back(s.t);
  EXPECT_EQ(times.size(), 8u);  // to 1.88, the last with a wheel row after it
  EXPECT_EQ(live.waiting_for().table, 0);
  EXPECT_DOUBLE_EQ(live.waiting_for().last_time, 2.03);
  EXPECT_TRUE(std::isnan(s.z[1])) << "no gyro rows after 0.495";
  EXPECT_THAT(
      [&] {
        try {
          live.push(1, tables[1].rows[50]);
        } catch (const Error& e) {
          return std::string(e.what());
        }
        return std::string();
      }(),
      HasSubstr("live table 'gyro' was closed: no row may follow"));
  live.close();
  while (live.next(&s)) times.push_back(s.t);
  EXPECT_TRUE(live.ended());
  EXPECT_EQ(live.waiting_for().table, -1);
  EXPECT_EQ(live.stats().rows, (std::vector<long>{20, 50}));
}

template <typename F>
std::string error_of_or_empty(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

template <typename F>
std::string error_of(F&& f) {
  const std::string error = error_of_or_empty(f);
  if (error.empty()) ADD_FAILURE() << "expected an error";
  return error;
}

TEST(LiveLog, ARowTheReaderRefusesIsAnErrorAfterTheStepsBeforeIt) {
  std::vector<Table> tables = two_sensors();
  tables[1].rows[120][0] = tables[1].rows[119][0];  // a gyro stamp repeated: t = 1.195 twice
  LiveLog live(two_sensor_bank(), live_tables(tables));
  std::vector<std::size_t> at(2, 0);
  for (const int k : merged_by_time(tables)) {
    live.push(k, tables[static_cast<std::size_t>(k)].rows[at[static_cast<std::size_t>(k)]++]);
  }
  std::vector<double> times;
  LogSample s;
  const std::string error = error_of([&] {
    while (live.next(&s)) times.push_back(s.t);
  });
  EXPECT_THAT(error, HasSubstr("live table 'gyro': row 121: column 't': time must increase strictly"));
  ASSERT_FALSE(times.empty());
  // The row belongs to the step at 1.38; every step before it is given.
  EXPECT_DOUBLE_EQ(times.back(), 1.13);
  EXPECT_THAT(error_of([&] { live.next(&s); }), HasSubstr("row 121"));
  live.push(0, tables[0].rows[0]);  // not read: whatever the timing, push() only stores it
  EXPECT_THAT(error_of([&] { live.next(&s); }), HasSubstr("row 121"));
  EXPECT_TRUE(live.ended());

  LiveLog infinite(two_sensor_bank(), live_tables(tables));
  infinite.push(0, {0.13, INFINITY, 1.0, 0.0});
  infinite.push(1, {0.2, 0.0});
  infinite.close();
  EXPECT_THAT(error_of([&] { infinite.next(&s); }),
              HasSubstr("live table 'wheels': row 1: column 2 ('left'): expected a finite number"));
}

// Before the first step nothing is lost by saying it at once, and a live
// log's other sensors would otherwise be read on while the inputs never come.
TEST(LiveLog, AnInputRowRefusedBeforeTheFirstStepIsSaidWhileTheOthersGoOn) {
  const std::vector<Table> tables = two_sensors();
  LiveLog live(two_sensor_bank(), live_tables(tables));
  live.push(0, {0.13, std::nan(""), 1.0, 0.0});  // no left wheel speed yet: no step
  live.push(0, {0.13, 0.5, 1.0, 0.0});           // the same stamp again
  LogSample s;
  for (int k = 0; k < 100; ++k) live.push(1, tables[1].rows[static_cast<std::size_t>(k)]);
  EXPECT_THAT(error_of([&] { live.next(&s); }),
              HasSubstr("live table 'wheels': row 2: column 't': time must increase strictly"));
  EXPECT_EQ(live.waiting_for().table, -1) << "the reader has stopped";
}

TEST(LiveLog, SaysWhatIsWrongWithATableOrARow) {
  const std::vector<Table> tables = two_sensors();
  const BankConfig bank = two_sensor_bank();
  EXPECT_THAT(error_of([&] {
                LiveLog live(bank, {{"wheels", {"t", "left", "right"}, 0.0}, live_table(tables[1])});
              }),
              HasSubstr("'v'"));
  EXPECT_THAT(error_of([&] {
                LiveLog live(bank, {{"wheels", tables[0].columns, 0.0}, {"wheels", {"t", "w"}, 0.0}});
              }),
              HasSubstr("two live tables are named 'wheels'"));
  EXPECT_THAT(error_of([&] {
                LiveLog live(bank, {{"wheels", {"t", "left", "right", "v", "left"}, 0.0}, live_table(tables[1])});
              }),
              HasSubstr("live table 'wheels' names column 'left' twice"));
  EXPECT_THAT(error_of([&] {
                LiveLog live(bank, {{"wheels", {"time", "left", "right", "v"}, 0.0}, live_table(tables[1])});
              }),
              HasSubstr("live table 'wheels': no time column 't'"));
  BankConfig by_rows = bank;
  by_rows.sampling.join = SamplingConfig::Join::kRows;
  EXPECT_THAT(error_of([&] { LiveLog live(by_rows, live_tables(tables)); }), HasSubstr("sampling.join: rows"));

  LiveLog live(bank, live_tables(tables));
  EXPECT_THAT(error_of([&] { live.table("imu"); }), HasSubstr("no table 'imu'; its tables: 'wheels', 'gyro'"));
  EXPECT_EQ(live.table("gyro"), 1);
  EXPECT_THAT(error_of([&] {
                live.push(1, {0.1, 0.2, 0.3});
              }),
              HasSubstr("live table 'gyro': a row has 3 value(s), the table 2 column(s): t, w"));
  EXPECT_THAT(error_of([&] { live.push(2, {0.1, 0.2}); }), HasSubstr("no table 2"));
}

TEST(LiveLog, ASensorThatStopsWithoutCloseIsNamedWhenTheOthersRowsPileUp) {
  const std::vector<Table> tables = two_sensors();
  LiveLog live(two_sensor_bank(), live_tables(tables));
  live.set_max_queued_rows(100);
  for (int k = 0; k < 3; ++k) live.push(0, tables[0].rows[static_cast<std::size_t>(k)]);
  LogSample s;
  std::string error;
  for (std::size_t k = 0; k < tables[1].rows.size() && error.empty(); ++k) {
    error = error_of_or_empty([&] { live.push(1, tables[1].rows[k]); });
    while (live.next(&s)) {
    }
  }
  EXPECT_THAT(error, HasSubstr("live table 'gyro' holds 100 rows the reader has not taken"));
  EXPECT_THAT(error,
              HasSubstr("the reader waits for a row of live table 'wheels' (3 row(s) pushed, the last at t = 0.33)"));
}

TEST(LiveLog, GoesAwayWhileItsReaderWaits) {
  const std::vector<Table> tables = two_sensors();
  for (int pushed = 0; pushed < 3; ++pushed) {
    LiveLog live(two_sensor_bank(), live_tables(tables));
    for (int k = 0; k < pushed; ++k) live.push(0, tables[0].rows[static_cast<std::size_t>(k)]);
  }  // each destructor stops the reader wherever it waits
  SUCCEED();
}

// The real BorealTC run with the bundled bank: the rows of its two files
// pushed as a robot's callbacks would push them give the steps the CLI reads.
TEST(RealBorealTcData, ALiveLogGivesTheBundledBanksStepsBitForBit) {
  const std::string dir = kBorealDir + "/ICE";
  if (!std::filesystem::exists(dir)) GTEST_SKIP() << "no shared data at " << dir;
  const BankConfig bank = load_bank_config(std::string(SKIDIMM_SOURCE_DIR) + "/configs/borealtc/terrains.yaml");
  const std::vector<Table> tables = {read_csv("pro", dir + "/pro_02.csv"), read_csv("imu", dir + "/imu_02.csv")};
  const auto files = read_files(bank, {dir + "/pro_02.csv", dir + "/imu_02.csv"});
  ASSERT_GT(files.size(), 100u);
  expect_same_steps(push_in_order(bank, tables, merged_by_time(tables)), files);
  expect_same_steps(push_in_order(bank, tables, in_random_bursts(tables, 11)), files);
}

}  // namespace live_log_test
}  // namespace
}  // namespace skidimm
