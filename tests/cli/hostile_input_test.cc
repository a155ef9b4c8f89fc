// End-to-end: what an attacker or a careless user can give `skidimm` ends
// in a clear error, a bounded amount of work and output, and nothing
// already computed lost: corrupt time stamps under a fixed rate, column
// expressions outside the language, files that give nothing, endless lines,
// two runs writing one output, FIFOs and huge files on the plugin path, and
// impossible tune settings.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "cli/cli_test_support.h"
#include "core/sanitizer.h"
#include "skidimm/io/csv.h"

namespace skidimm_test {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
namespace fs = std::filesystem;

long data_rows(const fs::path& csv) {
  skidimm::CsvReader reader(csv);
  std::vector<std::string> fields;
  long rows = 0;
  while (reader.next(&fields)) ++rows;
  return rows;
}

// The bundled terrain bank with its columns' section replaced.
fs::path bank_with(const fs::path& dir, const std::string& name, const std::string& columns_and_sampling) {
  std::string bank = read_file(kTerrains);
  const std::string from = "columns:\n  time: t\n  truth_mode: mode";
  const auto at = bank.find(from);
  EXPECT_NE(at, std::string::npos);
  bank.replace(at, from.size(), columns_and_sampling);
  return write_file(dir / name, bank);
}

TEST(HostileInput, AFixedRateStopsAtACorruptTimeStampAndKeepsTheRowsBefore) {
  const fs::path dir = test_directory();
  for (const std::string& stamp : {std::string("1e9"), std::string("1e300")}) {
    std::string log = read_file(kSwitching);
    // The 201st data row's time.
    std::size_t at = 0;
    for (int line = 0; line < 201; ++line) at = log.find('\n', at) + 1;
    log.replace(at, log.find(',', at) - at, stamp);
    const fs::path input = write_file(dir / "corrupt.csv", log);
    const fs::path out = dir / "out.csv";
    fs::remove(out.string() + ".partial");
    const Result r = run_shell(kSkidimm + " run --rate 100 --bank " + kTerrains + " --plugin-path " + kPlugins +
                               " --input " + input.string() + " --output " + out.string());
    EXPECT_EQ(r.exit_code, 1) << stamp << ": " << r.err;
    EXPECT_THAT(r.err, HasSubstr("corrupt.csv:202: column 't': the log has no row from t = "));
    EXPECT_THAT(r.err, HasSubstr("longer than sampling.max_gap (10 s)"));
    EXPECT_FALSE(fs::exists(out));
    ASSERT_TRUE(fs::exists(out.string() + ".partial")) << r.err;
    EXPECT_LT(fs::file_size(out.string() + ".partial"), 1u << 20) << "the grid stopped at the gap";
    EXPECT_GT(data_rows(out.string() + ".partial"), 300) << "the steps before the gap are kept";
  }
  // Told to, the grid skips the gap and the run succeeds, saying so.
  const fs::path skipping = bank_with(dir, "skipping.yaml",
                                      "columns:\n  time: t\n  truth_mode: mode\nsampling:\n  rate: 100\n  "
                                      "skip_gaps: true");
  std::string log = read_file(kSwitching);
  std::size_t at = 0;
  for (int line = 0; line < 1487; ++line) at = log.find('\n', at) + 1;
  log.replace(at, log.find(',', at) - at, "1e7");
  const fs::path paused = write_file(dir / "paused.csv", log);
  const Result r = run_shell(kSkidimm + " run --bank " + skipping.string() + " --plugin-path " + kPlugins +
                             " --input " + paused.string() + " --output " + (dir / "skipped.csv").string());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.err, HasSubstr("1 gap(s) without rows longer than sampling.max_gap (10 s) were skipped"));
}

// A row written twice in the middle of a real log (a recorder that wrote a
// message again): run stops there, keeps the steps before it and says how to
// go on; a bank that leaves such rows out runs the whole log, as it runs the
// log without the copy, and says it left one out.
TEST(HostileInput, ARowWrittenTwiceStopsTheRunOrIsLeftOutWhenTheBankSaysSo) {
  const fs::path dir = test_directory();
  const std::string log = read_file(kSwitching);
  std::size_t at = 0;
  for (int line = 0; line < 300; ++line) at = log.find('\n', at) + 1;
  const std::string row = log.substr(at, log.find('\n', at) + 1 - at);
  const fs::path twice = write_file(dir / "twice.csv", log.substr(0, at) + row + log.substr(at));
  const fs::path out = dir / "out.csv";
  const Result stopped = run_shell(kSkidimm + " run --bank " + kTerrains + " --plugin-path " + kPlugins + " --input " +
                                   twice.string() + " --output " + out.string());
  EXPECT_EQ(stopped.exit_code, 1) << stopped.err;
  EXPECT_THAT(stopped.err, HasSubstr("twice.csv:302: column 't': time must increase strictly"));
  EXPECT_THAT(stopped.err, HasSubstr("sampling.skip_out_of_order: true in the bank"));
  EXPECT_GT(data_rows(out.string() + ".partial"), 250) << "the steps before the copy are kept";
  const fs::path lenient =
      bank_with(dir, "lenient.yaml", "columns:\n  time: t\n  truth_mode: mode\nsampling:\n  skip_out_of_order: true");
  const Result left_out = run_shell(kSkidimm + " run --bank " + lenient.string() + " --plugin-path " + kPlugins +
                                    " --input " + twice.string() + " --output " + (dir / "left_out.csv").string());
  EXPECT_EQ(left_out.exit_code, 0) << left_out.err;
  EXPECT_THAT(left_out.err, HasSubstr("1 row(s) whose time was not after their file's last row were left out "
                                      "(sampling.skip_out_of_order), the first at " +
                                      twice.string() + ":302: t = "));
  const Result original = run_shell(kSkidimm + " run --bank " + lenient.string() + " --plugin-path " + kPlugins +
                                    " --input " + kSwitching + " --output " + (dir / "original.csv").string());
  EXPECT_EQ(original.exit_code, 0) << original.err;
  EXPECT_EQ(read_file(dir / "left_out.csv"), read_file(dir / "original.csv"));
  // eval scores the log without the copy, and says so (not as a warning: the bank asked for it).
  const Result scored = run_shell(kSkidimm + " eval --bank " + lenient.string() + " --plugin-path " + kPlugins +
                                  " --input " + twice.string() + " --json");
  EXPECT_EQ(scored.exit_code, 0) << scored.err;
  EXPECT_THAT(scored.err, HasSubstr("skidimm eval: " + twice.string() +
                                    ": 1 row(s) whose time was not after their "
                                    "file's last row were left out (sampling.skip_out_of_order), the first at " +
                                    twice.string() + ":302: t = "));
  // So do fit and tune, which fit the log without it.
  const std::string said = twice.string() +
                           ": 1 row(s) whose time was not after their file's last row were left out "
                           "(sampling.skip_out_of_order), the first at " +
                           twice.string() + ":302: t = ";
  const Result fitted = run_shell(kSkidimm + " fit --objective window --bank " + lenient.string() + " --plugin-path " +
                                  kPlugins + " --log " + twice.string());
  EXPECT_EQ(fitted.exit_code, 0) << fitted.err;
  EXPECT_THAT(fitted.err, HasSubstr("skidimm fit: " + said));
  const Result tuned = run_shell(kSkidimm + " tune -q --no-assess --tune likelihood-weight --bank " + lenient.string() +
                                 " --plugin-path " + kPlugins + " --log " + twice.string() + " --log " + kSwitching);
  EXPECT_EQ(tuned.exit_code, 0) << tuned.err;
  EXPECT_THAT(tuned.err, HasSubstr("skidimm tune: " + said));
  EXPECT_THAT(tuned.err, Not(HasSubstr("skidimm tune: " + kSwitching + ":"))) << "a log with nothing left out";
}

TEST(HostileInput, ARateFarAboveTheLogsIsRefusedByFitAndRun) {
  const fs::path dir = test_directory();
  std::string log = "t,phi_dot_L,phi_dot_R,V,omega,mode\n";
  for (int k = 0; k < 800; ++k) log += std::to_string(0.01 * k) + ",1,1.1,0.3,0.02,asphalt\n";
  const fs::path input = write_file(dir / "eight_seconds.csv", log);
  const Result fit = run_shell(kSkidimm + " fit --rate 1e6 --bank " + kTerrains + " --plugin-path " + kPlugins +
                               " --log asphalt=" + input.string());
  EXPECT_EQ(fit.exit_code, 1) << fit.err;
  EXPECT_THAT(fit.err, HasSubstr("eight_seconds.csv: the filter's rate"));
  EXPECT_THAT(fit.err, HasSubstr("a grid may take at most 1000 steps per row"));
  const Result run = run_shell(run_command(kTerrains, input.string(), (dir / "out.csv").string()) + " --rate 1e6");
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_THAT(run.err, HasSubstr("at most 1000 steps per row"));
  const Result huge = run_shell(kSkidimm + " eval --rate 1e300 --bank " + kTerrains + " --plugin-path " + kPlugins +
                                " --input " + input.string());
  EXPECT_NE(huge.exit_code, 0);
  EXPECT_THAT(huge.err, HasSubstr("at most 1e6"));
}

TEST(HostileInput, ExpressionsOutsideTheLanguageAreRefusedNamingTheBankAndField) {
  const fs::path dir = test_directory();
  const struct {
    std::string expression, says;
  } cases[] = {
      {"phi_dot_L = 3", "assignment ('=') is not part of the language"},
      {"phi_dot_L, phi_dot_R", "a ',' outside the arguments of min() or max()"},
      {"mean(V) + _skidimm_step99", "names starting with '_' are reserved"},
      {"mean((V)", "unbalanced parentheses"},
  };
  for (const auto& c : cases) {
    const fs::path bank = bank_with(dir, "bank.yaml",
                                    "columns:\n  time: t\n  truth_mode: mode\n  measurements:\n    V: \"" +
                                        c.expression + "\"\nsampling:\n  rate: 50");
    const Result r = run_shell(run_command(bank.string(), kSwitching, (dir / "out.csv").string()));
    EXPECT_EQ(r.exit_code, 1) << c.expression;
    EXPECT_THAT(r.err, HasSubstr(bank.string() + ": columns.measurements.V")) << c.expression;
    EXPECT_THAT(r.err, HasSubstr(c.says)) << c.expression;
    EXPECT_FALSE(fs::exists(dir / "out.csv"));
  }
  // A NUL in the expression (YAML "\0") ends nothing early.
  const fs::path nul = bank_with(
      dir, "nul.yaml", "columns:\n  time: t\n  truth_mode: mode\n  inputs:\n    phi_dot_L: \"phi_dot_L\\0+1\"");
  const Result r = run_shell(run_command(nul.string(), kSwitching, (dir / "out.csv").string()));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("columns.inputs.phi_dot_L"));
  EXPECT_THAT(r.err, HasSubstr("a control character (byte 0)"));
  // A 1 MB expression: refused, and the message quotes a short excerpt.
  const fs::path huge = bank_with(dir, "huge.yaml",
                                  "columns:\n  time: t\n  truth_mode: mode\n  inputs:\n    phi_dot_L: \"phi_dot_L" +
                                      std::string(1 << 20, '+') + "1\"");
  const Result long_one = run_shell(run_command(huge.string(), kSwitching, (dir / "out.csv").string()));
  EXPECT_EQ(long_one.exit_code, 1);
  EXPECT_THAT(long_one.err, HasSubstr("more than an expression may have (1024)"));
  EXPECT_LT(long_one.err.size(), 1000u);
}

TEST(HostileInput, AFileThatGivesNothingIsAnErrorNamingIt) {
  const fs::path dir = test_directory();
  // The switching log split into wheels (inputs) and a sensor file (V, omega).
  std::ifstream in(kSwitching);
  std::string line, wheels, sensors;
  bool header = true;
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::size_t begin = 0;
    for (int c = 0; c < 5; ++c) {
      const std::size_t end = line.find(',', begin);
      cells.push_back(line.substr(begin, end - begin));
      begin = end + 1;
    }
    wheels += cells[0] + "," + cells[1] + "," + cells[2] + "\n";
    sensors += cells[0] + "," + cells[3] + "," + cells[4] + "\n";
    header = false;
  }
  (void)header;
  const fs::path pro = write_file(dir / "pro.csv", wheels), imu = write_file(dir / "imu.csv", sensors);
  const fs::path bank = bank_with(dir, "bank.yaml", "columns:\n  time: t");
  const fs::path out = dir / "out.csv";
  ASSERT_EQ(run_shell(run_command(bank.string(), pro.string() + "+" + imu.string(), out.string())).exit_code, 0);
  // An offset that moves every sensor row past the wheels' end.
  const Result late = run_shell(run_command(bank.string(), pro.string() + "+" + imu.string() + "@1e6", out.string()));
  EXPECT_EQ(late.exit_code, 1);
  EXPECT_THAT(late.err, HasSubstr("imu.csv: none of its 1487 row(s) was used"));
  EXPECT_THAT(late.err, HasSubstr("with its offset of 1e+06 s"));
  // A sensor file with its header only.
  const fs::path empty = write_file(dir / "empty_imu.csv", "t,V,omega\n");
  const Result none = run_shell(run_command(bank.string(), pro.string() + "+" + empty.string(), out.string()));
  EXPECT_EQ(none.exit_code, 1);
  EXPECT_THAT(none.err, HasSubstr("empty_imu.csv:1: the file has a header but no data rows: its columns V, omega"));
  // A symlink loop and a directory where a log file is expected.
  fs::create_symlink(dir / "loop.csv", dir / "loop.csv");
  const Result loop =
      run_shell(run_command(bank.string(), pro.string() + "+" + (dir / "loop.csv").string(), out.string()));
  EXPECT_EQ(loop.exit_code, 1);
  EXPECT_THAT(loop.err, HasSubstr("loop.csv: cannot read: Too many levels of symbolic links"));
  // A binary file (here the start of a program) is said to be one.
  const fs::path binary = write_file(dir / "program.csv", std::string("\x7f"
                                                                      "ELF\x02\x01\x01\0\0\0,x\n1,2\n",
                                                                      17));
  const Result binary_run = run_shell(run_command(bank.string(), binary.string(), out.string()));
  EXPECT_EQ(binary_run.exit_code, 1);
  EXPECT_THAT(binary_run.err, HasSubstr("program.csv:1: binary data, not CSV text (its first line holds a NUL byte)"));
  // run reads one log, where fit, tune and eval read a directory's runs.
  const Result directory = run_shell(run_command(bank.string(), dir.string(), out.string()));
  EXPECT_EQ(directory.exit_code, 1);
  EXPECT_THAT(directory.err, HasSubstr("is a directory, not a log file (a directory names the runs of fit, tune and "
                                       "eval; run reads one)"));
  // And a column that is empty in every row is said in the summary.
  std::string no_omega;
  std::ifstream again(imu);
  while (std::getline(again, line))
    no_omega += line.substr(0, line.rfind(',')) + (no_omega.empty() ? ",omega\n" : ",\n");
  const fs::path blank = write_file(dir / "blank_imu.csv", no_omega);
  const Result blank_run = run_shell(kSkidimm + " run --bank " + bank.string() + " --plugin-path " + kPlugins +
                                     " --input " + pro.string() + "+" + blank.string() + " --output " + out.string());
  EXPECT_EQ(blank_run.exit_code, 0) << blank_run.err;
  EXPECT_THAT(blank_run.err, HasSubstr("measurement 'omega' (\"omega\") had no value at any step"));
}

TEST(HostileInput, AnEndlessLineOnStandardInputIsRefusedAtTheCap) {
  const fs::path dir = test_directory();
  // 64 MB of NUL bytes, then 64 MB of one header line.
  const Result nul = run_shell("head -c 67108864 /dev/zero | " + run_command(kTerrains, "-", (dir / "a.csv").string()));
  EXPECT_EQ(nul.exit_code, 1) << nul.err;
  EXPECT_THAT(nul.err, HasSubstr("standard input:1: a line longer than 1048576 bytes: not a CSV log"));
  const Result header = run_shell("{ printf t; head -c 67108864 /dev/zero | tr '\\0' 'x'; } | " +
                                  run_command(kTerrains, "-", (dir / "b.csv").string()));
  EXPECT_EQ(header.exit_code, 1) << header.err;
  EXPECT_THAT(header.err, HasSubstr("a line longer than 1048576 bytes"));
  // A data line too, with the rows before it kept.
  const Result row = run_shell("{ head -n 100 " + kSwitching + "; head -c 4194304 /dev/zero | tr '\\0' 1; } | " +
                               run_command(kTerrains, "-", (dir / "c.csv").string()));
  EXPECT_EQ(row.exit_code, 1) << row.err;
  EXPECT_THAT(row.err, HasSubstr("standard input:101: a line longer than 1048576 bytes"));
  // A header of 100,000 columns is read in linear time (the check for
  // duplicate names compared every pair).
  std::string wide = "t";
  for (int c = 0; c < 100000; ++c) wide += ",c" + std::to_string(c);
  const Result many = run_shell("printf '" + wide + "\\n' | " + run_command(kTerrains, "-", (dir / "d.csv").string()));
  EXPECT_EQ(many.exit_code, 1);
  EXPECT_THAT(many.err, HasSubstr("no column 'phi_dot_L'"));
  EXPECT_LT(many.err.size(), 2000u);
}

TEST(HostileInput, TwoRunsWritingOneOutputNeverMix) {
  const fs::path dir = test_directory();
  const fs::path out = dir / "out.csv";
  // Two different logs: each run's output is whole and one run's own.
  const fs::path reference_a = dir / "a.csv", reference_b = dir / "b.csv";
  const std::string stc = kSource + "/configs/examples/stc_switching.csv";
  const std::string stc_bank = kSource + "/configs/stc_slip4.yaml";
  ASSERT_EQ(run_shell(run_command(kTerrains, kSwitching, reference_a.string())).exit_code, 0);
  ASSERT_EQ(run_shell(run_command(stc_bank, stc, reference_b.string())).exit_code, 0);
  const std::string a = read_file(reference_a), b = read_file(reference_b);
  for (int attempt = 0; attempt < 5; ++attempt) {
    fs::remove(out);
    const Result r = run_shell(
        run_command(kTerrains, kSwitching, out.string()) + " & a=$!; " + run_command(stc_bank, stc, out.string()) +
        " & b=$!; " + run_command(kTerrains, kSwitching, out.string()) + " & c=$!; wait $a && wait $b && wait $c");
    EXPECT_EQ(r.exit_code, 0) << r.err;
    const std::string written = read_file(out);
    EXPECT_TRUE(written == a || written == b) << "attempt " << attempt << ": " << written.size() << " bytes";
    EXPECT_EQ(written.find('\0'), std::string::npos);
  }
  for (const auto& entry : fs::directory_iterator(dir)) {
    EXPECT_EQ(entry.path().string().find(".partial"), std::string::npos) << "left behind: " << entry.path();
  }
  // A directory as the output: refused before anything is computed.
  const Result directory = run_shell(run_command(kTerrains, kSwitching, dir.string()));
  EXPECT_EQ(directory.exit_code, 1);
  EXPECT_THAT(directory.err, HasSubstr(dir.string() + ": is a directory"));
  // The log itself as the output (another path to it): refused, the log kept.
  const fs::path log = write_file(dir / "log.csv", read_file(kSwitching));
  const Result itself = run_shell(run_command(kTerrains, log.string(), (dir / "." / "log.csv").string()));
  EXPECT_EQ(itself.exit_code, 1);
  EXPECT_THAT(itself.err, HasSubstr("is the log file " + log.string() + " itself"));
  EXPECT_EQ(read_file(log), read_file(kSwitching));
  // The bank as the output, or the figure over the output: refused, the bank kept.
  const fs::path bank = write_file(dir / "bank.yaml", read_file(kTerrains));
  const Result over_bank = run_shell(run_command(bank.string(), kSwitching, (dir / "." / "bank.yaml").string()));
  EXPECT_EQ(over_bank.exit_code, 1);
  EXPECT_THAT(over_bank.err, HasSubstr("--output " + (dir / "." / "bank.yaml").string() + " is the file of --bank (" +
                                       bank.string() + "), which this command reads"));
  EXPECT_EQ(read_file(bank), read_file(kTerrains));
  const fs::path figure = dir / "figure.svg";
  const Result figure_over_output =
      run_shell(run_command(kTerrains, kSwitching, figure.string()) + " --plot " + figure.string());
  EXPECT_EQ(figure_over_output.exit_code, 1);
  EXPECT_THAT(figure_over_output.err, HasSubstr("--output and --plot name the same file (" + figure.string() + ")"));
  EXPECT_FALSE(fs::exists(figure));
  // A .npy output's reason table (x.npy -> x.reasons.json) over the log: refused, the log kept.
  const fs::path json_log = write_file(dir / "x.reasons.json", read_file(kSwitching));
  const Result over_log = run_shell(run_command(kTerrains, json_log.string(), (dir / "x.npy").string()));
  EXPECT_EQ(over_log.exit_code, 1);
  EXPECT_THAT(over_log.err, HasSubstr("--output's reason table " + json_log.string() + " is the log file"));
  EXPECT_EQ(read_file(json_log), read_file(kSwitching));
  // An empty output path was found only when renaming into place, after the
  // whole run; a figure that is not .png or .svg only after it too.
  const Result empty = run_shell(run_command(kTerrains, kSwitching, "''"));
  EXPECT_EQ(empty.exit_code, 2);
  EXPECT_THAT(empty.err, HasSubstr("--output: expected a file path"));
  const Result text_figure =
      run_shell(run_command(kTerrains, kSwitching, (dir / "e.csv").string()) + " --plot " + (dir / "f.txt").string());
  EXPECT_EQ(text_figure.exit_code, 2);
  EXPECT_THAT(text_figure.err,
              HasSubstr("--plot " + (dir / "f.txt").string() + ": the figure must end in .png or .svg"));
  EXPECT_FALSE(fs::exists(dir / "e.csv")) << "refused before the run";
  for (const std::string& command :
       {"simulate --scenario " + kSource + "/configs/scenarios/ltc_switching.yaml --output ''",
        "fit --bank " + kTerrains + " --log " + kSwitching + " --output-bank ''",
        "tune --bank " + kTerrains + " --log " + kSwitching + " --table ''"}) {
    const Result r = run_skidimm(command);
    EXPECT_EQ(r.exit_code, 2) << command;
    EXPECT_THAT(r.err, HasSubstr(": expected a file path")) << command;
  }
  // Devices are not files: two outputs to /dev/null are no clash.
  const Result discarded = run_shell(run_command(kTerrains, kSwitching, "/dev/null"));
  EXPECT_EQ(discarded.exit_code, 0) << discarded.err;
  // tune wrote no held-out steps for an empty --estimates, with exit 0.
  const Result no_folder = run_skidimm("tune --bank " + kTerrains + " --log " + kSwitching + " --estimates ''");
  EXPECT_EQ(no_folder.exit_code, 2) << no_folder.err;
  EXPECT_THAT(no_folder.err, HasSubstr("--estimates: expected a directory path"));
  // plot's figure of another kind is a bad command line, as run --plot's is (it exited 1).
  const fs::path estimates = dir / "plotted.csv";
  ASSERT_EQ(run_shell(run_command(kTerrains, kSwitching, estimates.string())).exit_code, 0);
  const Result pdf = run_skidimm("plot --estimates " + estimates.string() + " --output " + (dir / "f.pdf").string());
  EXPECT_EQ(pdf.exit_code, 2) << pdf.err;
  EXPECT_THAT(pdf.err, HasSubstr("--output " + (dir / "f.pdf").string() + ": the figure must end in .png or .svg"));
  EXPECT_FALSE(fs::exists(dir / "f.pdf"));
}

// Options that cannot apply are refused, not ignored: an innovation gate of 1
// (which passes everything, like 0) got past the command line to fail after
// the bank was loaded, with exit 1; eval --estimates dropped --input and
// scored the files alone, with exit 0.
TEST(HostileInput, OptionsThatCannotApplyAreABadCommandLine) {
  const Result gate = run_shell(run_command(kTerrains, kSwitching, "/dev/null") + " --innovation-gate 1");
  EXPECT_EQ(gate.exit_code, 2) << gate.err;
  EXPECT_THAT(gate.err, HasSubstr("--innovation-gate: expected a probability in (0, 1), or 0 for none, got '1'"));
  EXPECT_EQ(run_shell(run_command(kTerrains, kSwitching, "/dev/null") + " --innovation-gate 0").exit_code, 0);
  const fs::path dir = test_directory();
  const fs::path estimates = dir / "estimates.csv";
  ASSERT_EQ(run_shell(run_command(kTerrains, kSwitching, estimates.string())).exit_code, 0);
  for (const std::string& option :
       {"--input " + kSwitching, std::string("--smooth"), std::string("--lag 1"), std::string("--rate 10")}) {
    const Result r = run_skidimm("eval --estimates " + estimates.string() + " " + option);
    EXPECT_EQ(r.exit_code, 2) << option << ": " << r.err;
    EXPECT_THAT(r.err, HasSubstr(option.substr(0, option.find(' ')) + " is for logs the bank is run over")) << option;
    EXPECT_EQ(r.out, "") << option;
  }
  EXPECT_EQ(run_skidimm("eval --estimates " + estimates.string()).exit_code, 0);
  // An .mcap output given to what reads estimates as CSV was told it came
  // through a pipe and to give it to --input, as a log.
  const fs::path mcap = dir / "estimates.mcap";
  ASSERT_EQ(run_shell(run_command(kTerrains, kSwitching, mcap.string())).exit_code, 0);
  for (const std::string& command : {"eval --estimates " + mcap.string(),
                                     "plot --estimates " + mcap.string() + " --output " + (dir / "f.png").string()}) {
    const Result r = run_skidimm(command);
    EXPECT_EQ(r.exit_code, 1) << command;
    EXPECT_THAT(r.err, HasSubstr(mcap.string() + ":1: an MCAP file, not CSV: this reads CSV here")) << command;
    EXPECT_THAT(r.err, HasSubstr("estimates `skidimm run` wrote as .mcap are JSON messages for Foxglove: for eval or "
                                 "plot, run again with --output X.csv"))
        << command;
    EXPECT_THAT(r.err, Not(HasSubstr("pipe"))) << command;
  }
}

// What is wrong with an input is said: a pattern given to run (which reads
// one log) and a bank through a pipe were both "no such ... file".
TEST(HostileInput, APatternForRunAndABankThroughAPipeAreSaidForWhatTheyAre) {
  const Result pattern = run_shell(run_command(kTerrains, "'" + kSource + "/configs/examples/ltc_*.csv'", "/dev/null"));
  EXPECT_EQ(pattern.exit_code, 1);
  EXPECT_THAT(pattern.err, HasSubstr("no such log file (a pattern with '*' names the runs of fit, tune and eval; run "
                                     "reads one)"));
  // A shell's other wildcards are no pattern here.
  const Result bracket = run_skidimm("eval --bank " + kTerrains + " --plugin-path " + kPlugins + " --input '" +
                                     kSource + "/configs/examples/ltc_switch[a-z]ng.csv'");
  EXPECT_EQ(bracket.exit_code, 1);
  EXPECT_THAT(bracket.err, HasSubstr("no such log file (a pattern takes '*' alone, not '?' or '[...]')"));
  const Result piped = run_shell(kSkidimm + " run -q --bank <(cat " + kTerrains + ") --plugin-path " + kPlugins +
                                 " --input " + kSwitching + " --output /dev/null");
  EXPECT_EQ(piped.exit_code, 1);
  EXPECT_THAT(piped.err, HasSubstr("is not a regular file (a pipe or a device): give the bank as a file"));
}

TEST(HostileInput, PluginPathsOpenOnlyRegularFilesAndSurviveHugeOnes) {
  const fs::path dir = test_directory();
  const fs::path fifo = dir / "fifo.so";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  for (const std::string& path : {fifo.string(), dir.string()}) {
    const Result r = run_shell(kSkidimm + " plugins --plugin-path " + path);
    EXPECT_EQ(r.exit_code, 0) << path << ": " << r.err;
    EXPECT_THAT(r.out + r.err, HasSubstr("not a plugin file: a FIFO")) << path;
  }
  const fs::path bank = bank_with(dir, "bank.yaml", "columns:\n  time: t\n  truth_mode: mode");
  const Result run =
      run_shell(kSkidimm + " run -q --bank " + bank.string() + " --plugin-path " + fifo.string() + " --plugin-path " +
                kPlugins + " --input " + kSwitching + " --output " + (dir / "out.csv").string());
  EXPECT_EQ(run.exit_code, 0) << run.err;
  // An 8 GB sparse file: refused by its size, never read.
  fs::create_directories(dir / "huge");
  std::ofstream(dir / "huge/eight_gb.so").close();
  fs::resize_file(dir / "huge/eight_gb.so", std::uintmax_t{8} << 30);
  const Result huge = run_shell(kSkidimm + " plugins --plugin-path " + (dir / "huge").string());
  EXPECT_EQ(huge.exit_code, 0) << huge.err;
  EXPECT_THAT(huge.out + huge.err, HasSubstr("eight_gb.so"));
  EXPECT_THAT(huge.out + huge.err, HasSubstr("larger than a plugin can be (1073741824 bytes)"));
  // 900 MB under an address-space limit of 800 MB: running out of memory
  // while reading it is a rejected plugin, not an abort. (A sanitizer's
  // runtime cannot start under such a limit.)
  if (SKIDIMM_SANITIZED) return;
  fs::remove(dir / "huge/eight_gb.so");
  std::ofstream(dir / "huge/nine_hundred_mb.so").close();
  fs::resize_file(dir / "huge/nine_hundred_mb.so", std::uintmax_t{900} << 20);
  const Result limited =
      run_shell("ulimit -v 800000; " + kSkidimm + " plugins --plugin-path " + (dir / "huge").string());
  EXPECT_EQ(limited.exit_code, 0) << limited.err;
  EXPECT_THAT(limited.out + limited.err, HasSubstr("nine_hundred_mb.so"));
  EXPECT_THAT(limited.out + limited.err, HasSubstr("out of memory while reading or loading it"));
}

TEST(HostileInput, NumberOptionsMustBeFinite) {
  const fs::path dir = test_directory();
  const std::string run = kSkidimm + " run -q --bank " + kTerrains + " --plugin-path " + kPlugins + " --input " +
                          kSwitching + " --output " + (dir / "out.csv").string();
  for (const std::string& option : {std::string("--rate nan"), std::string("--rate inf"), std::string("--lag nan"),
                                    std::string("--decision-enter nan"), std::string("--decision-hold inf"),
                                    std::string("--innovation-gate nan")}) {
    const Result r = run_shell(run + " " + option);
    EXPECT_EQ(r.exit_code, 2) << option << ": " << r.err;
    EXPECT_THAT(r.err, HasSubstr("expected a finite number")) << option;
  }
  const Result fit = run_shell(kSkidimm + " fit --objective window --window nan --bank " + kTerrains + " --log asphalt=" +
                               kSwitching);
  EXPECT_EQ(fit.exit_code, 2) << fit.err;
  EXPECT_THAT(fit.err, HasSubstr("expected a finite number, got 'nan'"));
  // Out of range, said in a few words (CLI11 printed DBL_MAX's 309 digits), and
  // --rate's upper bound on the command line, not only in the library's message.
  for (const auto& [option, message] : std::vector<std::pair<std::string, std::string>>{
           {"--rate 0", "--rate: expected a number > 0 and at most 1e6, got '0'"},
           {"--rate 1e7", "--rate: expected a number > 0 and at most 1e6, got '1e7'"},
           {"--lag -1", "--lag: expected a number >= 0, got '-1'"},
           {"--decision-hold -2", "--decision-hold: expected a number >= 0, got '-2'"}}) {
    const Result r = run_shell(run + " " + option);
    EXPECT_EQ(r.exit_code, 2) << option << ": " << r.err;
    EXPECT_THAT(r.err, HasSubstr(message)) << option;
    EXPECT_LT(r.err.size(), 200u) << option;
  }
  // --flush with an output written whole at the end: a bad command line, before the output is opened.
  for (const std::string output : {"flushed.mcap", "flushed.npy"}) {
    const Result flushed = run_shell(kSkidimm + " run -q --bank " + kTerrains + " --plugin-path " + kPlugins +
                                     " --input " + kSwitching + " --flush --output " + (dir / output).string());
    EXPECT_EQ(flushed.exit_code, 2) << output << ": " << flushed.err;
    EXPECT_THAT(flushed.err, HasSubstr("--flush writes CSV rows as they are computed"));
    EXPECT_FALSE(fs::exists(dir / (output + ".partial"))) << output;
  }
  // A loss scale at which the robust loss underflows (1e-170 made the cost NaN, blamed on the logs).
  const Result scale = run_shell(kSkidimm + " fit --objective window --loss cauchy --loss-scale 1e-170 --bank " +
                                 kTerrains + " --log asphalt=" + kSwitching);
  EXPECT_EQ(scale.exit_code, 2) << scale.err;
  EXPECT_THAT(scale.err, HasSubstr("--loss-scale: expected a number >= 0.001 and at most 1e6, got '1e-170'"));
  // The bank's bound on the decision's hold holds for the command line too (1e308 s was taken), and
  // settings the command line gave that cannot be are a bad command line (exit 2; it was 1).
  const Result hold = run_shell(run + " --decision-hold 1e308");
  EXPECT_EQ(hold.exit_code, 2) << hold.err;
  EXPECT_THAT(hold.err, HasSubstr("the command line's settings: decision hold: need min_hold >= 0 s and under "
                                  "1e9 s, got 1e+308"));
  const Result crossed = run_shell(run + " --decision-enter 0.5 --decision-leave 0.7");
  EXPECT_EQ(crossed.exit_code, 2) << crossed.err;
  EXPECT_THAT(crossed.err, HasSubstr("decision thresholds: need 0 <= leave < enter <= 1, got enter 0.5, leave 0.7"));
  EXPECT_FALSE(fs::exists(dir / "out.csv"));
  // Lists of decision settings are crossed: 1010 combinations would each score every file again.
  std::string enters = "0.5";
  for (int k = 1; k <= 100; ++k) enters += "," + std::to_string(0.5 + 0.001 * k);
  const Result grid = run_shell(kSkidimm + " eval --estimates " + (dir / "any.csv").string() + " --decision-enter " +
                                enters + " --decision-leave 0.01,0.02,0.03,0.04,0.05,0.06,0.07,0.08,0.09,0.1");
  EXPECT_EQ(grid.exit_code, 2) << grid.err;
  EXPECT_THAT(grid.err, HasSubstr("lists of --decision-* settings make 1010 combinations; at most 1000 are compared"));
}

// Two logs from the switching example, for tune.
std::string two_logs(const fs::path& dir) {
  std::ifstream in(kSwitching);
  std::string header, line, first, second;
  std::getline(in, header);
  for (int k = 0; std::getline(in, line); ++k) (k < 740 ? first : second) += line + "\n";
  return " --log " + write_file(dir / "first.csv", header + "\n" + first).string() + " --log " +
         write_file(dir / "second.csv", header + "\n" + second).string();
}

TEST(HostileInput, TuneRefusesOneFoldAndClampsItsThreadsToTheCores) {
  const fs::path dir = test_directory();
  const std::string tune = kSkidimm + " tune -q --bank " + kTerrains + " --plugin-path " + kPlugins + two_logs(dir) +
                           " --objective none --no-assess";
  for (const std::string& option : {std::string("--folds 1"), std::string("--inner-folds 1")}) {
    const Result r = run_shell(tune + " " + option);
    EXPECT_EQ(r.exit_code, 2) << option << ": " << r.err;
    EXPECT_THAT(r.err, HasSubstr("expected 0 (leave one log out) or a number of groups from 2 to 1000, got '1'"))
        << option;
  }
  const Result many = run_shell(tune + " --threads 1000000 --table " + (dir / "many.csv").string());
  const Result two = run_shell(tune + " --threads 2 --table " + (dir / "two.csv").string());
  ASSERT_EQ(many.exit_code, 0) << many.err;
  ASSERT_EQ(two.exit_code, 0) << two.err;
  EXPECT_EQ(many.out, two.out) << "the same choice, as fast as with the cores";
}

}  // namespace
}  // namespace skidimm_test
