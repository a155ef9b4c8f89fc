// `skidimm plot`: PNG and SVG figures through gnuplot, a line of its own for
// each of many modes, estimates from a pipe, and no raw text from the files
// handed to gnuplot.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <csignal>
#include <cstdlib>
#include <fstream>
#include <string>

#include "cli/cli_test_support.h"

namespace skidimm_test {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

TEST(Cli, PlotDrawsPngAndSvgAndSaysWhenGnuplotIsMissing) {
  const fs::path dir = test_directory();
  const std::string log = kSource + "/configs/examples/stc_switching.csv";
  ASSERT_EQ(
      run_skidimm("run -q --bank " + kSource + "/configs/stc_slip4.yaml --input " + log + " --output " +
                  (dir / "out.csv").string() + " --plugin-path " + kPlugins + " --plot " + (dir / "run.png").string())
          .exit_code,
      0);
  const Result svg = run_skidimm("plot --estimates " + (dir / "out.csv").string() + " --log " + log +
                                 " --states --output " + (dir / "states.svg").string());
  ASSERT_EQ(svg.exit_code, 0) << svg.err;
  const std::string png = read_file(dir / "run.png");
  ASSERT_GT(png.size(), 10000u);
  EXPECT_EQ(png.substr(1, 3), "PNG");
  const std::string drawing = read_file(dir / "states.svg");
  EXPECT_THAT(drawing, HasSubstr("<svg"));
  EXPECT_THAT(drawing, HasSubstr("slip_FR_RR"));
  EXPECT_THAT(drawing, HasSubstr("theta"));
  // The decision track: a row per mode and one for `unknown`, under the probabilities.
  EXPECT_THAT(drawing, HasSubstr(">decision<"));
  EXPECT_THAT(drawing, HasSubstr(">unknown<"));
  EXPECT_FALSE(fs::exists(dir / "states.svg.gnuplot")) << "the script is removed after a successful plot";
  // Without gnuplot on PATH: a clear error, not a crash.
  const std::string command = "env PATH=/nonexistent " + std::string(SKIDIMM_EXECUTABLE) + " plot --estimates " +
                              (dir / "out.csv").string() + " --output " + (dir / "x.png").string() + " 2>" +
                              (dir / "err").string();
  const int status = std::system(command.c_str());
  EXPECT_EQ(WEXITSTATUS(status), 1);
  EXPECT_THAT(read_file(dir / "err"), HasSubstr("gnuplot is not installed or not on PATH"));
  // A figure of another kind is a bad command line, as run --plot's is.
  EXPECT_EQ(run_skidimm("plot --estimates " + (dir / "out.csv").string() + " --output x.pdf").exit_code, 2);
  // The figure over the estimates it draws (named as a figure): refused, the estimates kept.
  fs::copy_file(dir / "out.csv", dir / "estimates.svg");
  const Result over = run_skidimm("plot --estimates " + (dir / "estimates.svg").string() + " --output " +
                                  (dir / "." / "estimates.svg").string());
  EXPECT_EQ(over.exit_code, 1);
  EXPECT_THAT(over.err, HasSubstr("is the file of --estimates (" + (dir / "estimates.svg").string() + ")"));
  EXPECT_EQ(read_file(dir / "estimates.svg"), read_file(dir / "out.csv"));
  // A log without a bank is drawn by its columns' names; one named otherwise
  // added nothing to the figure, without a word. A log without --states was
  // not drawn at all.
  {
    std::ofstream other(dir / "other.csv");
    other << "time,x,y\n0,1,2\n1,2,3\n";
  }
  const Result unnamed = run_skidimm("plot --estimates " + (dir / "out.csv").string() + " --log " +
                                     (dir / "other.csv").string() + " --states --output " + (dir / "o.png").string());
  EXPECT_EQ(unnamed.exit_code, 1) << unnamed.err;
  EXPECT_THAT(unnamed.err, HasSubstr((dir / "other.csv").string() + ": nothing of this log can be drawn"));
  EXPECT_THAT(unnamed.err, HasSubstr("it has time, x, y"));
  EXPECT_FALSE(fs::exists(dir / "o.png"));
  const Result undrawn = run_skidimm("plot --estimates " + (dir / "out.csv").string() + " --log " + log + " --output " +
                                     (dir / "o.png").string());
  EXPECT_EQ(undrawn.exit_code, 2) << undrawn.err;
  EXPECT_THAT(undrawn.err, HasSubstr("--log is drawn in the panels of --states"));
  // Estimates of another bank than --bank's were drawn without the log's
  // panels, and exit 0; eval refuses them, and so does plot now.
  const Result other_bank = run_skidimm("plot --estimates " + (dir / "out.csv").string() + " --bank " + kSource +
                                        "/configs/ltc_terrains.yaml --plugin-path " + kPlugins + " --log " + log +
                                        " --states --output " + (dir / "b.png").string());
  EXPECT_EQ(other_bank.exit_code, 1) << other_bank.err;
  EXPECT_THAT(other_bank.err, HasSubstr((dir / "out.csv").string() +
                                        ":1: its modes differ from bank 'ltc_terrains': it was run with another bank"));
  EXPECT_FALSE(fs::exists(dir / "b.png"));
  const Result same_bank = run_skidimm("plot --estimates " + (dir / "out.csv").string() + " --bank " + kSource +
                                       "/configs/stc_slip4.yaml --plugin-path " + kPlugins + " --log " + log +
                                       " --states --output " + (dir / "b.png").string());
  EXPECT_EQ(same_bank.exit_code, 0) << same_bank.err;
  // The log read through the bank: a 'true' line in the legend where the log has true states, none where it has not.
  auto rows = read_csv(log);
  std::vector<std::size_t> kept;
  for (std::size_t c = 0; c < rows[0].size(); ++c) {
    if (rows[0][c].rfind("true_", 0) != 0) kept.push_back(c);
  }
  std::string measured_only;
  for (const auto& row : rows) {
    for (std::size_t k = 0; k < kept.size(); ++k) measured_only += (k ? "," : "") + row[kept[k]];
    measured_only += "\n";
  }
  const fs::path robot_log = write_file(dir / "robot.csv", measured_only);
  for (const auto& [input, legend] : {std::make_pair(log, true), std::make_pair(robot_log.string(), false)}) {
    const fs::path figure = dir / (legend ? "with_truth.svg" : "without_truth.svg");
    const Result drawn = run_skidimm("plot --estimates " + (dir / "out.csv").string() + " --bank " + kSource +
                                     "/configs/stc_slip4.yaml --plugin-path " + kPlugins + " --log " + input +
                                     " --states --output " + figure.string());
    ASSERT_EQ(drawn.exit_code, 0) << drawn.err;
    EXPECT_EQ(read_file(figure).find(">true<") != std::string::npos, legend) << input;
  }
}

// A log stamped by a clock (a ROS 2 bag's header.stamp: epoch seconds) was
// drawn on an axis from 0 to 1.7e9 s, every panel blank: it is drawn from
// its first row, whose time the axis names, the log's own panels too.
// skidimm ignores SIGPIPE for itself; gnuplot, its child, gets the default
// back, or a gnuplot writing into a closed pipe would never stop. A stand-in
// gnuplot reports the signals it was started with ignored.
TEST(CliIo, PlotStartsGnuplotWithSigpipeAtItsDefault) {
  const fs::path dir = test_directory();
  fs::create_directories(dir / "bin");
  {
    std::ofstream fake(dir / "bin" / "gnuplot");
    fake << "#!/bin/sh\ngrep SigIgn /proc/$$/status > '" << (dir / "ignored").string() << "'\n";
  }
  fs::permissions(dir / "bin" / "gnuplot", fs::perms::owner_all);
  const std::string log = kSource + "/configs/examples/ltc_switching.csv";
  ASSERT_EQ(run_skidimm("run -q --bank " + kSource + "/configs/ltc_terrains.yaml --input " + log + " --output " +
                        (dir / "out.csv").string())
                .exit_code,
            0);
  const std::string command = "env PATH=" + (dir / "bin").string() + ":/usr/bin:/bin " +
                              std::string(SKIDIMM_EXECUTABLE) + " plot --estimates " + (dir / "out.csv").string() +
                              " --output " + (dir / "x.png").string() + " 2>/dev/null";
  std::system(command.c_str());
  const std::string ignored = read_file(dir / "ignored");
  ASSERT_THAT(ignored, HasSubstr("SigIgn:"));
  const unsigned long mask = std::stoul(ignored.substr(ignored.find(':') + 1), nullptr, 16);
  EXPECT_EQ(mask & (1ul << (SIGPIPE - 1)), 0ul) << ignored;
}

// plot and run count time from the same origin (skidimm/time_origin.h).
TEST(CliIo, PlotDrawsALogStampedByAClockFromItsFirstRow) {
  const fs::path dir = test_directory();
  auto rows = read_csv(kSwitching);
  const int t = column(rows[0], "t");
  for (std::size_t i = 1; i < rows.size(); ++i) {
    std::string& cell = rows[i][static_cast<std::size_t>(t)];
    cell = std::to_string(1718000000.0 + std::stod(cell));
  }
  const fs::path log = write_file(dir / "epoch.csv", csv_text(rows));
  const std::string bank = kSource + "/configs/ltc_terrains.yaml";
  // run's summary counts from the same first time, every digit of it named.
  const Result run =
      run_skidimm("run --bank " + bank + " --input " + log.string() + " --output " + (dir / "out.csv").string());
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_THAT(run.err, HasSubstr("dominant mode over time (s from the first step, t = 1718000000 s):\n"
                                 "       0.000 -      0.000 s  (a tie)"));
  const Result plot = run_skidimm("plot --estimates " + (dir / "out.csv").string() + " --bank " + bank + " --log " +
                                  log.string() + " --states --output " + (dir / "epoch.svg").string());
  ASSERT_EQ(plot.exit_code, 0) << plot.err;
  const std::string svg = read_file(dir / "epoch.svg");
  EXPECT_THAT(svg, HasSubstr(">time (s) since t = 1718000000 s<"));
  EXPECT_THAT(svg, HasSubstr("> 25<"));  // seconds from the first row, not 1.7e9
  EXPECT_EQ(svg.find("e+09<"), std::string::npos);
  // A log timed from its start keeps its axis from 0.
  ASSERT_EQ(run_skidimm("run -q --bank " + bank + " --input " + kSwitching + " --output " + (dir / "own.csv").string())
                .exit_code,
            0);
  ASSERT_EQ(run_skidimm("plot --estimates " + (dir / "own.csv").string() + " --output " + (dir / "own.svg").string())
                .exit_code,
            0);
  EXPECT_THAT(read_file(dir / "own.svg"), HasSubstr(">time (s)<"));
}

// A bank with classes: the truth and the decisions name classes. Drawn
// with the bank (--bank alone is no longer refused), each class takes its
// first mode's colour; without it, its truth bands are grey and named and its
// decision row dark grey. Its decision row was coloured like the mode of the
// same row number, and its truth bands were not drawn.
TEST(CliIo, PlotColoursTheClassesOfABankWithClasses) {
  const fs::path dir = test_directory();
  const fs::path bank = write_file(dir / "paved.yaml", read_file(kTerrains) +
                                                           "\nclasses:\n  paved: [asphalt, crushed_concrete]\n"
                                                           "  soft: [grass]\n");
  ASSERT_EQ(run_skidimm("run -q --bank " + bank.string() + " --plugin-path " + kPlugins + " --input " + kSwitching +
                        " --output " + (dir / "out.csv").string())
                .exit_code,
            0);
  // Its truth by class, as a log labelled by terrain (BorealTC's) gives it.
  std::string estimates = read_file(dir / "out.csv");
  for (const auto& [mode, class_name] : {std::pair<std::string, std::string>{",asphalt,updated", ",paved,updated"},
                                         {",crushed_concrete,updated", ",paved,updated"},
                                         {",grass,updated", ",soft,updated"}}) {
    for (std::size_t at = estimates.find(mode); at != std::string::npos; at = estimates.find(mode, at)) {
      estimates.replace(at, mode.size(), class_name);
    }
  }
  ASSERT_EQ(estimates.find(",grass,updated"), std::string::npos);
  write_file(dir / "out.csv", estimates);
  const auto count = [](const std::string& text, const std::string& part) {
    int n = 0;
    for (std::size_t at = text.find(part); at != std::string::npos; at = text.find(part, at + 1)) ++n;
    return n;
  };
  const Result with_bank = run_skidimm("plot --estimates " + (dir / "out.csv").string() + " --bank " + bank.string() +
                                       " --plugin-path " + kPlugins + " --output " + (dir / "bank.svg").string());
  ASSERT_EQ(with_bank.exit_code, 0) << with_bank.err;
  const std::string coloured = read_file(dir / "bank.svg");
  EXPECT_EQ(count(coloured, ">paved<"), 1) << "the decision row's name alone";
  EXPECT_EQ(count(coloured, "rgb( 85,  85,  85)"), 0);
  EXPECT_EQ(count(coloured, "rgb(136, 136, 136)"), 0);
  const Result alone =
      run_skidimm("plot --estimates " + (dir / "out.csv").string() + " --output " + (dir / "alone.svg").string());
  ASSERT_EQ(alone.exit_code, 0) << alone.err;
  const std::string grey = read_file(dir / "alone.svg");
  // The log: crushed concrete (paved), grass (soft), asphalt (paved).
  EXPECT_EQ(count(grey, ">paved<"), 3) << "two bands named, and the decision row";
  EXPECT_EQ(count(grey, ">soft<"), 2);
  EXPECT_GT(count(grey, "rgb( 85,  85,  85)"), 0);
  EXPECT_GT(count(grey, "rgb(136, 136, 136)"), 0);
  // With the bank, paved's bands and bars take asphalt's violet and soft's
  // grass's green: more of each than the lines and keys alone draw.
  for (const std::string colour : {"rgb(148,   0, 211)", "rgb(  0, 158, 115)"}) {
    EXPECT_GT(count(coloured, colour), count(grey, colour) + 1) << colour;
  }
}

// A decision never taken (every row `unknown`) names nothing: without the
// bank, whether it would have named modes or classes is not known, and the
// track draws the `unknown` row alone, not a row per mode.
TEST(CliIo, PlotOfADecisionNeverTakenDrawsTheUnknownRowAlone) {
  const fs::path dir = test_directory();
  ASSERT_EQ(run_skidimm("run -q --bank " + kTerrains + " --plugin-path " + kPlugins + " --input " + kSwitching +
                        " --output " + (dir / "out.csv").string())
                .exit_code,
            0);
  std::vector<std::vector<std::string>> rows = read_csv(dir / "out.csv");
  const auto decision = static_cast<std::size_t>(column(rows[0], "decision"));
  for (std::size_t i = 1; i < rows.size(); ++i) rows[i][decision] = "unknown";
  write_file(dir / "never.csv", csv_text(rows));
  const auto count = [](const std::string& text, const std::string& part) {
    int n = 0;
    for (std::size_t at = text.find(part); at != std::string::npos; at = text.find(part, at + 1)) ++n;
    return n;
  };
  const Result plot =
      run_skidimm("plot --estimates " + (dir / "never.csv").string() + " --output " + (dir / "never.svg").string());
  ASSERT_EQ(plot.exit_code, 0) << plot.err;
  const std::string never = read_file(dir / "never.svg");
  const Result decided =
      run_skidimm("plot --estimates " + (dir / "out.csv").string() + " --output " + (dir / "decided.svg").string());
  ASSERT_EQ(decided.exit_code, 0) << decided.err;
  EXPECT_EQ(count(read_file(dir / "decided.svg"), ">grass<"), count(never, ">grass<") + 1)
      << "a decision row for grass where it was decided, none where nothing was";
  EXPECT_EQ(count(never, ">unknown<"), 1);
}

// gnuplot's line colours repeat after 8: in a bank of more modes, each mode
// still gets a colour (or, past 20, a dash pattern) of its own.
TEST(CliIo, PlotGivesEachOfManyModesItsOwnLine) {
  const fs::path dir = test_directory();
  std::string text = "t";
  for (int j = 0; j < 22; ++j) text += ",mu_m" + std::to_string(j);
  text += "\n";
  for (int k = 0; k < 5; ++k) {
    text += std::to_string(0.5 * k);
    for (int j = 0; j < 22; ++j) text += "," + std::to_string((j + k) % 22 == 0 ? 0.79 : 0.01);
    text += "\n";
  }
  const fs::path estimates = write_file(dir / "many.csv", text);
  const fs::path figure = dir / "many.svg";
  const Result plot = run_skidimm("plot --estimates " + estimates.string() + " --output " + figure.string());
  ASSERT_EQ(plot.exit_code, 0) << plot.err;
  const std::string svg = read_file(figure);
  // Modes 9 and 10 in the 12 colours after gnuplot's 8 (#8c564b, #e377c2),
  // not in the 1st and 2nd modes' dark violet and green again.
  EXPECT_THAT(svg, HasSubstr("rgb(140,  86,  75)"));
  EXPECT_THAT(svg, HasSubstr("rgb(227, 119, 194)"));
  EXPECT_THAT(svg, HasSubstr("rgb(158, 218, 229)"));  // the 20th, #9edae5
  // The 21st mode: the 1st mode's colour, dashed (the 1st is solid).
  EXPECT_THAT(svg, HasSubstr("stroke='rgb(148,   0, 211)' stroke-dasharray"));
}

// plot reads the estimates twice (here, then gnuplot): from a pipe they are
// copied first. Text from the file reaches gnuplot printable, and names
// reach it without a shell.
TEST(CliIo, PlotReadsAPipeAndGivesGnuplotNoRawTextFromTheFiles) {
  const fs::path dir = test_directory();
  const fs::path piped = dir / "piped.png";
  const Result pipe = run_pipeline(run_command(kTerrains, kSwitching, "-") + " | " + kSkidimm + " plot --estimates - --output " +
                                piped.string());
  ASSERT_EQ(pipe.exit_code, 0) << pipe.err;
  EXPECT_EQ(read_file(piped).substr(1, 3), "PNG");
  for (const auto& entry : fs::directory_iterator(dir)) {
    EXPECT_EQ(entry.path(), piped) << "left behind: " << entry.path();
  }

  const fs::path estimates = dir / "estimates.csv";
  ASSERT_EQ(run_pipeline(run_command(kTerrains, kSwitching, estimates.string())).exit_code, 0);
  auto rows = read_csv(estimates);
  // A mode name with a line break (a quoted CSV header cell) used to end
  // gnuplot's string mid-script; an apostrophe in the figure's name broke the
  // shell command line.
  rows[0][1] = "mu_asphalt\nset output 'elsewhere.png'";
  std::string text;
  for (const auto& row : rows) {
    for (std::size_t c = 0; c < row.size(); ++c) {
      const bool quote = row[c].find_first_of(",\n'") != std::string::npos;
      text += (c ? "," : "") + (quote ? "\"" + row[c] + "\"" : row[c]);
    }
    text += "\n";
  }
  const fs::path odd = write_file(dir / "odd.csv", text);
  const fs::path figure = dir / "it's a figure.png";
  const Result plot = run_skidimm("plot --estimates " + odd.string() + " --output \"" + figure.string() + "\"");
  EXPECT_EQ(plot.exit_code, 0) << plot.err;
  EXPECT_EQ(read_file(figure).substr(1, 3), "PNG");
  EXPECT_FALSE(fs::exists(dir / "elsewhere.png"));

  // A time cell that is not a number: the file, line, column and the cell.
  rows = read_csv(estimates);
  rows[3][0] = "2.5s";
  text.clear();
  for (const auto& row : rows) {
    for (std::size_t c = 0; c < row.size(); ++c) text += (c ? "," : "") + row[c];
    text += "\n";
  }
  const fs::path bad = write_file(dir / "bad.csv", text);
  const Result located = run_skidimm("plot --estimates " + bad.string() + " --output " + (dir / "bad.png").string());
  EXPECT_EQ(located.exit_code, 1);
  EXPECT_THAT(located.err, HasSubstr(bad.string() + ":4: column 1 ('t'): expected the time, a finite number, got '2.5s'"));
  EXPECT_FALSE(fs::exists(dir / "bad.png"));
  EXPECT_FALSE(fs::exists(dir / "bad.png.gnuplot"));
  // Too few rows, or times that do not increase: said before gnuplot is
  // given them (it failed in its own words, or drew them wrongly).
  rows = read_csv(estimates);
  ASSERT_EQ(rows[0][1].rfind("mu_", 0), 0u) << "the second column is a mode's probability";
  const auto with_cell = [](std::vector<std::string> row, std::size_t c, const std::string& cell) {
    row[c] = cell;
    return row;
  };
  const struct {
    std::string name;
    std::vector<std::vector<std::string>> table;
    std::string message;
  } cases[] = {
      {"header_only", {rows[0]}, ":1: no rows to plot: the estimates have a header only"},
      {"one_row", {rows[0], rows[1]}, ":2: one row: a figure over time needs two time stamps or more"},
      {"repeated_t", {rows[0], rows[1], rows[2], rows[2]}, ":4: column 1 ('t'): time must increase, but "},
      {"nan_mu",
       {rows[0], rows[1], with_cell(rows[2], 1, "nan")},
       ":3: column 2 ('" + rows[0][1] + "'): expected a probability, a number from 0 to 1, got 'nan'"},
      {"mu_above_one",
       {rows[0], with_cell(rows[1], 1, "1.5"), rows[2]},
       ":2: column 2 ('" + rows[0][1] + "'): expected a probability, a number from 0 to 1, got '1.5'"},
  };
  for (const auto& c : cases) {
    const fs::path file = write_file(dir / (c.name + ".csv"), csv_text(c.table));
    const Result r = run_skidimm("plot --estimates " + file.string() + " --output " + (dir / "few.png").string());
    EXPECT_EQ(r.exit_code, 1) << c.name;
    EXPECT_THAT(r.err, HasSubstr(file.string() + c.message)) << c.name;
    EXPECT_THAT(r.err, ::testing::Not(HasSubstr("gnuplot"))) << c.name;
    EXPECT_FALSE(fs::exists(dir / "few.png")) << c.name;
  }
}

}  // namespace
}  // namespace skidimm_test
