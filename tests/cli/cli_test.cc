// End to end, what every `skidimm` command shares: usage errors and help,
// progress only on a terminal, logs that cannot be read twice from a pipe,
// writes onto a full disk, and bad cells named by file, line and column.
// Each command's own tests are in <command>_command_test.cc.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "cli/cli_test_support.h"

namespace skidimm_test {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

TEST(Cli, UsageErrorsExitWithTwoAndHelpWithZero) {
  // `skidimm` alone is a newcomer asking what it does: the usage, not an error.
  const Result alone = run_skidimm("");
  EXPECT_EQ(alone.exit_code, 0);
  EXPECT_THAT(alone.out, HasSubstr("Usage: skidimm [OPTIONS] SUBCOMMAND"));
  EXPECT_THAT(alone.out, HasSubstr("Subcommands:"));
  EXPECT_EQ(run_skidimm("--frobnicate").exit_code, 2) << "an option, but no command";
  EXPECT_EQ(run_skidimm("run --bank").exit_code, 2);
  // A first word that names no command is named, with the commands there are.
  const Result unknown = run_skidimm("explain --bank x");
  EXPECT_EQ(unknown.exit_code, 2);
  EXPECT_THAT(unknown.err, HasSubstr("skidimm: unknown command 'explain'; the commands: run, validate, simulate, fit, "
                                     "tune, eval, plot, plugins, new-plugin, bag"));
  const Result missing_path = run_skidimm("plugins --plugin-path /no/such/dir");
  EXPECT_EQ(missing_path.exit_code, 2);
  EXPECT_THAT(missing_path.err, HasSubstr("/no/such/dir"));
  // A bank file that does not exist is a bad command line too, named (docs/cli.md's exit codes).
  const Result missing_bank = run_skidimm("run --bank /no/such/bank.yaml --input /no/such/log.csv");
  EXPECT_EQ(missing_bank.exit_code, 2);
  EXPECT_THAT(missing_bank.err, HasSubstr("--bank: File does not exist: /no/such/bank.yaml"));
  // A mistyped required option is named, not only the option it left out
  // (CLI11 checks what is required first: "--output is required" alone).
  const Result typo = run_skidimm("run --bank " + kTerrains + " --input " + kSwitching + " --ouput o.csv");
  EXPECT_EQ(typo.exit_code, 2);
  EXPECT_THAT(typo.err, HasSubstr("The following arguments were not expected: --ouput o.csv"));
  EXPECT_THAT(typo.err, HasSubstr("--output is required"));
  const Result only_missing = run_skidimm("run --bank " + kTerrains + " --input " + kSwitching);
  EXPECT_EQ(only_missing.exit_code, 2);
  EXPECT_THAT(only_missing.err, HasSubstr("--output is required"));
  EXPECT_THAT(only_missing.err, ::testing::Not(HasSubstr("not expected")));
  // In the order given (CLI11 lists them backwards).
  const Result extras = run_skidimm("run --bank " + kTerrains + " --input " + kSwitching + " --output o.csv --smoth x");
  EXPECT_EQ(extras.exit_code, 2);
  EXPECT_THAT(extras.err, HasSubstr("The following arguments were not expected: --smoth x\n"));
  EXPECT_THAT(run_skidimm("eval --input " + kSwitching + " --bnak").err,
              HasSubstr("The following argument was not expected: --bnak\n"));
  const Result help = run_skidimm("run --help");
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_THAT(help.out, HasSubstr("--plugin-path"));
  // Every command's help ends with examples and where to read more.
  for (const char* command :
       {"run", "bag", "validate", "simulate", "fit", "tune", "eval", "plot", "plugins", "new-plugin"}) {
    const Result h = run_skidimm(std::string(command) + " --help");
    EXPECT_EQ(h.exit_code, 0) << command;
    EXPECT_THAT(h.out, ::testing::ContainsRegex("\nExamples:\n  skidimm " + std::string(command) + "[ \n]"))
        << command;
    EXPECT_THAT(h.out.substr(h.out.rfind("\n", h.out.size() - 2) + 1),
                ::testing::StartsWith("More: docs/cli.md#skidimm-" + std::string(command)))
        << command;
  }
}

// Options a command cannot honour together are a bad command line: exit 2,
// a message naming them, and nothing read or written (one of them used to be
// ignored without a word, or to fail with 1 like a bad file).
TEST(Cli, OptionsThatCannotBeHonouredTogetherExitWithTwo) {
  const fs::path dir = test_directory();
  const std::string bank = " --bank " + kTerrains + " --plugin-path " + kPlugins;
  const std::string scenario = " --scenario " + kSource + "/configs/scenarios/ltc_switching.yaml";
  const std::string out = " --output " + (dir / "out.csv").string();
  const std::string two_logs =
      " --log " + kSwitching + " --log " + write_file(dir / "copy.csv", read_file(kSwitching)).string();
  const struct {
    std::string arguments, message;
  } clashes[] = {
      {"fit" + bank + " --log " + kSwitching + " --shared",
       "--shared fits the bank-level (shared:) parameters by the window objective only: add --objective window"},
      // Said before the logs are read: a missing one does not hide it.
      {"tune" + bank + two_logs + " --log " + (dir / "missing.csv").string() + " --assess sessions",
       "--assess sessions needs --sessions FILE"},
      {"run" + bank + " --input " + kSwitching + out + " --smooth --lag 1",
       "smooth (over the whole log) and lag (smoothing with a fixed lag) exclude each other"},
      {"eval" + bank + " --input " + kSwitching + " --smooth --lag 1",
       "smooth (over the whole log) and lag (smoothing with a fixed lag) exclude each other"},
      {"eval --input " + kSwitching, "give --bank with --input, or --estimates"},
      {"simulate" + scenario + bank + out, "give either --scenario or --bank, not both"},
      {"simulate" + out, "give --scenario (the physical simulator) or --bank with --inputs-from"},
      {"simulate" + bank + out, "--bank needs --inputs-from LOG"},
      {"simulate" + bank + " --inputs-from " + kSwitching + " --duration 5" + out, "--duration is the scenario's"},
      {"simulate" + scenario + " --inputs-from " + kSwitching + out, "--inputs-from drives a bank's models"},
      {"simulate" + scenario + " --rate 10" + out, "--rate steps a bank's models"},
      {"fit" + bank + " --log " + kSwitching + " --objective window --fit-r", "--fit-r is an option of the likelihood"},
      {"fit" + bank + " --log " + kSwitching + " --output-noise",
       "--output-noise is an option of the window objective"},
      {"run" + bank + " --input " + kSwitching + out + " --serve 99999", "a port from 0 (any free port) to 65535"},
      {"run" + bank + " --input " + kSwitching + out + " --serve localhost:0", "'localhost' is not an IP address"},
      {"run" + bank + " --input " + kSwitching + out + " --serve-speed 2", "--serve-speed requires --serve"},
      {"plot --estimates " + kSwitching + out + " --log " + kSwitching + " --rate 10",
       "--rate reads --log through the bank's columns, which needs --bank and --log"},
  };
  for (const auto& c : clashes) {
    const Result r = run_skidimm(c.arguments);
    EXPECT_EQ(r.exit_code, 2) << c.arguments << "\n" << r.err;
    EXPECT_THAT(r.err, HasSubstr(c.message)) << c.arguments;
    EXPECT_FALSE(fs::exists(dir / "out.csv")) << c.arguments;
  }
}

// Progress (rate, time left) is for a person at a terminal: a stderr
// captured to a file gets none of it, so what a script logs is the same from
// run to run; on a terminal (a pseudo-terminal from script(1)) run shows how
// far it is, in rows.
TEST(Cli, RunAndFitShowProgressOnlyOnATerminal) {
  const fs::path dir = test_directory();
  const std::string bank = kSource + "/configs/ltc_terrains.yaml";
  const std::string log = kSource + "/configs/examples/ltc_switching.csv";  // 1487 rows: one update, at row 1024
  const std::string run = "run --bank " + bank + " --input " + log + " --output " + (dir / "out.csv").string() +
                          " --plugin-path " + kPlugins;
  const Result captured = run_skidimm(run);
  ASSERT_EQ(captured.exit_code, 0) << captured.err;
  EXPECT_THAT(captured.err, HasSubstr("skidimm run: bank 'ltc_terrains'"));  // the summary stays
  EXPECT_EQ(captured.err.find('\r'), std::string::npos);
  EXPECT_THAT(captured.err, ::testing::Not(HasSubstr("rows/s")));
  // The window objective: the same progress, a fraction of the likelihood's solve.
  const Result fit = run_skidimm("fit --objective window --bank " + bank + " --log " + log + " --output-bank " +
                                 (dir / "fitted.yaml").string() + " --plugin-path " + kPlugins);
  ASSERT_EQ(fit.exit_code, 0) << fit.err;
  EXPECT_EQ(fit.err.find('\r'), std::string::npos);
  EXPECT_THAT(fit.err, ::testing::Not(HasSubstr("iterations/s")));

  if (std::system("script --version > /dev/null 2>&1") != 0) GTEST_SKIP() << "no script(1) for a pseudo-terminal";
  const fs::path transcript = dir / "terminal.txt";
  const std::string command = "script -qec '" + std::string(SKIDIMM_EXECUTABLE) + " " + run + "' /dev/null > " +
                              transcript.string() + " 2>&1 < /dev/null";
  ASSERT_EQ(std::system(command.c_str()), 0) << read_file(transcript);
  const std::string terminal = read_file(transcript);
  EXPECT_THAT(terminal, HasSubstr("\rskidimm run: "));
  // The rate and time left join after a second (format_rate_and_time_left,
  // tested on its own): this run is faster, so the line ends at the rows.
  EXPECT_THAT(terminal, HasSubstr("%  1024 rows\x1b[K"));
  EXPECT_THAT(terminal, HasSubstr("\r\x1b[Kskidimm run: bank 'ltc_terrains'"))
      << "the line is cleared before the summary";
}

TEST(CliIo, CommandsThatReadALogTwiceRefuseAPipeAndSaySo) {
  const fs::path dir = test_directory();
  const Result tune = run_pipeline("cat " + kSwitching + " | " + kSkidimm + " tune --bank " + kTerrains +
                                " --plugin-path " + kPlugins + " --log - --log " + kSwitching);
  EXPECT_EQ(tune.exit_code, 1);
  EXPECT_THAT(tune.err, HasSubstr("-: standard input can be read only once (standard input, a pipe or a FIFO), but tune "
                                  "reads each log more than once: save it to a file first"));
  // run --plot reads its estimates again, not its log: a piped input is
  // drawn, a piped output is refused before the run.
  const Result plot =
      run_pipeline("cat " + kSwitching + " | " + run_command(kTerrains, "-", (dir / "out.csv").string()) + " --plot " +
                   (dir / "figure.png").string());
  EXPECT_EQ(plot.exit_code, 0) << plot.err;
  EXPECT_TRUE(fs::exists(dir / "figure.png"));
  const Result piped = run_pipeline(run_command(kTerrains, kSwitching, "-") + " --plot " +
                                    (dir / "piped.png").string() + " > /dev/null");
  EXPECT_EQ(piped.exit_code, 2);
  EXPECT_THAT(piped.err, HasSubstr("--plot reads the estimates again after the run, which --output -"));
  EXPECT_FALSE(fs::exists(dir / "piped.png"));
}

TEST(CliIo, WritesOntoAFullDiskFailWithTheReasonAndLeaveNoFile) {
  const fs::path dir = test_directory();
  // A file-size limit of 0 (with SIGXFSZ ignored) makes every write to a
  // regular file fail, as a full disk does; stderr goes through a pipe.
  const std::string limited = "trap '' XFSZ; ulimit -f 0; ";
  const fs::path entry = dir / "entry.yaml";
  const Result fit = run_pipeline("(" + limited + kSkidimm + " fit --bank " + kTerrains + " --plugin-path " + kPlugins +
                               " --objective window --log " + kSwitching + " --output-entry " + entry.string() +
                               ") 2>&1 | cat >&2");
  EXPECT_EQ(fit.exit_code, 1) << fit.err;
  EXPECT_THAT(fit.err, HasSubstr(entry.string() + ".partial: cannot write: File too large"));
  EXPECT_FALSE(fs::exists(entry));
  EXPECT_FALSE(fs::exists(entry.string() + ".partial"));
  const fs::path out = dir / "out.csv";
  const Result run = run_pipeline("(" + limited + run_command(kTerrains, kSwitching, out.string()) + ") 2>&1 | cat >&2");
  EXPECT_EQ(run.exit_code, 1) << run.err;
  EXPECT_THAT(run.err, HasSubstr(out.string() + ".partial: cannot write: File too large"));
  EXPECT_FALSE(fs::exists(out));
  EXPECT_FALSE(fs::exists(out.string() + ".partial"));
  // A device is written in place, never replaced by a renamed file.
  const Result full = run_pipeline(kSkidimm + " fit --bank " + kTerrains + " --plugin-path " + kPlugins +
                                " --objective window --log " + kSwitching + " --output-entry /dev/full");
  EXPECT_EQ(full.exit_code, 1);
  EXPECT_THAT(full.err, HasSubstr("/dev/full: cannot write: No space left on device"));
  const Result run_full = run_pipeline(run_command(kTerrains, kSwitching, "/dev/full"));
  EXPECT_EQ(run_full.exit_code, 1);
  EXPECT_THAT(run_full.err, HasSubstr("/dev/full: cannot write: No space left on device"));
  const Result run_null = run_pipeline(run_command(kTerrains, kSwitching, "/dev/null"));
  EXPECT_EQ(run_null.exit_code, 0) << run_null.err;
  EXPECT_TRUE(fs::is_character_file("/dev/null"));
  EXPECT_TRUE(fs::is_character_file("/dev/full"));
  EXPECT_FALSE(fs::exists("/dev/null.partial"));
  const Result to_pipe = run_pipeline(run_command(kTerrains, kSwitching, "/dev/stdout") + " | cat > /dev/null");
  EXPECT_EQ(to_pipe.exit_code, 0) << "CSV to a pipe: " << to_pipe.err;
}

TEST(CliIo, BadCellsNameTheFileLineColumnAndWhatWasExpected) {
  const fs::path dir = test_directory();
  // A true_<state> cell that is not a number, in the log eval runs over.
  std::ifstream in(kSwitching);
  std::string text, line;
  for (int row = 0; std::getline(in, line) && row < 50; ++row) {
    if (row == 20) {  // column 12, true_V
      std::size_t at = 0;
      for (int comma = 0; comma < 11; ++comma) at = line.find(',', at) + 1;
      line = line.substr(0, at) + "fast" + line.substr(line.find(',', at));
    }
    text += line + "\n";
  }
  const fs::path bad_truth = write_file(dir / "bad_truth.csv", text);
  const Result truth = run_pipeline(kSkidimm + " eval --bank " + kTerrains + " --plugin-path " + kPlugins + " --input " +
                                 bad_truth.string());
  EXPECT_EQ(truth.exit_code, 1);
  EXPECT_THAT(truth.err, HasSubstr(bad_truth.string() + ":21: column 12 ('true_V'): expected a finite number"));
  EXPECT_THAT(truth.err, HasSubstr("got 'fast'"));
  // A subnormal cell is a number: the nearest double, as strtod reads it.
  text.replace(text.find("fast"), 4, "1e-320");
  write_file(bad_truth, text);
  const Result subnormal = run_pipeline(kSkidimm + " eval --bank " + kTerrains + " --plugin-path " + kPlugins +
                                     " --input " + bad_truth.string());
  EXPECT_EQ(subnormal.exit_code, 0) << subnormal.err;

  // eval --estimates: the output of run, then broken in each way.
  const fs::path estimates = dir / "estimates.csv";
  ASSERT_EQ(run_pipeline(run_command(kTerrains, kSwitching, estimates.string())).exit_code, 0);
  std::vector<std::string> lines;
  {
    std::ifstream e(estimates);
    while (std::getline(e, line)) lines.push_back(line);
  }
  auto with_row = [&](std::size_t index, const std::string& replacement) {
    std::string out;
    for (std::size_t i = 0; i < lines.size() && i < 40; ++i) out += (i == index ? replacement : lines[i]) + "\n";
    return write_file(dir / "broken.csv", out);
  };
  auto cells = [&](std::size_t index) {
    std::vector<std::string> c;
    std::stringstream row(lines[index]);
    std::string cell;
    while (std::getline(row, cell, ',')) c.push_back(cell);
    if (!lines[index].empty() && lines[index].back() == ',') c.push_back("");  // an empty last cell (reason)
    return c;
  };
  auto join = [](const std::vector<std::string>& c) {
    std::string out;
    for (const std::string& x : c) out += (out.empty() ? "" : ",") + x;
    return out;
  };
  struct Case {
    std::string name;
    std::vector<std::string> row;
    std::string expected;
  };
  std::vector<Case> cases;
  std::vector<std::string> c = cells(10);
  c[0] = "soon";
  cases.push_back({"bad t", c, ":11: column 1 ('t'): expected a finite time in seconds, got 'soon'"});
  c = cells(10);
  c[1] = "x";
  cases.push_back({"bad mu", c, ":11: column 2 ('mu_asphalt'): expected a probability in [0, 1], got 'x'"});
  c = cells(10);
  c[1] = "7";
  cases.push_back({"mu = 7", c, ":11: column 2 ('mu_asphalt'): expected a probability in [0, 1], got 7"});
  c = cells(10);
  c[1] = "0.5";
  c[2] = "0.5";
  c[3] = "0.5";
  cases.push_back({"sum 1.5", c, ":11: the mode probabilities (mu_ columns) sum to 1.5"});
  c = cells(10);
  c[0] = cells(5)[0];
  cases.push_back({"time backwards", c, ":11: column 1 ('t'): time must increase strictly, but "});
  for (const Case& k : cases) {
    const fs::path broken = with_row(10, join(k.row));
    const Result r = run_pipeline(kSkidimm + " eval --estimates " + broken.string());
    EXPECT_EQ(r.exit_code, 1) << k.name;
    EXPECT_THAT(r.err, HasSubstr(broken.string() + k.expected)) << k.name;
    EXPECT_THAT(r.err, ::testing::Not(HasSubstr("unexpected error"))) << k.name;
  }
  const fs::path header_only = write_file(dir / "header_only.csv", lines[0] + "\n");
  const Result empty = run_pipeline(kSkidimm + " eval --estimates " + header_only.string());
  EXPECT_EQ(empty.exit_code, 1);
  EXPECT_THAT(empty.err, HasSubstr(header_only.string() + ":1: the file has a header but no rows"));
}

}  // namespace
}  // namespace skidimm_test
