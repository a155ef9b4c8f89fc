// `skidimm eval` end to end, on the bundled switching example and logs made
// from it: accuracy, latency and consistency as text and JSON, decision
// settings and a run's decision remade from its probabilities, the filter's
// settings over the bank's, classes scoring several modes as one. It says what it means: per-class accuracy
// over each class's own time, logs keyed by their paths, blank truth cells
// unlabelled, patterns paired by run key, and one order for a confusion's
// rows and columns. A log that fails half-way is named, and the others are
// still scored.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "cli/cli_test_support.h"

namespace skidimm_test {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
namespace fs = std::filesystem;

std::string eval(const std::string& arguments) { return "eval --bank " + kTerrains + " --plugin-path " + kPlugins + " " + arguments; }

// eval --json's output as a YAML node (JSON is YAML).
YAML::Node json_of(const Result& r) {
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return YAML::Load(r.out);
}

// Seconds each row of a log stands for: until the next row, the last one
// for the interval before it (mode_metrics.h).
std::vector<double> row_seconds(const std::vector<std::vector<std::string>>& rows) {
  const int t = column(rows[0], "t");
  std::vector<double> out;
  for (std::size_t i = 1; i < rows.size(); ++i) {
    const std::size_t next = i + 1 < rows.size() ? i + 1 : i;
    const std::size_t prev = i + 1 < rows.size() ? i : i - 1;
    out.push_back(std::stod(rows[next][static_cast<std::size_t>(t)]) - std::stod(rows[prev][static_cast<std::size_t>(t)]));
  }
  return out;
}

TEST(EvalCommand, PerClassAccuracyIsOverEachClassesOwnTimeInSwitchingLogs) {
  // Two copies of one switching log: each log's main truth is the same class,
  // so counting each log for its main truth leaves the other two out.
  // Two groups (one argument given twice would be one group).
  const std::string copy = write_file(test_directory() / "copy.csv", read_file(kSwitching)).string();
  const Result r = run_skidimm(eval("--input " + kSwitching + " --input " + copy + " --json"));
  const YAML::Node all = json_of(r)["overall"];
  const YAML::Node confusion = all["confusion_seconds"];
  ASSERT_EQ(confusion.size(), 3u);
  double sum = 0.0;
  for (const char* terrain : {"asphalt", "grass", "crushed_concrete"}) {
    double row = 0.0;
    for (const auto& cell : confusion[terrain]) row += cell.second.as<double>();
    const double expected = confusion[terrain][terrain].as<double>() / row;
    const YAML::Node per_class = all["per_class"][terrain];
    EXPECT_NEAR(per_class["seconds"].as<double>(), row, 1e-3) << terrain;
    EXPECT_NEAR(per_class["accuracy"].as<double>(), expected, 1e-5) << terrain;
    sum += expected;
  }
  EXPECT_NEAR(all["mean_over_classes_by_time"]["accuracy"].as<double>(), sum / 3, 1e-5);
  EXPECT_EQ(all["mean_over_classes"]["per_class"].size(), 1u) << "tune's figure: each log counted for its main truth";
  const Result table = run_skidimm(eval("--input " + kSwitching + " --input " + copy));
  ASSERT_EQ(table.exit_code, 0) << table.err;
  const std::string all_table = table.out.substr(table.out.find("\nall:"));
  EXPECT_THAT(all_table, HasSubstr("per class, over its own true time:  asphalt "));
  EXPECT_THAT(all_table, HasSubstr(" grass "));
  EXPECT_THAT(all_table, HasSubstr(" crushed_concrete "));
  // Two means of log p(truth) over several logs, each said for what it is.
  EXPECT_THAT(all_table, HasSubstr("mean log probability of the truth -0.103 (over all labelled time)"));
  EXPECT_THAT(all_table, HasSubstr("over logs (each log's mean, averaged), against -1.099"));
}

// The switching log cut at its changes of terrain into three logs of one
// terrain each, and spliced back with --splice in the order given: one run
// whose changes are where the log's were (each log's times shifted by less
// than a step), followed as fast as in the log; given in another order, the
// changes are between those terrains. Smoothing a splice is refused.
TEST(EvalCommand, SpliceScoresTheLogsAsOneRunTheGroupsTakingTurns) {
  const std::string log = read_file(kSwitching);
  std::vector<std::string> lines;
  for (std::size_t at = 0, next; at < log.size(); at = next + 1) {
    next = log.find('\n', at);
    lines.push_back(log.substr(at, next - at));
  }
  const auto dir = test_directory();
  const auto segment = [&](const std::string& name, std::size_t first, std::size_t last) {
    std::string text = lines[0] + "\n";
    for (std::size_t i = first; i <= last && i < lines.size(); ++i) {
      if (!lines[i].empty()) text += lines[i] + "\n";
    }
    return write_file(dir / name, text).string();
  };
  // Lines (from 0, the header) where the log's truth changes: 500 and 995.
  const std::string crushed = segment("crushed.csv", 1, 499);
  const std::string grass = segment("grass.csv", 500, 994);
  const std::string asphalt = segment("asphalt.csv", 995, lines.size());
  const YAML::Node original = json_of(run_skidimm(eval("--input " + kSwitching + " --json")))["logs"].begin()->second;
  const Result r =
      run_skidimm(eval("--splice --input " + crushed + " --input " + grass + " --input " + asphalt + " --json"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const YAML::Node logs = json_of(r)["logs"];
  ASSERT_EQ(logs.size(), 1u) << "one run";
  const YAML::Node spliced = logs.begin()->second;
  ASSERT_EQ(spliced["switches"].size(), 2u);
  for (std::size_t k = 0; k < 2; ++k) {
    const YAML::Node got = spliced["switches"][k], expected = original["switches"][k];
    EXPECT_EQ(got["from"].as<std::string>(), expected["from"].as<std::string>());
    EXPECT_EQ(got["to"].as<std::string>(), expected["to"].as<std::string>());
    EXPECT_NEAR(got["time"].as<double>(), expected["time"].as<double>(), 0.05);
    EXPECT_NEAR(got["first_latency"].as<double>(), expected["first_latency"].as<double>(), 0.1);
  }
  EXPECT_NEAR(spliced["accuracy"].as<double>(), original["accuracy"].as<double>(), 0.01);
  const Result reversed =
      run_skidimm(eval("--splice --input " + asphalt + " --input " + grass + " --input " + crushed + " --json"));
  ASSERT_EQ(reversed.exit_code, 0) << reversed.err;
  const YAML::Node turns = json_of(reversed)["logs"].begin()->second["switches"];
  ASSERT_EQ(turns.size(), 2u);
  EXPECT_EQ(turns[0]["from"].as<std::string>(), "asphalt");
  EXPECT_EQ(turns[0]["to"].as<std::string>(), "grass");
  EXPECT_EQ(turns[1]["to"].as<std::string>(), "crushed_concrete");
  const Result table = run_skidimm(eval("--splice --input " + crushed + " --input " + grass + " --input " + asphalt));
  EXPECT_THAT(table.out, HasSubstr("spliced (3 logs end to end, the groups taking turns): 1 log(s)"));
  // A log that cannot be read is left out of the splice and listed; the exit code says so.
  const Result missing = run_skidimm(eval("--splice --input " + crushed + " --input " + (dir / "none.csv").string() +
                                          " --input " + asphalt + " --json"));
  EXPECT_EQ(missing.exit_code, 1) << missing.err;
  EXPECT_THAT(missing.err, HasSubstr("none.csv: no such log file"));
  EXPECT_THAT(missing.err,
              HasSubstr("1 of 3 log(s) failed and are left out of the splice above, which joins the other 2"));
  const YAML::Node two = YAML::Load(missing.out)["logs"].begin()->second["switches"];
  ASSERT_EQ(two.size(), 1u);
  EXPECT_EQ(two[0]["from"].as<std::string>(), "crushed_concrete");
  EXPECT_EQ(two[0]["to"].as<std::string>(), "asphalt");
  // A log that never gave a measurement is scored on the others, and said, by its name.
  std::string without_gyro = lines[0] + "\n";
  for (std::size_t i = 500; i <= 994; ++i) {
    std::vector<std::string> cells;
    std::stringstream row(lines[i]);
    for (std::string cell; std::getline(row, cell, ',');) cells.push_back(cell);
    cells[4].clear();  // omega
    for (std::size_t c = 0; c < cells.size(); ++c) without_gyro += (c ? "," : "") + cells[c];
    without_gyro += "\n";
  }
  const std::string no_gyro = write_file(dir / "grass_no_gyro.csv", without_gyro).string();
  const Result unmeasured =
      run_skidimm(eval("--splice --input " + crushed + " --input " + no_gyro + " --input " + asphalt + " --json"));
  EXPECT_EQ(unmeasured.exit_code, 0) << unmeasured.err;
  EXPECT_THAT(unmeasured.err, HasSubstr("skidimm eval: warning: " + no_gyro + ": measurement 'omega'"));
  EXPECT_THAT(unmeasured.err, Not(HasSubstr(crushed + ": measurement")));
  const Result smoothed = run_skidimm(eval("--splice --smooth --input " + crushed + " --input " + grass));
  EXPECT_EQ(smoothed.exit_code, 2) << smoothed.err;
  EXPECT_THAT(smoothed.err, HasSubstr("--splice scores the filter as it runs across each change, and --smooth"));
}

TEST(EvalCommand, JsonKeysLogsByTheirPathsSoSameNamedFilesStayApart) {
  const fs::path dir = test_directory();
  fs::create_directories(dir / "a");
  fs::create_directories(dir / "b");
  fs::copy_file(kSwitching, dir / "a" / "run.csv");
  fs::copy_file(kSwitching, dir / "b" / "run.csv");
  const Result r = run_skidimm(eval("--input " + (dir / "a").string() + " --input " + (dir / "b").string() +
                                    " --input " + (dir / "a" / "run.csv").string() + " --json"));
  const YAML::Node logs = json_of(r)["logs"];
  ASSERT_EQ(logs.size(), 3u) << r.out;
  EXPECT_TRUE(logs[(dir / "a" / "run.csv").string()]);
  EXPECT_TRUE(logs[(dir / "b" / "run.csv").string()]);
  EXPECT_TRUE(logs[(dir / "a" / "run.csv").string() + " (2)"]) << "the same file given twice";
}

TEST(EvalCommand, BlankTruthCellsAreUnlabelledAndNotScoredUnlessTheBankCarriesThem) {
  // The last 7 s of the switching log (asphalt from 20 s) lose their label.
  auto rows = read_csv(kSwitching);
  const int t = column(rows[0], "t"), mode = column(rows[0], "mode");
  const std::vector<double> seconds = row_seconds(rows);
  double blank = 0.0, asphalt = 0.0, labelled = 0.0;
  for (std::size_t i = 1; i < rows.size(); ++i) {
    if (std::stod(rows[i][static_cast<std::size_t>(t)]) >= 23.0) {
      rows[i][static_cast<std::size_t>(mode)] = "";
      blank += seconds[i - 1];
    } else {
      labelled += seconds[i - 1];
      if (rows[i][static_cast<std::size_t>(mode)] == "asphalt") asphalt += seconds[i - 1];
    }
  }
  const fs::path dir = test_directory();
  const fs::path log = write_file(dir / "tail_unlabelled.csv", csv_text(rows));
  const YAML::Node all = json_of(run_skidimm(eval("--input " + log.string() + " --json")))["overall"];
  EXPECT_NEAR(all["duration"].as<double>(), labelled, 1e-4);
  EXPECT_NEAR(all["unlabelled_seconds"].as<double>(), blank, 1e-4);
  EXPECT_NEAR(all["per_class"]["asphalt"]["seconds"].as<double>(), asphalt, 1e-4) << "the blank tail is not asphalt";
  const Result table = run_skidimm(eval("--input " + log.string()));
  EXPECT_THAT(table.out, HasSubstr(" s unlabelled (blank truth: not scored)"));

  // A bank whose logs write a label only when it changes carries it.
  std::string bank = skidimm_test::read_file(kTerrains);
  bank.replace(bank.find("truth_mode: mode"), 16, "truth_mode: mode\n  truth_blank: carry");
  const fs::path carrying = write_file(dir / "carrying.yaml", bank);
  const Result carried = run_skidimm("eval --bank " + carrying.string() + " --plugin-path " + kPlugins + " --input " +
                                     log.string() + " --json");
  const YAML::Node c = json_of(carried)["overall"];
  EXPECT_NEAR(c["duration"].as<double>(), labelled + blank, 1e-4);
  EXPECT_NEAR(c["unlabelled_seconds"].as<double>(), 0.0, 1e-12);
}

// Unlabelled arguments named alike (files of one name, or patterns, in two
// folders) are two groups, named by their folders: --json wrote two groups
// under one key. One label given twice is one group.
TEST(EvalCommand, GroupsNamedAlikeAreToldApartByTheirFolders) {
  const fs::path dir = test_directory();
  fs::create_directories(dir / "a");
  fs::create_directories(dir / "b");
  const fs::path a = write_file(dir / "a" / "run.csv", read_file(kSwitching));
  const fs::path b = write_file(dir / "b" / "run.csv", read_file(kSwitching));
  // Files by their folders; a folder's '*' pattern by its folder (it was named '*').
  for (const auto& [arguments, named] :
       {std::pair<std::string, std::string>{"--input " + a.string() + " --input " + b.string(), "/[^:\n]*"},
        {"--input '" + (dir / "a").string() + "/*.csv' --input '" + (dir / "b").string() + "/*.csv'", "/\\*"}}) {
    const Result table = run_skidimm(eval(arguments));
    ASSERT_EQ(table.exit_code, 0) << table.err;
    EXPECT_THAT(table.out, ::testing::ContainsRegex("\na" + named + ": 1 log\\(s\\)")) << arguments << table.out;
    EXPECT_THAT(table.out, ::testing::ContainsRegex("\nb" + named + ": 1 log\\(s\\)")) << arguments;
    const YAML::Node json = json_of(run_skidimm(eval(arguments + " --json")));
    EXPECT_EQ(json["groups"].size(), 2u) << arguments;
  }
  const YAML::Node labelled =
      json_of(run_skidimm(eval("--input grass=" + a.string() + " --input grass=" + b.string() + " --json")));
  ASSERT_EQ(labelled["groups"].size(), 1u);
  EXPECT_EQ(labelled["groups"]["grass"]["logs"].as<int>(), 2);
}

// A log without labelled time has nothing to score: said so, null in the
// JSON, and out of the per-log means, where its 0 used to read as a score.
// When no log has any, the report is printed and eval exits 1: a script
// must not take a report of nothing for a pass.
TEST(EvalCommand, ALogWithoutLabelledTimeIsNotScored) {
  auto rows = read_csv(kSwitching);
  const int mode = column(rows[0], "mode");
  for (std::size_t i = 1; i < rows.size(); ++i) rows[i][static_cast<std::size_t>(mode)] = "";
  const fs::path dir = test_directory();
  const fs::path blank = write_file(dir / "all_blank.csv", csv_text(rows));
  const Result table = run_skidimm(eval("--input " + blank.string()));
  EXPECT_EQ(table.exit_code, 1) << table.err;
  EXPECT_THAT(table.err, HasSubstr("skidimm eval: error: no log has labelled time (two steps or more with a truth): "
                                   "nothing was scored"));
  EXPECT_THAT(table.out, HasSubstr("1 without labelled time, not scored"));
  EXPECT_THAT(table.out, HasSubstr("nothing to score: no labelled time"));
  EXPECT_THAT(table.out, Not(HasSubstr("accuracy (time fraction)")));
  const Result blank_json = run_skidimm(eval("--input " + blank.string() + " --json"));
  EXPECT_EQ(blank_json.exit_code, 1);
  const YAML::Node all = YAML::Load(blank_json.out)["overall"];
  EXPECT_TRUE(all["accuracy"].IsNull());
  EXPECT_TRUE(all["mean_truth_log_probability"].IsNull());
  EXPECT_TRUE(all["mean_over_classes"]["accuracy"].IsNull());
  // Beside a labelled log, the per-log figures are the labelled log's alone.
  const Result mixed = run_skidimm(eval("--input " + blank.string() + " --input " + kSwitching + " --json"));
  EXPECT_EQ(mixed.exit_code, 0) << mixed.err;
  const YAML::Node both = json_of(mixed)["overall"];
  const YAML::Node alone = json_of(run_skidimm(eval("--input " + kSwitching + " --json")))["overall"];
  EXPECT_EQ(both["logs"].as<int>(), 2);
  EXPECT_DOUBLE_EQ(both["accuracy_per_log"]["min"].as<double>(), alone["accuracy_per_log"]["min"].as<double>());
  EXPECT_DOUBLE_EQ(both["mean_over_classes"]["accuracy"].as<double>(),
                   alone["mean_over_classes"]["accuracy"].as<double>());
}

TEST(EvalCommand, PatternsPairFilesByRunKeyAndListOrSkipTheUnpaired) {
  // The switching log split into a wheel file and a sensor file per run, as
  // the BorealTC data comes (pro_NN.csv + imu_NN.csv).
  const auto rows = read_csv(kSwitching);
  std::vector<std::vector<std::string>> pro, imu;
  for (const auto& row : rows) {
    pro.push_back({row[column(rows[0], "t")], row[column(rows[0], "phi_dot_L")], row[column(rows[0], "phi_dot_R")],
                   row[column(rows[0], "mode")]});
    imu.push_back({row[column(rows[0], "t")], row[column(rows[0], "V")], row[column(rows[0], "omega")]});
  }
  const fs::path dir = test_directory();
  for (const char* run : {"01", "02", "04"}) write_file(dir / ("pro_" + std::string(run) + ".csv"), csv_text(pro));
  for (const char* run : {"01", "02", "03"}) write_file(dir / ("imu_" + std::string(run) + ".csv"), csv_text(imu));
  const std::string pattern = "'" + (dir / "pro_*.csv").string() + "+" + (dir / "imu_*.csv").string() + "'";

  const Result refused = run_skidimm(eval("--input " + pattern + " --json"));
  EXPECT_EQ(refused.exit_code, 1);
  EXPECT_THAT(refused.err, HasSubstr("2 of 4 run(s) are not in every file of the pattern"));
  EXPECT_THAT(refused.err, HasSubstr((dir / "imu_03.csv").string() + " has no partner " + (dir / "pro_03.csv").string()));
  EXPECT_THAT(refused.err, HasSubstr((dir / "pro_04.csv").string() + " has no partner " + (dir / "imu_04.csv").string()));
  EXPECT_THAT(refused.err, HasSubstr("--skip-unpaired"));

  const Result skipped = run_skidimm(eval("--input " + pattern + " --skip-unpaired --json"));
  const YAML::Node json = json_of(skipped);
  EXPECT_EQ(json["overall"]["logs"].as<int>(), 2);
  EXPECT_TRUE(json["logs"][(dir / "pro_01.csv").string() + "+" + (dir / "imu_01.csv").string()]);
  EXPECT_TRUE(json["logs"][(dir / "pro_02.csv").string() + "+" + (dir / "imu_02.csv").string()]);
  EXPECT_THAT(skipped.err, HasSubstr("left out: " + (dir / "imu_03.csv").string()));
  EXPECT_THAT(skipped.err, HasSubstr("left out: " + (dir / "pro_04.csv").string()));
}

// The confusion table of an eval table: its header line and `rows` rows.
std::vector<std::string> confusion_lines(const std::string& out, int rows) {
  std::vector<std::string> lines;
  std::size_t at = out.find("confusion (rows: truth");
  if (at == std::string::npos) return lines;
  at = out.find('\n', at) + 1;
  for (int i = 0; i <= rows; ++i) {
    const std::size_t end = out.find('\n', at);
    lines.push_back(out.substr(at, end - at));
    at = end + 1;
  }
  return lines;
}

// A pipe among a directory's or a pattern's files would wait for a writer
// that never comes (eval hung on one without a word): refused, named.
TEST(EvalCommand, APipeInADirectoryOrPatternOfLogsIsRefused) {
  const fs::path dir = test_directory() / "logs";
  fs::create_directories(dir);
  fs::copy_file(kSwitching, dir / "a.csv");
  const Result made = run_shell("mkfifo " + (dir / "b.csv").string());
  ASSERT_EQ(made.exit_code, 0) << made.err;
  for (const std::string& argument : {dir.string(), (dir / "*.csv").string()}) {
    const Result r = run_shell("timeout 60 " + kSkidimm + " eval --bank " + kTerrains + " --plugin-path " + kPlugins +
                               " --input '" + argument + "'");
    EXPECT_EQ(r.exit_code, 1) << argument << ": " << r.err;
    EXPECT_THAT(r.err, HasSubstr((dir / "b.csv").string() + " is not a regular file (a pipe)")) << argument;
  }
}

// A truth column of the wrong values (the time: a label per step) or one
// that changes at every step listed a line per step: the text report lists
// at most 10 labels the bank lacks and 50 switches, and says how many more.
TEST(EvalCommand, ATruthColumnOfAValuePerStepDoesNotListEveryStep) {
  const fs::path dir = test_directory();
  std::string bank = read_file(kTerrains);
  bank.replace(bank.find("truth_mode: mode"), 16, "truth_mode: t");
  const fs::path timed = write_file(dir / "timed.yaml", bank);
  const Result by_time = run_skidimm("eval --bank " + timed.string() + " --input " + kSwitching);
  ASSERT_EQ(by_time.exit_code, 0) << by_time.err;
  EXPECT_LT(std::count(by_time.out.begin(), by_time.out.end(), '\n'), 120) << by_time.out.substr(0, 2000);
  EXPECT_THAT(by_time.out, HasSubstr(" more truth labels not in the bank, left out of the tables here (--json lists "
                                     "every one): is the truth column the right one?"));
  // Labels that alternate at every row: a switch per row.
  std::string log = read_file(kSwitching), alternating;
  std::istringstream rows(log);
  std::string line;
  std::getline(rows, line);
  alternating = line + "\n";
  const std::size_t mode_column = 10;  // t, phi_dot_L, phi_dot_R, V, omega, ax, ay, X, Y, theta, mode, ...
  for (int k = 0; std::getline(rows, line); ++k) {
    std::vector<std::string> cells;
    std::stringstream split(line);
    for (std::string cell; std::getline(split, cell, ',');) cells.push_back(cell);
    cells[mode_column] = k % 2 == 0 ? "grass" : "asphalt";
    for (std::size_t c = 0; c < cells.size(); ++c) alternating += (c ? "," : "") + cells[c];
    alternating += "\n";
  }
  const Result flicker =
      run_skidimm("eval --bank " + kTerrains + " --input " + write_file(dir / "flicker.csv", alternating).string());
  ASSERT_EQ(flicker.exit_code, 0) << flicker.err;
  EXPECT_LT(std::count(flicker.out.begin(), flicker.out.end(), '\n'), 120);
  EXPECT_THAT(flicker.out, ::testing::ContainsRegex("\\.\\.\\. and [0-9]+ more switches \\(--json lists every one\\)"));
}

TEST(EvalCommand, ALogThatFailsHalfWayCostsTheOthersNothing) {
  // Three copies of the switching log, the second with a bad cell half-way:
  // the two good logs are scored as they would be alone, and the bad one is
  // named with its line and left out, with a failing exit.
  auto rows = read_csv(kSwitching);
  const std::size_t bad_row = rows.size() / 2;
  rows[bad_row][static_cast<std::size_t>(column(rows[0], "omega"))] = "abc";
  const fs::path dir = test_directory();
  const fs::path bad = write_file(dir / "bad.csv", csv_text(rows));
  const fs::path good = dir / "good.csv";
  fs::copy_file(kSwitching, good);
  const std::string bad_line = bad.string() + ":" + std::to_string(bad_row + 1) + ":";

  const Result r = run_skidimm(eval("--input " + kSwitching + " --input " + bad.string() + " --input " +
                                    good.string() + " --json"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("skidimm eval: error: " + bad_line));
  EXPECT_THAT(r.err, HasSubstr("1 of 3 log(s) failed and are left out of the report above, which scores the other 2"));
  const YAML::Node partial = YAML::Load(r.out);
  ASSERT_EQ(partial["logs"].size(), 2u) << r.out;
  EXPECT_FALSE(partial["logs"][bad.string()]);
  const YAML::Node alone =
      json_of(run_skidimm(eval("--input " + kSwitching + " --input " + good.string() + " --json")));
  EXPECT_EQ(YAML::Dump(partial["overall"]), YAML::Dump(alone["overall"]));

  // The text report too; and when every log fails, no report at all.
  const Result table = run_skidimm(eval("--input " + bad.string() + " --input " + good.string()));
  EXPECT_EQ(table.exit_code, 1);
  EXPECT_THAT(table.out, HasSubstr("accuracy (time fraction)"));
  EXPECT_THAT(table.err, HasSubstr(bad_line));
  const Result none = run_skidimm(eval("--input " + bad.string()));
  EXPECT_EQ(none.exit_code, 1);
  EXPECT_EQ(none.out, "");
  EXPECT_THAT(none.err, HasSubstr("1 of 1 log(s) failed and are left out of every figure: nothing was scored"));

  // Scoring files `skidimm run` wrote: a cut one fails, the whole one counts.
  const fs::path whole = dir / "whole_estimates.csv";
  ASSERT_EQ(run_shell(run_command(kTerrains, kSwitching, whole.string())).exit_code, 0);
  std::string text = skidimm_test::read_file(whole);
  const fs::path cut = write_file(dir / "cut_estimates.csv", text.substr(0, text.size() / 2) + "\n1,2\n");
  const Result files = run_skidimm("eval --estimates " + whole.string() + " --estimates " + cut.string() + " --json");
  EXPECT_EQ(files.exit_code, 1) << files.err;
  EXPECT_THAT(files.err, HasSubstr(cut.string()));
  EXPECT_EQ(YAML::Load(files.out)["logs"].size(), 1u) << files.out;
}

TEST(EvalCommand, ConfusionRowsAndColumnsAreInTheBanksOrder) {
  // The bank lists asphalt, grass, crushed_concrete: not alphabetical.
  const Result r = run_skidimm(eval("--input " + kSwitching));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::vector<std::string> lines = confusion_lines(r.out, 3);
  ASSERT_EQ(lines.size(), 4u) << r.out;
  EXPECT_LT(lines[0].find("asphalt"), lines[0].find("grass"));
  EXPECT_LT(lines[0].find("grass"), lines[0].find("crushed_concrete"));
  EXPECT_THAT(lines[1], ::testing::StartsWith("  asphalt "));
  EXPECT_THAT(lines[2], ::testing::StartsWith("  grass "));
  EXPECT_THAT(lines[3], ::testing::StartsWith("  crushed_concrete "));
  // The same with --estimates and no bank: the file's modes, in its order.
  const fs::path estimates = test_directory() / "estimates.csv";
  ASSERT_EQ(run_skidimm("run -q --bank " + kTerrains + " --plugin-path " + kPlugins + " --input " + kSwitching +
                        " --output " + estimates.string())
                .exit_code,
            0);
  const Result from_file = run_skidimm("eval --estimates " + estimates.string());
  ASSERT_EQ(from_file.exit_code, 0) << from_file.err;
  EXPECT_EQ(confusion_lines(from_file.out, 3), lines);
}

// Estimates files of which only some have a decision column: the decision
// is scored over those, and the report says how many of the logs that is.
TEST(EvalCommand, ADecisionOverSomeOfTheFilesSaysOverHowMany) {
  const fs::path dir = test_directory();
  const fs::path with = dir / "with.csv";
  ASSERT_EQ(run_skidimm("run -q --bank " + kTerrains + " --plugin-path " + kPlugins + " --input " + kSwitching +
                        " --output " + with.string())
                .exit_code,
            0);
  // The same file without its decision column.
  std::istringstream lines(skidimm_test::read_file(with));
  std::string line, without;
  std::size_t drop = std::string::npos;
  while (std::getline(lines, line)) {
    std::vector<std::string> cells;
    std::stringstream row(line);
    for (std::string cell; std::getline(row, cell, ',');) cells.push_back(cell);
    if (!line.empty() && line.back() == ',') cells.emplace_back();  // an empty last cell (reason)
    if (drop == std::string::npos) drop = std::find(cells.begin(), cells.end(), "decision") - cells.begin();
    ASSERT_LT(drop, cells.size()) << line;
    cells.erase(cells.begin() + static_cast<std::ptrdiff_t>(drop));
    for (std::size_t c = 0; c < cells.size(); ++c) without += (c ? "," : "") + cells[c];
    without += "\n";
  }
  const fs::path none = write_file(dir / "without.csv", without);
  const std::string both = "eval --estimates " + with.string() + " --estimates " + none.string();
  const Result text = run_skidimm(both);
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_THAT(text.out, HasSubstr("decision (the files' decision column; 1 of 2 logs, the others have none)"));
  const YAML::Node json = json_of(run_skidimm(both + " --json"));
  EXPECT_EQ(json["overall"]["decision"]["logs"].as<int>(), 1);
  const Result one = run_skidimm("eval --estimates " + with.string());
  ASSERT_EQ(one.exit_code, 0) << one.err;
  EXPECT_THAT(one.out, HasSubstr("decision (the files' decision column): accuracy"));
  EXPECT_EQ(
      json_of(run_skidimm("eval --estimates " + with.string() + " --json"))["overall"]["decision"]["logs"].as<int>(),
      1);
}

// The decision column of a bank with classes names classes, which files read
// without the bank do not know: each mu_ column is then a class, and every
// decision was scored wrong at probability 0 beside a confusion matrix of
// modes against classes.
TEST(EvalCommand, EstimatesOfABankWithClassesNeedThatBank) {
  const fs::path dir = test_directory();
  const fs::path bank =
      write_file(dir / "paved.yaml", skidimm_test::read_file(kTerrains) +
                                         "\nclasses:\n  paved: [asphalt, crushed_concrete]\n  soft: [grass]\n");
  const fs::path estimates = dir / "estimates.csv";
  ASSERT_EQ(run_skidimm("run -q --bank " + bank.string() + " --plugin-path " + kPlugins + " --input " + kSwitching +
                        " --output " + estimates.string())
                .exit_code,
            0);
  const Result alone = run_skidimm("eval --estimates " + estimates.string());
  EXPECT_EQ(alone.exit_code, 1) << alone.err;
  EXPECT_THAT(alone.err, HasSubstr(estimates.string() + ":"));
  EXPECT_THAT(alone.err, HasSubstr("column"));
  EXPECT_THAT(alone.err, HasSubstr("('decision'): '"));
  EXPECT_THAT(alone.err, HasSubstr("' is neither 'unknown' nor a class of the file ('asphalt', 'grass', "
                                   "'crushed_concrete'); without --bank each mu_ column is a class of its own"));
  const Result with_bank = run_skidimm("eval --estimates " + estimates.string() + " --bank " + bank.string());
  ASSERT_EQ(with_bank.exit_code, 0) << with_bank.err;
  EXPECT_THAT(with_bank.out, HasSubstr("decision (the files' decision column): accuracy"));
  // A cell no bank wrote is refused with the bank too.
  std::string text = skidimm_test::read_file(estimates);
  const std::size_t row = text.find("\n") + 1;
  const std::size_t end = text.find("\n", row);
  std::string line = text.substr(row, end - row);
  for (const std::string decided : {",paved,", ",soft,", ",unknown,"}) {
    const std::size_t at = line.find(decided);
    if (at != std::string::npos) line.replace(at, decided.size(), ",gravel,");
  }
  const fs::path edited = write_file(dir / "edited.csv", text.substr(0, row) + line + text.substr(end));
  const Result gravel = run_skidimm("eval --estimates " + edited.string() + " --bank " + bank.string());
  EXPECT_EQ(gravel.exit_code, 1) << gravel.err;
  EXPECT_THAT(gravel.err, HasSubstr(edited.string() + ":2: column"));
  EXPECT_THAT(gravel.err, HasSubstr("'gravel' is neither 'unknown' nor a class of the bank ('paved', 'soft')"));
}

// A label before the estimates (LABEL=FILE, as --input takes it) is their
// truth: it was read as the group's name only, the file's truth_mode column
// scored instead, and estimates run without a truth could not be scored.
TEST(EvalCommand, ALabelOfEstimatesIsTheirTruth) {
  const fs::path dir = test_directory();
  // The switching log without its truth column, as a robot's own log.
  auto rows = skidimm_test::read_csv(kSwitching);
  const std::size_t mode = static_cast<std::size_t>(skidimm_test::column(rows[0], "mode"));
  for (auto& row : rows) row.erase(row.begin() + static_cast<std::ptrdiff_t>(mode));
  const fs::path no_truth = write_file(dir / "no_truth.csv", csv_text(rows));
  const fs::path truthful = dir / "truth.csv", labelled = dir / "grass.csv", unlabelled = dir / "none.csv";
  for (const auto& [input, output] : {std::pair<std::string, fs::path>{kSwitching, truthful},
                                      {"grass=" + kSwitching, labelled},
                                      {no_truth.string(), unlabelled}}) {
    ASSERT_EQ(run_skidimm("run -q --bank " + kTerrains + " --plugin-path " + kPlugins + " --input " + input +
                          " --output " + output.string())
                  .exit_code,
              0);
  }
  const auto accuracy = [](const Result& r) { return json_of(r)["overall"]["accuracy"].as<double>(); };
  // Scored against its truth column the filter is right most of the time;
  // the log holds grass for about a third of it.
  const Result as_run = run_skidimm("eval --json --estimates " + truthful.string());
  ASSERT_EQ(as_run.exit_code, 0) << as_run.err;
  const Result relabelled = run_skidimm("eval --json --estimates grass=" + truthful.string());
  ASSERT_EQ(relabelled.exit_code, 0) << relabelled.err;
  EXPECT_GT(accuracy(as_run), 0.9);
  EXPECT_LT(accuracy(relabelled), 0.5);
  EXPECT_GT(accuracy(relabelled), 0.2);
  EXPECT_THAT(relabelled.out, HasSubstr("\"grass\": {\"logs\": 1"));
  // A run labelled grass scores the same.
  const Result as_labelled = run_skidimm("eval --json --estimates " + labelled.string());
  ASSERT_EQ(as_labelled.exit_code, 0) << as_labelled.err;
  EXPECT_DOUBLE_EQ(accuracy(as_labelled), accuracy(relabelled));
  // Estimates without a truth_mode column: refused with what to do, scored with a label.
  const Result bare = run_skidimm("eval --estimates " + unlabelled.string());
  EXPECT_EQ(bare.exit_code, 1);
  EXPECT_THAT(bare.err, HasSubstr("no truth_mode column to score against: the log was run without a truth; label the "
                                  "estimates with the mode or class they show (LABEL="));
  const Result grass = run_skidimm("eval --json --estimates grass=" + unlabelled.string());
  ASSERT_EQ(grass.exit_code, 0) << grass.err;
  EXPECT_DOUBLE_EQ(accuracy(grass), accuracy(relabelled));  // the same run, the same label
  const Result wrong = run_skidimm("eval --estimates gravel=" + labelled.string());
  EXPECT_EQ(wrong.exit_code, 1);
  EXPECT_THAT(wrong.err, HasSubstr("'gravel' is not a mode of these estimates; their modes (mu_ columns): asphalt, "
                                   "grass, crushed_concrete; give --bank for its classes"));
  const Result wrong_with_bank = run_skidimm("eval --estimates gravel=" + labelled.string() + " --bank " + kTerrains +
                                             " --plugin-path " + kPlugins);
  EXPECT_EQ(wrong_with_bank.exit_code, 1);
  EXPECT_THAT(wrong_with_bank.err, HasSubstr("'gravel' is neither a mode nor a class of bank 'ltc_terrains'"));
}

// A measurement a log never gives (a column empty throughout, a misspelt
// joint name in a bag) leaves the log scored on the others: eval and
// validate --check say so, as run's summary does.
TEST(EvalCommand, AMeasurementTheLogNeverGivesIsSaid) {
  const fs::path dir = test_directory();
  auto rows = skidimm_test::read_csv(kSwitching);
  const std::size_t omega = static_cast<std::size_t>(skidimm_test::column(rows[0], "omega"));
  for (std::size_t i = 1; i < rows.size(); ++i) rows[i][omega].clear();
  const fs::path log = write_file(dir / "no_omega.csv", csv_text(rows));
  const std::string warning = log.string() + ": measurement 'omega' (\"omega\") had no value at any step";
  const Result evaluated = run_skidimm(eval("--input " + log.string()));
  EXPECT_EQ(evaluated.exit_code, 0) << evaluated.err;
  EXPECT_THAT(evaluated.err, HasSubstr("skidimm eval: warning: " + warning + "\n"));
  const Result checked =
      run_skidimm("validate " + kTerrains + " --plugin-path " + kPlugins + " --check " + log.string());
  EXPECT_THAT(checked.err, HasSubstr("skidimm validate: warning: " + warning + "\n"));
  const Result whole = run_skidimm(eval("--input " + kSwitching));
  EXPECT_THAT(whole.err, Not(HasSubstr("had no value")));
}

// A truth column in another case than the bank's names (ASPHALT for
// asphalt) scores 0: fit and tune refuse it with the case pointed out, eval
// says it beside the truth it cannot score.
TEST(EvalCommand, ATruthInAnotherCaseIsPointedOut) {
  auto rows = skidimm_test::read_csv(kSwitching);
  const std::size_t mode = static_cast<std::size_t>(skidimm_test::column(rows[0], "mode"));
  for (std::size_t i = 1; i < rows.size(); ++i) {
    for (char& c : rows[i][mode]) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  }
  const Result r = run_skidimm(eval("--input " + write_file(test_directory() / "upper.csv", csv_text(rows)).string()));
  EXPECT_THAT(r.out, HasSubstr("truth mode 'GRASS' is not in the bank (10.0 s, always wrong); names are "
                               "case-sensitive: 'grass'?"));
}

// The consistency table is keyed by true mode, whose names may be longer
// than the classes' the confusion table is sized by: each name keeps its
// column (crushed_concrete ran into its number).
TEST(EvalCommand, TheConsistencyTableFitsItsModesNames) {
  const fs::path dir = test_directory();
  const fs::path bank =
      write_file(dir / "paved.yaml", skidimm_test::read_file(kTerrains) +
                                         "\nclasses:\n  paved: [asphalt, crushed_concrete]\n  soft: [grass]\n");
  const Result r = run_skidimm("eval --bank " + bank.string() + " --plugin-path " + kPlugins +
                               " --input crushed_concrete=" + kSwitching);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, ::testing::ContainsRegex("\n    crushed_concrete  [0-9]+\\.[0-9]{2} \\["));
}

TEST(Cli, EvalReportsAccuracyLatencyAndConsistencyAsTextAndJson) {
  const std::string args = "eval --bank " + kSource + "/configs/ltc_terrains.yaml --input " + kSource +
                           "/configs/examples/ltc_switching.csv --plugin-path " + kPlugins;
  const Result text = run_skidimm(args);
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_THAT(text.out, HasSubstr("accuracy (time fraction)"));
  EXPECT_THAT(text.out, HasSubstr("10.01 s  crushed_concrete -> grass: first"));
  EXPECT_THAT(text.out, HasSubstr("state RMSE vs true_<state>: V"));
  EXPECT_THAT(text.out, HasSubstr("consistency of the true mode's filter"));
  const Result json = run_skidimm(args + " --json");
  ASSERT_EQ(json.exit_code, 0) << json.err;
  EXPECT_EQ(json.out.rfind("{\"overall\": {\"logs\": 1,", 0), 0u) << json.out.substr(0, 80);
  EXPECT_THAT(json.out, HasSubstr("\"switches\": [{\"time\": 10.0055, \"from\": \"crushed_concrete\""));
  // The same metrics from the `run` output alone (no NIS, no state truth).
  const fs::path out = test_directory() / "out.csv";
  ASSERT_EQ(run_skidimm("run -q --bank " + kSource + "/configs/ltc_terrains.yaml --input " + kSource +
                        "/configs/examples/ltc_switching.csv --output " + out.string() + " --plugin-path " + kPlugins)
                .exit_code,
            0);
  const Result from_output = run_skidimm("eval --estimates " + out.string());
  ASSERT_EQ(from_output.exit_code, 0) << from_output.err;
  const auto accuracy_line = [](const std::string& s) { return s.substr(s.find("accuracy"), 40); };
  EXPECT_EQ(accuracy_line(from_output.out), accuracy_line(text.out));
  const Result no_truth = run_skidimm("eval --bank " + kSource + "/configs/husky/ice_ltc.yaml --input x.csv");
  EXPECT_EQ(no_truth.exit_code, 1);
  EXPECT_THAT(no_truth.err, HasSubstr("names no columns.truth_mode"));
}

// The bundled bank records where each terrain was fitted (fitted_inputs);
// eval counts the steps outside those ranges. With every terrain fitted on
// wheel speeds in [0, 1] rad/s, a step is outside for every class exactly
// when a wheel turned outside [0, 1]: the share is the rows', counted here
// from the log itself. A bank that records no ranges prints no line.
TEST(EvalCommand, CountsTheStepsOutsideTheInputsTheTerrainsWereFittedOn) {
  const Result bundled = run_skidimm(eval("--input " + kSwitching));
  ASSERT_EQ(bundled.exit_code, 0) << bundled.err;
  EXPECT_THAT(bundled.out, HasSubstr("inputs outside the ranges the classes were fitted on: "));

  std::string narrow = read_file(kTerrains);
  ASSERT_EQ(with_fitted_inputs(&narrow, "{phi_dot_L: [0, 1], phi_dot_R: [0, 1]}"), 3)
      << "one per terrain in " << kTerrains;
  const fs::path narrow_bank = write_file(test_directory() / "narrow.yaml", narrow);
  const RowsOutside outside = switching_rows_outside(0.0, 1.0);
  ASSERT_GT(outside.outside, 0);
  const double share = static_cast<double>(outside.outside) / static_cast<double>(outside.rows);
  const YAML::Node json = json_of(run_skidimm("eval --bank " + narrow_bank.string() + " --plugin-path " + kPlugins +
                                              " --input " + kSwitching + " --json"));
  const YAML::Node e = json["overall"]["extrapolation"];
  ASSERT_TRUE(e.IsMap()) << "overall.extrapolation";
  EXPECT_EQ(e["steps"].as<long>(), outside.rows);
  EXPECT_NEAR(e["outside_estimate"].as<double>(), share, 1e-6);
  EXPECT_NEAR(e["outside_truth"].as<double>(), share, 1e-6);
  EXPECT_THAT(e["farthest"].as<std::string>(), HasSubstr("fitted on 0 to 1)"));

  // The bundled bank with `ranges` as every terrain's fitted inputs ("": none), evaluated with `options`.
  const auto eval_with_ranges = [](const std::string& name, const std::string& ranges, const std::string& options) {
    std::string text = read_file(kTerrains);
    with_fitted_inputs(&text, ranges);
    const fs::path bank = write_file(test_directory() / name, text);
    return run_skidimm("eval --bank " + bank.string() + " --plugin-path " + kPlugins + " --input " + kSwitching +
                       options);
  };
  // Ranges no step leaves: the accuracy is over all the steps, with no empty "of those".
  const Result inside = eval_with_ranges("wide.yaml", "{phi_dot_L: [-1000, 1000], phi_dot_R: [-1000, 1000]}", "");
  ASSERT_EQ(inside.exit_code, 0) << inside.err;
  EXPECT_THAT(inside.out, HasSubstr(": 0.0% of the steps for the most likely class; 0.0% for the true class, the "
                                    "most likely right on "));
  EXPECT_THAT(inside.out, HasSubstr("% of the steps\n"));
  EXPECT_THAT(inside.out, Not(HasSubstr("-%")));

  const Result without = eval_with_ranges("none.yaml", "", "");
  ASSERT_EQ(without.exit_code, 0) << without.err;
  EXPECT_THAT(without.out, Not(HasSubstr("inputs outside")));
  EXPECT_TRUE(json_of(eval_with_ranges("none.yaml", "", " --json"))["overall"]["extrapolation"].IsNull());
}

// The range of accuracy another set of runs would score (accuracy_range.h), on
// real BorealTC runs with the bundled bank: its standard error is the one
// computed here from each run's accuracy in the JSON, the range holds this
// set's own mean, --range-for asks for another set's counts, and a count
// that does not fit the runs' terrains fails the command after the report.
TEST(EvalCommand, SaysWhatRangeAnotherSetOfRunsWouldScoreOnRealRuns) {
  const std::string boreal = std::string(SKIDIMM_SHARED_DATA_DIR) + "/borealtc";
  if (!fs::exists(boreal)) GTEST_SKIP() << "no shared data at " << boreal;
  const auto runs = [&](const std::string& terrain, const std::string& pattern) {
    return " --input '" + terrain + "=" + boreal + "/" + terrain + "/pro_" + pattern + ".csv+" + boreal + "/" +
           terrain + "/imu_" + pattern + ".csv'";
  };
  // ICE 10, 11 and SNOW 21, 22, 24, 25: four runs beyond each terrain's first.
  const std::string command = "eval --bank " + kSource + "/configs/borealtc/terrains.yaml --plugin-path " + kPlugins +
                              runs("ICE", "1*") + runs("SNOW", "2*");
  const YAML::Node json = json_of(run_skidimm(command + " --json"));
  std::map<std::string, std::vector<double>> by_terrain;
  for (const auto& log : json["logs"]) {
    const YAML::Node per_class = log.second["mean_over_classes"]["per_class"];
    ASSERT_EQ(per_class.size(), 1u) << log.first.as<std::string>();
    for (const auto& c : per_class)
      by_terrain[c.first.as<std::string>()].push_back(log.second["accuracy"].as<double>());
  }
  ASSERT_EQ(by_terrain["ICE"].size(), 2u);
  ASSERT_EQ(by_terrain["SNOW"].size(), 4u);
  // The spread of runs about their terrain's mean, pooled: sum of squares
  // over sum_c (n_c - 1); this mean's standard error s sqrt(sum_c 1 / n_c) / C.
  double mean = 0.0, squares = 0.0, inverse_counts = 0.0;
  int degrees = 0;
  for (const auto& [terrain, accuracies] : by_terrain) {
    double m = 0.0;
    for (double a : accuracies) m += a / static_cast<double>(accuracies.size());
    for (double a : accuracies) squares += (a - m) * (a - m);
    mean += m / 2.0;
    degrees += static_cast<int>(accuracies.size()) - 1;
    inverse_counts += 1.0 / static_cast<double>(accuracies.size());
  }
  const YAML::Node overall = json["overall"]["mean_over_classes"];
  const YAML::Node range = overall["range"];
  ASSERT_TRUE(range.IsMap()) << "overall.mean_over_classes.range";
  EXPECT_NEAR(overall["accuracy"].as<double>(), mean, 1e-5);
  EXPECT_EQ(range["degrees_of_freedom"].as<int>(), degrees);
  EXPECT_NEAR(range["standard_error"].as<double>(), std::sqrt(squares / degrees * inverse_counts) / 2.0, 1e-5);
  EXPECT_EQ(range["level"].as<double>(), 0.9);
  EXPECT_LT(range["low"].as<double>(), mean);
  EXPECT_GT(range["high"].as<double>(), mean);
  EXPECT_EQ(range["logs_per_class"]["ICE"].as<int>(), 2);
  EXPECT_EQ(range["logs_per_class"]["SNOW"].as<int>(), 4);
  // Each group's range is its own runs': ICE's two say nothing of how runs
  // differ (one beyond its first), and a run alone has no range.
  const YAML::Node ice = json["groups"].begin()->second["mean_over_classes"]["range"];
  EXPECT_TRUE(ice["low"].IsNull());
  EXPECT_EQ(ice["logs_per_class"]["ICE"].as<int>(), 2);
  EXPECT_TRUE(json["logs"].begin()->second["mean_over_classes"]["range"].IsNull());

  const Result text = run_skidimm(command + " --range-for ICE=4,SNOW=9");
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_THAT(text.out, HasSubstr("another 13 logs drawn like these (ICE 4, SNOW 9) would score a mean over classes "
                                  "between "));
  const YAML::Node asked = json_of(run_skidimm(command + " --range-for ICE=4,SNOW=9 --json"));
  EXPECT_EQ(asked["overall"]["mean_over_classes"]["range"]["logs_per_class"]["SNOW"].as<int>(), 9);
  EXPECT_EQ(asked["overall"]["mean_over_classes"]["range"]["standard_error"].as<double>(),
            range["standard_error"].as<double>());

  // A terrain left out: the report is printed whole, then the command fails.
  const Result missing = run_skidimm(command + " --range-for ICE=4");
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_THAT(missing.out, HasSubstr("confusion"));
  EXPECT_THAT(missing.err, HasSubstr("--range-for: the other set leaves out class 'SNOW'"));
  // Not CLASS=COUNT: refused before any run is read.
  const Result bad = run_skidimm(command + " --range-for ICE=four");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_THAT(bad.err, HasSubstr("'ICE=four' is not CLASS=COUNT"));
  EXPECT_EQ(bad.out, "");
  // One report's range, where lists of decision settings make a report each: refused before anything is read.
  const Result grid = run_skidimm("eval --estimates " + (test_directory() / "none.csv").string() +
                                  " --decision-enter 0.6,0.8 --range-for ICE=4");
  EXPECT_EQ(grid.exit_code, 2);
  EXPECT_THAT(grid.err, HasSubstr("--range-for gives the range of one report's accuracy"));
}

TEST(Cli, EvalTakesDecisionSettingsAndRemakesARunsDecisionFromItsProbabilities) {
  const fs::path dir = test_directory();
  const std::string bank = kSource + "/configs/ltc_terrains.yaml",
                    log = kSource + "/configs/examples/ltc_switching.csv";
  const std::string settings = " --decision-enter 0.6 --decision-hold 0.2";
  ASSERT_EQ(run_skidimm("run -q --bank " + bank + " --input " + log + " --output " + (dir / "given.csv").string() +
                        settings + " --plugin-path " + kPlugins)
                .exit_code,
            0);
  ASSERT_EQ(run_skidimm("run -q --bank " + bank + " --input " + log + " --output " + (dir / "default.csv").string() +
                        " --plugin-path " + kPlugins)
                .exit_code,
            0);
  // The decision's JSON scores, from "accuracy" to "lost".
  const auto decision_of = [](const Result& r) {
    EXPECT_EQ(r.exit_code, 0) << r.err;
    const std::size_t begin = r.out.find("\"decision\": {\"accuracy\"");
    const std::size_t end = r.out.find("\"lost\"", begin);
    return begin == std::string::npos || end == std::string::npos ? std::string() : r.out.substr(begin, end - begin);
  };
  const std::string written = decision_of(run_skidimm("eval --json --estimates " + (dir / "given.csv").string()));
  ASSERT_FALSE(written.empty());
  EXPECT_EQ(decision_of(run_skidimm("eval --json --bank " + bank + " --input " + log + settings + " --plugin-path " +
                                    kPlugins)),
            written)
      << "eval runs the bank with the settings run was given";
  EXPECT_EQ(decision_of(run_skidimm("eval --json --estimates " + (dir / "default.csv").string() + settings)), written)
      << "the decision made again from the probabilities of a run with the bank's own settings";
  EXPECT_NE(decision_of(run_skidimm("eval --json --estimates " + (dir / "default.csv").string())), written)
      << "the settings change the decision on this log";
  // The table says how the decision it scores was made.
  EXPECT_THAT(run_skidimm("eval --bank " + bank + " --input " + log + settings + " --plugin-path " + kPlugins).out,
              HasSubstr("decision (enter 0.6, leave 0.05, hold 0.2 s): accuracy"));
  EXPECT_THAT(run_skidimm("eval --estimates " + (dir / "default.csv").string() + settings).out,
              HasSubstr("decision (made again: enter 0.6, leave 0.05, hold 0.2 s): accuracy"));
  EXPECT_THAT(run_skidimm("eval --estimates " + (dir / "default.csv").string()).out,
              HasSubstr("decision (the files' decision column): accuracy"));
  const Result bad =
      run_skidimm("eval --estimates " + (dir / "default.csv").string() + " --decision-enter 0.05 --decision-leave 0.1");
  EXPECT_EQ(bad.exit_code, 2) << "a bad command line";
  EXPECT_THAT(bad.err, HasSubstr("need 0 <= leave < enter <= 1, got enter 0.05, leave 0.1"));
}

// Lists of decision settings score every combination on the files read
// once: each combination's report is, to the byte, what eval with that one
// setting prints.
TEST(Cli, EvalComparesListsOfDecisionSettingsAsEachAlone) {
  const fs::path dir = test_directory();
  const std::string bank = kSource + "/configs/ltc_terrains.yaml",
                    log = kSource + "/configs/examples/ltc_switching.csv";
  for (const char* name : {"a.csv", "b.csv"}) {  // the second run with another bank's decision column
    ASSERT_EQ(run_skidimm("run -q --bank " + bank + " --input " + log + " --output " + (dir / name).string() +
                          (name[0] == 'b' ? " --decision-enter 0.7" : "") + " --plugin-path " + kPlugins)
                  .exit_code,
              0);
  }
  const std::string estimates = " --estimates " + (dir / "a.csv").string() + " --estimates " + (dir / "b.csv").string();
  const Result compared =
      run_skidimm("eval --json --bank " + bank + estimates + " --decision-enter 0.6,0.9 --decision-hold 0.2,1,3");
  ASSERT_EQ(compared.exit_code, 0) << compared.err;
  const YAML::Node settings = json_of(compared)["decision_settings"];
  ASSERT_EQ(settings.size(), 6u);
  std::vector<std::string> reports;
  std::size_t k = 0;
  for (const char* enter : {"0.6", "0.9"}) {
    for (const char* hold : {"0.2", "1", "3"}) {
      SCOPED_TRACE(std::string(enter) + " " + hold);
      EXPECT_EQ(settings[k]["enter"].as<std::string>(), enter) << "enter slowest, hold fastest";
      EXPECT_EQ(settings[k]["hold"].as<std::string>(), hold);
      EXPECT_EQ(settings[k]["leave"].as<double>(), 0.05) << "the bank's leave where none is given";
      const Result alone = run_skidimm("eval --json --bank " + bank + estimates + " --decision-enter " + enter +
                                       " --decision-hold " + hold);
      ASSERT_EQ(alone.exit_code, 0) << alone.err;
      const std::size_t at = compared.out.find("\"report\": " + alone.out.substr(0, alone.out.size() - 1) + "}");
      EXPECT_NE(at, std::string::npos) << "the report of this setting is what eval with it alone prints";
      reports.push_back(alone.out);
      ++k;
    }
  }
  EXPECT_NE(reports.front(), reports.back()) << "the settings change the decision on these runs";
  // The table: a row per setting, after the most likely class's accuracy, said once.
  const Result table =
      run_skidimm("eval --bank " + bank + estimates + " --decision-enter 0.6,0.9 --decision-hold 0.2,1,3");
  ASSERT_EQ(table.exit_code, 0) << table.err;
  EXPECT_THAT(table.out, HasSubstr("decision settings compared on 2 log(s); the most likely class, the same for each: "
                                   "accuracy "));
  EXPECT_THAT(table.out, HasSubstr("\n  0.9      0.05     3         "));
  // Lists need files a filter wrote: a bad command line, before anything runs.
  const Result without =
      run_skidimm("eval --bank " + bank + " --input " + log + " --decision-enter 0.6,0.9 --plugin-path " + kPlugins);
  EXPECT_EQ(without.exit_code, 2) << without.err;
  EXPECT_THAT(without.err, HasSubstr("lists of --decision-* settings are compared on files a filter already wrote"));
  // Each setting is checked as a bank's would be.
  const Result bad = run_skidimm("eval" + estimates + " --decision-enter 0.9,0.05 --decision-leave 0.1");
  EXPECT_EQ(bad.exit_code, 2) << "a bad command line";
  EXPECT_THAT(bad.err, HasSubstr("need 0 <= leave < enter <= 1, got enter 0.05, leave 0.1"));
}

// --likelihood-weight and --innovation-gate are the bank's own settings,
// given on the command line as `run` takes them: eval with the option scores
// exactly what eval of a bank file holding the same value scores. With
// --estimates there is no filter for them to change, and eval says so.
TEST(Cli, EvalTakesTheFiltersSettingsAsTheBankWouldHoldThem) {
  const fs::path dir = test_directory();
  const std::string settings = "likelihood_weight: 0.05\ninnovation_gate: 0.999\n";
  const std::string bank = write_file(dir / "tempered.yaml", read_file(kTerrains) + "\n" + settings).string();
  const std::string scores = "--json --input " + kSwitching + " --plugin-path " + kPlugins;
  const Result from_file = run_skidimm("eval --bank " + bank + " " + scores);
  ASSERT_EQ(from_file.exit_code, 0) << from_file.err;
  const Result given = run_skidimm(eval(scores + " --likelihood-weight 0.05 --innovation-gate 0.999"));
  ASSERT_EQ(given.exit_code, 0) << given.err;
  EXPECT_EQ(given.out, from_file.out);
  EXPECT_NE(run_skidimm(eval(scores)).out, from_file.out) << "the settings change the scores on this log";

  ASSERT_EQ(run_skidimm("run -q --bank " + kTerrains + " --input " + kSwitching + " --output " +
                        (dir / "run.csv").string() + " --plugin-path " + kPlugins)
                .exit_code,
            0);
  for (const std::string option : {"--likelihood-weight 0.5", "--innovation-gate 0.99"}) {
    const Result refused = run_skidimm("eval --estimates " + (dir / "run.csv").string() + " " + option);
    EXPECT_EQ(refused.exit_code, 2) << option;
    EXPECT_THAT(refused.err, HasSubstr(option.substr(0, option.find(' ')) + " changes how the filter runs")) << option;
  }
  const Result bad = run_skidimm(eval(scores + " --likelihood-weight 1.5"));
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_THAT(bad.err, HasSubstr("--likelihood-weight"));
}

TEST(Cli, ClassesScoreSeveralModesAsOne) {
  const fs::path dir = test_directory();
  std::string bank = read_file(kSource + "/configs/ltc_terrains.yaml");
  bank += "classes:\n  soft: [grass, crushed_concrete]\n";
  write_file(dir / "classes.yaml", bank);
  const Result eval = run_skidimm("eval --bank " + (dir / "classes.yaml").string() + " --input " + kSource +
                                  "/configs/examples/ltc_switching.csv --plugin-path " + kPlugins);
  ASSERT_EQ(eval.exit_code, 0) << eval.err;
  EXPECT_THAT(eval.out, HasSubstr("soft asphalt"));  // the confusion's columns: classes
  // Grass taken for crushed concrete is now right: the class accuracy is at least the mode accuracy.
  const std::string key = "accuracy (time fraction)";
  ASSERT_NE(eval.out.find(key), std::string::npos);
  EXPECT_GE(std::stod(eval.out.substr(eval.out.find(key) + key.size())), 0.976);
}

}  // namespace
}  // namespace skidimm_test
