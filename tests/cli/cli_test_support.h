// What the end-to-end tests of the `skidimm` executable share: running it,
// or a shell script around it, with its output captured; the bundled files
// they run it on; reading back what it wrote.
#ifndef SKIDIMM_TESTS_CLI_CLI_TEST_SUPPORT_H_
#define SKIDIMM_TESTS_CLI_CLI_TEST_SUPPORT_H_

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "core/temp_files.h"
#include "skidimm/io/csv.h"

namespace skidimm_test {

inline const std::string kSource = SKIDIMM_SOURCE_DIR;
inline const std::string kPlugins = SKIDIMM_PLUGIN_DIR;               // the bundled plugins
inline const std::string kFixturePlugins = SKIDIMM_TEST_PLUGIN_ROOT;  // the tests' own, broken on purpose
inline const std::string kSkidimm = SKIDIMM_EXECUTABLE;
inline const std::string kTerrains = kSource + "/configs/ltc_terrains.yaml";
inline const std::string kSwitching = kSource + "/configs/examples/ltc_switching.csv";

struct Result {
  int exit_code;
  std::string out;
  std::string err;
};

// Where one test process captures a command's output: named after the test
// (ctest runs the tests of a file in parallel) and beside its
// test_directory(), which would empty it.
inline std::filesystem::path capture_directory(const std::string& kind) {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const std::filesystem::path dir =
      std::filesystem::path(::testing::TempDir()) /
      ("skidimm_" + kind + "_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir;
}

// Runs a shell command line with standard input from /dev/null, its stdout
// and stderr captured.
inline Result run_captured(const std::string& command, const std::filesystem::path& dir) {
  const int status = std::system(
      (command + " > " + (dir / "out").string() + " 2> " + (dir / "err").string() + " < /dev/null").c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, read_file(dir / "out"), read_file(dir / "err")};
}

// `skidimm <arguments>` through the shell.
inline Result run_skidimm(const std::string& arguments) {
  return run_captured(kSkidimm + " " + arguments, capture_directory("cli_capture"));
}

// A bash script; a hang is ended by `timeout` and shows as exit code 124.
inline Result run_shell(const std::string& script) {
  const std::filesystem::path dir = capture_directory("cli_shell");
  write_file(dir / "script.sh", script + "\n");
  return run_captured("timeout 300 bash " + (dir / "script.sh").string(), dir);
}

// A bash script whose pipelines fail when any of their commands does (pipefail).
inline Result run_pipeline(const std::string& script) { return run_shell("set -o pipefail\n" + script); }

// `command` fails (exit 1) with `message` on stderr, before `not_reached`
// (what the work it refused would have printed) appears there.
inline void expect_refused_before(const std::string& command, const std::string& message,
                                  const std::string& not_reached) {
  SCOPED_TRACE(command);
  const Result r = run_pipeline(command);
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find(message), std::string::npos) << "no '" << message << "' in:\n" << r.err;
  EXPECT_EQ(r.err.find(not_reached), std::string::npos) << "'" << not_reached << "' reached:\n" << r.err;
}

// The command line of `skidimm run`, quiet, over one input.
// ltc_terrains' asphalt and a mode whose plugin fails as `failure` says above 0.5 m/s.
inline std::filesystem::path faulty_bank(const std::filesystem::path& dir, const std::string& failure) {
  return write_file(dir / "faulty.yaml", R"(
name: faulty
states: [V, omega]
inputs: [phi_dot_L, phi_dot_R]
columns: {time: t, truth_mode: mode}
measurement:
  observe: [V, omega]
  R: {std: [0.05, 0.02]}
transition: {mean_dwell_time: 10.0}
initial:
  covariance: {std: [0.5, 0.5]}
modes:
  - name: asphalt
    model: ltc_linear
    params: {A: [[-36.28555, 0.935196], [0.5454627, -29.78963]], B: [[3.164964, 2.846713], [-4.866783, 4.78034]]}
    Q: [[0.00556329, 0], [0, 0.003817253]]
  - name: slippery
    model: faulty_model
    params: {failure: )" + failure + R"(, above: 0.5}
    Q: {diagonal: [0.01, 0.01]}
)");
}

// The bundled switching example with every mode but asphalt named
// `slippery`: a log of faulty_bank()'s modes.
inline std::string slippery_switching_log() {
  std::string log = read_file(kSource + "/configs/examples/ltc_switching.csv");
  for (const std::string other : {"grass", "crushed_concrete"}) {
    for (std::size_t at = log.find(other); at != std::string::npos; at = log.find(other, at)) {
      log.replace(at, other.size(), "slippery");
    }
  }
  return log;
}

inline std::string run_command(const std::string& bank, const std::string& input, const std::string& output) {
  return kSkidimm + " run -q --bank " + bank + " --plugin-path " + kPlugins + " --input " + input + " --output " +
         output;
}

// `bank_text` with every mode's `fitted_inputs:` line replaced by `ranges`
// (e.g. "{phi_dot_L: [0, 1]}"), or removed where `ranges` is empty; the
// number of lines replaced.
inline int with_fitted_inputs(std::string* bank_text, const std::string& ranges) {
  const std::string key = "    fitted_inputs: {";
  std::string::size_type at = 0;
  int replaced = 0;
  while ((at = bank_text->find(key, at)) != std::string::npos) {
    const std::string::size_type end = bank_text->find('\n', at);
    if (ranges.empty()) {
      bank_text->erase(at, end + 1 - at);
    } else {
      bank_text->replace(at, end - at, "    fitted_inputs: " + ranges);
      ++at;
    }
    ++replaced;
  }
  return replaced;
}

// A CSV file's rows, the header first.
inline std::vector<std::vector<std::string>> read_csv(const std::filesystem::path& path) {
  skidimm::CsvReader reader(path);
  std::vector<std::vector<std::string>> rows{reader.header()};
  std::vector<std::string> fields;
  while (reader.next(&fields)) rows.push_back(fields);
  return rows;
}

// The index of column `name` in `header` (a test failure if absent).
inline int column(const std::vector<std::string>& header, const std::string& name) {
  for (std::size_t i = 0; i < header.size(); ++i) {
    if (header[i] == name) return static_cast<int>(i);
  }
  ADD_FAILURE() << "no column " << name;
  return 0;
}

// How many rows of the bundled switching log have a wheel speed
// (phi_dot_L, phi_dot_R) outside [lowest, highest], of how many, and that
// share as a run's or tune's summary prints it ("12.5%").
struct RowsOutside {
  long outside = 0;
  long rows = 0;
  std::string percent;
};

inline RowsOutside switching_rows_outside(double lowest, double highest) {
  const auto rows = read_csv(kSwitching);
  const int left = column(rows[0], "phi_dot_L"), right = column(rows[0], "phi_dot_R");
  RowsOutside r;
  r.rows = static_cast<long>(rows.size()) - 1;
  for (std::size_t i = 1; i < rows.size(); ++i) {
    const double l = std::stod(rows[i][static_cast<std::size_t>(left)]);
    const double w = std::stod(rows[i][static_cast<std::size_t>(right)]);
    r.outside += l < lowest || l > highest || w < lowest || w > highest;
  }
  char text[32];
  std::snprintf(text, sizeof(text), "%.1f%%", 100.0 * static_cast<double>(r.outside) / static_cast<double>(r.rows));
  r.percent = text;
  return r;
}

// The switching example's header and first row alone, in `dir`: a log too
// short to score (a step stands for the time to the next).
inline std::filesystem::path one_row_log(const std::filesystem::path& dir) {
  std::ifstream in(kSwitching);
  std::string header, first_row;
  std::getline(in, header);
  std::getline(in, first_row);
  return write_file(dir / "one_row.csv", header + "\n" + first_row + "\n");
}

// configs/ltc_terrains.yaml measuring V alone, in `dir`: a bank with a state
// (omega) that no measurement observes.
inline std::filesystem::path terrains_measuring_v_only(const std::filesystem::path& dir) {
  std::string text = read_file(kTerrains);
  for (const auto& [from, to] :
       {std::make_pair(std::string("observe: [V, omega]"), std::string("observe: [V]")),
        std::make_pair(std::string("R: {std: [0.05, 0.02]}"), std::string("R: {std: [0.05]}"))}) {
    EXPECT_NE(text.find(from), std::string::npos) << from;
    if (text.find(from) != std::string::npos) text.replace(text.find(from), from.size(), to);
  }
  return write_file(dir / "v_only.yaml", text);
}

// Rows as CSV text.
inline std::string csv_text(const std::vector<std::vector<std::string>>& rows) {
  std::string text;
  for (const auto& row : rows) {
    for (std::size_t i = 0; i < row.size(); ++i) text += (i ? "," : "") + row[i];
    text += "\n";
  }
  return text;
}

// The bundled switching example as a log in two files at two rates, written
// into `dir`: inputs and V at 10 Hz (slow.csv), omega at 50 Hz (fast.csv).
struct SplitLog {
  std::filesystem::path slow, fast;
  long fast_rows = 0;
};
inline SplitLog split_example(const std::filesystem::path& dir) {
  const auto rows = read_csv(kSwitching);
  const auto& h = rows[0];
  std::string slow = "t,phi_dot_L,phi_dot_R,V,mode\n", fast = "t,omega\n";
  SplitLog log;
  for (std::size_t i = 1; i < rows.size(); ++i) {
    const auto& r = rows[i];
    fast += r[column(h, "t")] + "," + r[column(h, "omega")] + "\n";
    ++log.fast_rows;
    if (i % 5 == 1) {
      slow += r[column(h, "t")] + "," + r[column(h, "phi_dot_L")] + "," + r[column(h, "phi_dot_R")] + "," +
              r[column(h, "V")] + "," + r[column(h, "mode")] + "\n";
    }
  }
  log.slow = write_file(dir / "slow.csv", slow);
  log.fast = write_file(dir / "fast.csv", fast);
  return log;
}

}  // namespace skidimm_test

#endif  // SKIDIMM_TESTS_CLI_CLI_TEST_SUPPORT_H_
