// skidimm: identify the traction mode of a skid-steer robot from its logs.
//
//   skidimm run --bank B.yaml --input log.csv --output out.csv
//   skidimm validate B.yaml [--check log.csv]
//   skidimm simulate --scenario S.yaml --output log.csv
//   skidimm fit --bank B.yaml --log MODE=log.csv [--append-to B.yaml]
//   skidimm tune --bank B.yaml --log MODE=log.csv ... --output-bank tuned.yaml
//   skidimm eval --bank B.yaml --input logs/ [--json]
//   skidimm plot --estimates out.csv --output figure.png
//   skidimm plugins
//   skidimm new-plugin NAME [--dir DIR]
#include <arpa/inet.h>

#include <CLI/CLI.hpp>
#include <charconv>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <system_error>
#include <type_traits>
#include <vector>

#include "commands.h"
#include "documentation.h"
#include "skidimm/engine/fatal_signal_report.h"
#include "skidimm/evaluation/accuracy_range.h"
#include "skidimm/io/csv.h"
#include "skidimm/io/estimates_writer.h"
#include "skidimm/io/log_arguments.h"
#include "skidimm/io/output_file.h"
#include "skidimm/io/ros/live_estimates.h"
#include "skidimm/printable.h"
#include "skidimm/simulation/scenario.h"

namespace fs = std::filesystem;
using namespace skidimm::cli;

namespace {

// NaN passes CLI11's range checks (every comparison with it is false), and
// inf its sign checks: a number option is finite first.
// Decimal only, as a bank's numbers are: CLI11 alone takes 0x10 as 16.
CLI::Validator finite_number() {
  return CLI::Validator(
      [](std::string& text) {
        // Blanks around a number are no part of it ("0.5, 0.7" is two).
        const std::size_t begin = text.find_first_not_of(" \t");
        text =
            begin == std::string::npos ? std::string() : text.substr(begin, text.find_last_not_of(" \t") + 1 - begin);
        const char* first =
            text.data() + (!text.empty() && text[0] == '+' && text.size() > 1 && text[1] != '-' ? 1 : 0);
        const char* last = text.data() + text.size();
        double value = 0.0;
        const auto [end, error] = std::from_chars(first, last, value, std::chars_format::general);
        return error == std::errc() && end == last && std::isfinite(value)
                   ? std::string()
                   : "expected a finite number, got '" + text + "'";
      },
      "");
}

// A number above `lowest` (or from it, `inclusive`) and at most `highest`,
// said in those words: CLI11's PositiveNumber printed DBL_MAX's 309 digits.
// After finite_number(), which refuses what is not a number.
CLI::Validator number_above(double lowest, bool inclusive, double highest = std::numeric_limits<double>::max()) {
  return CLI::Validator(
      [=](std::string& text) {
        double value = 0.0;
        if (!CLI::detail::lexical_cast(text, value)) return std::string();  // finite_number() says so
        if ((inclusive ? value >= lowest : value > lowest) && value <= highest) return std::string();
        // 1e6, not 1e+06.
        const auto bound = [](double value) {
          char digits[32];
          std::snprintf(digits, sizeof digits, "%g", value);
          std::string out = digits;
          for (const char* exponent : {"e+0", "e+"}) {
            const std::size_t at = out.find(exponent);
            if (at != std::string::npos) out.replace(at, std::strlen(exponent), "e");
          }
          return out;
        };
        std::string expected = std::string("expected a number ") + (inclusive ? ">= " : "> ") + bound(lowest);
        if (highest < std::numeric_limits<double>::max()) expected += " and at most " + bound(highest);
        return expected + ", got '" + text + "'";
      },
      "");
}

// A seed as the scenario's `seed:` takes it (parse_seed), where CLI11's own
// reading would wrap -1 and clamp 2^64 to 18446744073709551615.
CLI::Validator whole_seed() {
  return CLI::Validator(
      [](std::string& text) {
        return skidimm::simulation::parse_seed(text)
                   ? std::string()
                   : "expected a whole number from 0 to 18446744073709551615, got '" + text + "'";
      },
      "");
}

// An empty path would be found only when the output is renamed into place,
// after the whole run.
CLI::Validator file_path(const char* expected = "a file path") {
  return CLI::Validator(
      [expected](std::string& text) { return text.empty() ? "expected " + std::string(expected) : std::string(); }, "");
}

// Logs per class ("ASPHALT=2,ICE=4") as parse_logs_per_class reads them,
// refused before any work.
CLI::Validator logs_per_class() {
  return CLI::Validator(
      [](std::string& text) {
        try {
          skidimm::evaluation::parse_logs_per_class(text);
          return std::string();
        } catch (const std::invalid_argument& e) {
          return std::string(e.what());
        }
      },
      "");
}

const char* const kPooledQ =
    "Window objective: give every fitted mode one Q, the mean of the modes' own estimates, so the modes are told apart "
    "by what they predict rather than by how much each expects to miss";
const char* const kPartialPooling =
    "With --parameter-uncertainty: pool the fitted parameters of the modes of one regime (same model and fit_when, "
    "three modes or more) partially, each towards their mean by how little its own logs determined it";
const char* const kUncertaintyPerLog =
    "With --parameter-uncertainty: count each log's rows as correlated, each channel's residual variance scaled by "
    "its design effect over the logs (about the rows per log where each log is missed by an offset of its own), so "
    "a mode fitted on a few logs widens as a fit on a few rows would";

const char* const kSkipUnpaired =
    "A pattern pairs its files by run key ('pro_*.csv+imu_*.csv': pro_02 with imu_02); leave out, with a note, "
    "the runs some of its files lack, instead of an error listing them";

// A subcommand's --help ends with runnable examples (on the bundled banks and
// logs, bundled_path) and the page that says more.
std::string examples(const std::vector<std::string>& commands, const std::string& section) {
  std::string text = "Examples:\n";
  bool reads_log = false, reads_estimates = false;
  for (const std::string& command : commands) {
    text += "  " + command + "\n";
    reads_log = reads_log || command.find("--input log.csv") != std::string::npos ||
                command.find("--log log.csv") != std::string::npos;
    reads_estimates = reads_estimates || command.find("--estimates estimates.csv") != std::string::npos;
  }
  // Two files the examples pass from one command to the next.
  if (reads_log) text += "  (log.csv: the log the first example of `skidimm simulate --help` writes)\n";
  if (reads_estimates) text += "  (estimates.csv: the output the first example of `skidimm run --help` writes)\n";
  return text + "More: " + documentation_path("docs/cli.md") + section;
}

}  // namespace

int main(int argc, char** argv) {
  // A reader that goes away (`skidimm run --output - | head`) is an error
  // the command reports and handles (what it keeps, the checkpoint it does or
  // does not write), not a signal that ends it without a word.
  std::signal(SIGPIPE, SIG_IGN);
  CLI::App app{"skidimm " SKIDIMM_VERSION ": Interacting Multiple Model identification of skid-steer traction modes",
               "skidimm"};
  app.require_subcommand(1);
  app.set_version_flag("--version", SKIDIMM_VERSION);
  app.footer("Each command's --help ends with examples. Documentation: " + documentation_path("README.md") +
             " (start here), " + documentation_path("docs/cli.md") + " (every command and option)");
  // Bundled files the examples use, and one log the examples write and read.
  const std::string terrains = bundled_path("configs/ltc_terrains.yaml");
  const std::string switching = bundled_path("configs/examples/ltc_switching.csv");

  std::vector<std::string> plugin_paths;
  auto add_plugin_path = [&plugin_paths](CLI::App* command) {
    command
        ->add_option("--plugin-path", plugin_paths,
                     "Directory (or plugin file) searched first for motion-model plugins; repeatable")
        ->check(CLI::ExistingPath);
  };

  // A file to read, or "-" for standard input.
  const CLI::Validator existing_file_or_stdin(
      [](std::string& path) { return path == "-" ? std::string() : CLI::ExistingFile(path); }, "FILE or -");

  auto add_rate = [](CLI::App* command, auto* rate, const char* more = "") {
    command
        ->add_option("--rate", *rate,
                     std::string("Filter steps per second on a fixed grid (overrides the bank's sampling.rate); "
                                 "default: the bank's sampling.rate, else a step at every time stamp of the log") +
                         more)
        ->transform(finite_number())
        ->check(number_above(0.0, false, 1e6));
  };
  // The decision's settings: a value each (run: std::optional), or a list
  // each (eval: std::vector, comma-separated; with --estimates, every
  // combination is compared). `lists`: what a list does, for the help.
  auto add_decision_options = [](CLI::App* command, auto* enter, auto* leave, auto* hold,
                                 std::optional<double>* stale_after, const std::string& lists) {
    const auto option = [&](const char* name, auto* value, const std::string& help) {
      CLI::Option* o = command->add_option(name, *value, help + lists);
      if constexpr (!std::is_same_v<std::decay_t<decltype(*value)>, std::optional<double>>) o->delimiter(',');
      return o->transform(finite_number());
    };
    option("--decision-enter", enter,
           "Probability at which a mode (class) is decided (overrides the bank's decision.enter)")
        ->check(CLI::Range(0.0, 1.0));
    option("--decision-leave", leave,
           "Probability below which, for the hold, the decided mode is given up for unknown (decision.leave; 0: "
           "never)")
        ->check(CLI::Range(0.0, 1.0));
    option("--decision-hold", hold,
           "Seconds a decision is kept at least, and below decision.leave before it is given up (decision.min_hold)")
        ->check(number_above(0.0, true));
    command
        ->add_option("--decision-stale-after", *stale_after,
                     "Seconds without any measurement after which the decision is given up for unknown; 0: never "
                     "(decision.stale_after; default the bank's shortest mean dwell time)")
        ->transform(finite_number())
        ->check(number_above(0.0, true));
  };

  // Settings of the filter itself, over the bank's (run, and eval when it runs a bank).
  auto add_filter_overrides = [](CLI::App* command, skidimm::RunOverrides* overrides) {
    command
        ->add_option("--innovation-gate", overrides->innovation_gate,
                     "Chi-square innovation gate: probability a consistent measurement passes, in (0, 1); 0: none "
                     "(overrides the bank's innovation_gate; " +
                         documentation_path("docs/engine.md") + ")")
        ->transform(finite_number())
        ->check(CLI::Validator(
            [](std::string& text) {
              double value = 0.0;
              if (!CLI::detail::lexical_cast(text, value)) return std::string();  // finite_number() says so
              return value >= 0.0 && value < 1.0
                         ? std::string()
                         : "expected a probability in (0, 1), or 0 for none, got '" + text + "'";
            },
            ""));
    command
        ->add_option("--likelihood-weight", overrides->likelihood_weight,
                     "Weight of each step's evidence in the mode probabilities, in (0, 1]; 1: the plain IMM "
                     "(overrides the bank's likelihood_weight; " + documentation_path("docs/engine.md") + ")")
        ->check(CLI::Validator(
            [](std::string& text) {
              double weight = 0.0;
              const bool number = CLI::detail::lexical_cast(text, weight);
              return number && weight > 0.0 && weight <= 1.0 ? std::string()
                                                             : "expected a weight in (0, 1], got '" + text + "'";
            },
            "W in (0, 1]"));
  };

  RunOptions run_options;
  std::string bank, output;
  CLI::App* run = app.add_subcommand("run", "Run a bank of modes over a log and write per-step estimates");
  run->footer(examples({"skidimm run --bank " + terrains + " --input " + switching + " --output estimates.csv",
                        "skidimm run --bank " + terrains + " --input " + switching + " --smooth --output smoothed.csv"},
                       "#skidimm-run"));
  run->add_option("--bank,-b", bank, "Bank file (YAML), see " + documentation_path("docs/bank-format.md"))->required()->check(CLI::ExistingFile);
  run->add_option("--input,-i", run_options.inputs,
                  "[MODE=]FILE[@OFFSET][+FILE...]: the log's files; repeat for more files of the same log "
                  "(merged by time, or row by row with the bank's sampling.join: rows)")
      ->required();
  add_rate(run, &run_options.overrides.rate);
  run->add_flag("--smooth", run_options.smooth,
                "Write probabilities and states smoothed over the whole log (offline labelling; " +
                    documentation_path("docs/engine.md") + ")");
  run->add_option("--lag", run_options.lag,
                  "Write each step smoothed with this many seconds of later data (online, delayed)")
      ->transform(finite_number())
      ->check(number_above(0.0, true));
  add_decision_options(run, &run_options.overrides.decision_enter, &run_options.overrides.decision_leave,
                       &run_options.overrides.decision_hold, &run_options.overrides.decision_stale, "");
  run->add_option("--output,-o", output,
                  "Output: a NumPy array for a path ending in .npy, an MCAP file for Foxglove for .mcap, else CSV; "
                  "written as <output>.partial, renamed when complete; '-' for CSV on standard output")
      ->required()
      ->check(file_path());
  run->add_flag("--flush", run_options.flush,
                "Write each row as soon as it is computed (run behind another program, through a pipe)");
  run->add_flag("--quiet,-q", run_options.quiet, "No summary or progress on stderr");
  add_filter_overrides(run, &run_options.overrides);
  run->add_flag("--strict", run_options.strict,
                "The first row where a mode's filter is rejected ends the run with an error (rows so far are kept)");
  std::string run_plot;
  run->add_option("--plot", run_plot, "Also draw the mode probabilities to this .png or .svg (needs gnuplot)")
      ->check(file_path());
  run->add_option("--serve", run_options.serve,
                  "[HOST:]PORT: publish each step live to Foxglove (its WebSocket protocol; " +
                      documentation_path("docs/foxglove.md") +
                      "); HOST 127.0.0.1 unless given, PORT 0 for any free port")
      ->check(CLI::Validator(
          [](std::string& text) {
            // A bad address is a bad command line, found before the bank is read.
            std::string host;
            std::uint16_t port = 0;
            try {
              skidimm::ros::LiveEstimates::parse_address(text, &host, &port);
            } catch (const skidimm::Error&) {
              return "expected [HOST:]PORT, a port from 0 (any free port) to 65535, got '" + text + "'";
            }
            in6_addr address{};
            if (::inet_pton(AF_INET, host.c_str(), &address) != 1 &&
                ::inet_pton(AF_INET6, host.c_str(), &address) != 1) {
              return "'" + host + "' is not an IP address (HOST is numeric: 127.0.0.1, 0.0.0.0, ::1)";
            }
            return std::string();
          },
          "[HOST:]PORT"));
  run->add_option("--serve-speed", run_options.serve_speed,
                  "With --serve, replaying a file: times real time (default 1); 0 as fast as the filter runs")
      ->transform(finite_number())
      ->check(number_above(0.0, true))
      ->needs("--serve");  // it paces the replay the server shows, and nothing else
  run->add_flag("--copy-topics", run_options.copy_topics,
                "With an .mcap output and a bag input: copy the bag topics the bank reads into the output");
  run->add_option("--resume", run_options.resume,
                  "Start the filter (and decision) where a checkpoint file left it, not from the bank's prior; the "
                  "log goes on along the checkpoint's clock")
      ->check(CLI::ExistingFile);
  run->add_option("--save-checkpoint", run_options.save_checkpoint,
                  "Write the filter's state after the last step (also after an error) to this file, for --resume")
      ->check(file_path());
  run->add_option("--checkpoint-every", run_options.checkpoint_every,
                  "With --save-checkpoint: also write it as the run goes, every SECONDS of the log's time (a live "
                  "run that may be killed outright keeps a recent one)")
      ->transform(finite_number())
      ->check(number_above(0.0, false))
      ->needs("--save-checkpoint");
  add_plugin_path(run);

  std::string validate_bank;
  CLI::App* validate = app.add_subcommand("validate", "Check a bank file and its plugins without running it");
  validate->footer(examples({"skidimm validate " + terrains, "skidimm validate " + terrains + " --check " + switching},
                            "#skidimm-validate"));
  validate->add_option("bank", validate_bank, "Bank file (YAML)")->required()->check(CLI::ExistingFile);
  std::vector<std::string> validate_checks;
  validate->add_option("--check", validate_checks,
                       "[MODE=]FILE[@OFFSET][+FILE...]: also check each mode's model at 20 operating points of this "
                       "log (a directory or a '*' pattern for several): its Jacobian against finite differences, "
                       "finite values, dt = 0 the identity; repeatable");
  double validate_rate = 0.0;
  add_rate(validate, &validate_rate);
  add_plugin_path(validate);

  SimulateOptions simulate_options;
  std::string scenario, simulate_output;
  CLI::App* simulate =
      app.add_subcommand("simulate", "Simulate a skid-steer robot driving a scenario and write its sensor log");
  simulate->footer(
      examples({"skidimm simulate --scenario " + bundled_path("configs/scenarios/ltc_switching.yaml") +
                    " --output log.csv --seed 7",
                "skidimm simulate --bank " + terrains + " --inputs-from " + switching + " --output model_log.csv"},
               "#skidimm-simulate"));
  simulate->add_option("--scenario,-s", scenario, "Scenario file (YAML), see " + documentation_path("docs/simulation.md"))
      ->check(CLI::ExistingFile);
  std::string simulate_bank;
  simulate->add_option("--bank,-b", simulate_bank,
                       "Instead of a scenario: simulate this bank's own models (known truth, for testing fits)")
      ->check(CLI::ExistingFile);
  simulate->add_option("--inputs-from", simulate_options.inputs_from,
                       "With --bank: the log whose inputs, times and truth (or MODE= label) drive the models");
  add_rate(simulate, &simulate_options.rate);
  add_plugin_path(simulate);
  simulate->add_option("--output,-o", simulate_output, "Log CSV to write")->required()->check(file_path());
  simulate
      ->add_option("--output-bank", simulate_options.output_bank,
                   "With --bank: also write the bank with columns that read the simulated log (where the bank "
                   "reads expressions, the log has the inputs and measurements under their own names)")
      ->check(file_path());
  simulate->add_option("--seed", simulate_options.seed, "Random seed (default: the scenario's)")->check(whole_seed());
  simulate->add_option("--duration", simulate_options.duration, "Seconds to simulate (default: the scenario's)")
      ->transform(finite_number())
      ->check(number_above(0.0, false));
  simulate->add_flag("--quiet,-q", simulate_options.quiet, "No summary on stderr");

  FitCommandOptions fit_options;
  std::string fit_bank, entry_output, append_to, bank_output;
  CLI::App* fit = app.add_subcommand("fit", "Fit the parameters and process noise of a bank's modes to logs");
  fit->footer(examples({"skidimm fit --bank " + terrains + " --log " + switching + " --output-bank fitted.yaml",
                        "skidimm fit --bank " + terrains + " --log log.csv --objective window --window 0.5 "
                        "--output-entry entries.yaml"},
                       "#skidimm-fit"));
  fit->add_option("--bank,-b", fit_bank, "Bank file giving the models, columns and measurement noise")
      ->required()
      ->check(CLI::ExistingFile);
  fit->add_option("--log,-l", fit_options.logs,
                  "[MODE=]FILE[@OFFSET][+FILE...]: a log of MODE (a directory or a '*' pattern for several); "
                  "without MODE=, --mode or else the bank's truth column says which; repeatable")
      ->required();
  fit->add_option("--mode,-m", fit_options.mode, "The mode that logs without MODE= show; its values start the fit");
  fit->add_option("--name", fit_options.name, "Name of the fitted --mode in the output (e.g. a new terrain)");
  fit->add_flag("--skip-unpaired", fit_options.skip_unpaired, kSkipUnpaired);
  fit->add_flag("--shared", fit_options.shared,
                "Also fit the bank-level (shared:) parameters jointly over every mode's logs, then each mode's own");
  fit->add_option("--objective", fit_options.objective,
                  "likelihood (default): each mode's own filter innovation likelihood; window: prediction error "
                  "over windows started from measured states (see " + documentation_path("docs/fitting.md") + ")")
      ->check(CLI::IsMember({"likelihood", "window"}));
  fit->add_flag("--fit-r", fit_options.fit_r,
                "Likelihood objective: also fit one measurement noise R (diagonal) for the whole bank");
  fit->add_flag(
      "--output-noise", fit_options.output_noise,
      "Window objective: give each fitted mode its own R, whose rows of the measured outputs are its outputs' "
      "residual variance (its model's error included); the state rows keep the bank's R");
  fit->add_flag("--parameter-uncertainty", fit_options.parameter_uncertainty,
                "Window objective: write each fitted mode's parameter covariance (parameter_covariance:), so its "
                "predictions widen for inputs unlike those it was fitted on");
  fit->add_flag("--uncertainty-per-log", fit_options.uncertainty_per_log, kUncertaintyPerLog)
      ->needs("--parameter-uncertainty");
  fit->add_flag("--residual-correlation", fit_options.residual_correlation,
                "Window objective: write each fitted mode's residual correlation (residual_correlation:), the lag-1 "
                "correlation of its whitened one-step errors, so its likelihood counts a persistent miss once");
  fit->add_flag("--pooled-q", fit_options.pooled_q, kPooledQ);
  fit->add_flag("--partial-pooling", fit_options.partial_pooling, kPartialPooling)->needs("--parameter-uncertainty");
  fit->add_flag("--full-q", fit_options.full_q,
                "Q with off-diagonal terms (likelihood: fitted; window: the correlations of the one-step errors)");
  fit->add_flag("--hold-unexcited", fit_options.hold_unexcited,
                "Hold parameters the logs do not excite at their starting values instead of failing (each is named)");
  fit->add_option("--window", fit_options.window,
                  "Window objective: seconds each prediction runs from a measured start; 0 = one-step (default)")
      ->transform(finite_number())
      ->check(number_above(0.0, true));
  add_rate(fit, &fit_options.rate, "; the written bank (--output-bank) takes it as its sampling.rate");
  fit->add_option("--loss", fit_options.loss, "Robust loss: huber (default), cauchy, none")
      ->check(CLI::IsMember({"huber", "cauchy", "none"}));
  // In units of R's standard deviations: far below one, the robust loss
  // underflows (1e-170 made the cost NaN, blamed on the logs); far above,
  // it is the plain square.
  fit->add_option("--loss-scale", fit_options.loss_scale, "Loss scale in measurement standard deviations (3)")
      ->transform(finite_number())
      ->check(number_above(1e-3, true, 1e6));
  fit->add_option("--held-out", fit_options.held_out, "[MODE=]FILE[+FILE...] to evaluate after fitting; repeatable");
  fit->add_option("--output-entry", entry_output, "Write the fitted mode entries (YAML) to this file")
      ->check(file_path());
  fit->add_option("--append-to", append_to, "Append the fitted mode to this bank file (comments kept)")
      ->check(CLI::ExistingFile);
  fit->add_option("--output-bank", bank_output, "Write the whole bank with fitted values to this file")
      ->check(file_path());
  add_plugin_path(fit);

  TuneCommandOptions tune_options;
  std::string tune_bank;
  CLI::App* tune = app.add_subcommand("tune",
                                      "Choose noise scales, dwell time, floor, likelihood weight and fit objective by "
                                      "cross-validation over labelled logs");
  tune->footer(examples({"skidimm tune --bank " + terrains + " --log " + switching +
                             " --log log.csv --objective none --tune dwell --no-assess --output-bank tuned.yaml"},
                        "#skidimm-tune"));
  tune->add_option("--bank,-b", tune_bank, "Bank giving the models, columns and starting values")
      ->required()
      ->check(CLI::ExistingFile);
  tune->add_option("--log,-l", tune_options.logs,
                   "[MODE=]FILE[@OFFSET][+FILE...], a directory or a '*' pattern: labelled logs; each log is a "
                   "cross-validation group; repeatable")
      ->required();
  tune->add_option("--mode,-m", tune_options.mode, "The mode logs without MODE= show");
  tune->add_flag("--skip-unpaired", tune_options.skip_unpaired, kSkipUnpaired);
  add_rate(tune, &tune_options.rate, "; the written bank (--output-bank) takes it as its sampling.rate");
  tune->add_option("--objective", tune_options.objectives,
                   "Fit objectives to compare, comma-separated: likelihood, window, none (the bank's models as they "
                   "are: tune the settings only); default likelihood");
  tune->add_option("--tune", tune_options.knobs,
                   "Settings to choose, comma-separated: r-scale, r-components, q-scale, q-modes, dwell, floor, "
                   "likelihood-weight, likelihood-dof, unknown-inflation, extrapolation-scale (default "
                   "r-scale,q-scale,dwell,floor, dwell only where a development log shows a change of class or "
                   "with --splice)")
      ->check(CLI::Validator(
          [](std::string& text) {
            // '' tuned the defaults and ',' nothing, each without a word.
            return text.find_first_not_of(", ") == std::string::npos ? std::string("expected one or more settings")
                                                                     : std::string();
          },
          ""));
  // One group would leave every fold nothing to train on.
  const CLI::Validator folds_count(
      [](std::string& text) {
        int folds = -1;
        return CLI::detail::lexical_cast(text, folds) && folds >= 0 && folds != 1 && folds <= 1000
                   ? std::string()
                   : "expected 0 (leave one log out) or a number of groups from 2 to 1000, got '" + text + "'";
      },
      "0 or 2..1000");
  tune->add_option("--folds", tune_options.folds,
                   "Groups of logs for cross-validation; 0 = leave one log out (default)")
      ->check(folds_count);
  tune->add_option("--inner-folds", tune_options.inner_folds,
                   "Groups of the nested assessment's inner cross-validation; 0 = leave one log out (default 4)")
      ->check(folds_count);
  tune->add_flag("--no-assess", tune_options.no_assess, "Skip the nested assessment (its scores are the honest ones)");
  tune->add_option("--assess", tune_options.protocols,
                   "How the nested assessment holds logs out, comma-separated, each reported: logs (leave one log "
                   "out, or --folds groups), sessions (leave one session out, --sessions), extrapolation:INPUT[:F] "
                   "(per class, the share F, default 0.25, of its logs with the largest mean |INPUT|) or "
                   "extrapolation:NAME=EXPR[:F] (ranked by an expression of the log's columns); default logs");
  tune->add_option("--sessions", tune_options.sessions,
                   "File of 'GLOB SESSION' lines: which logs were recorded together (for --assess sessions)")
      ->check(CLI::ExistingFile);
  tune->add_flag("--splice", tune_options.splice,
                 "Score the logs a fold holds out as one run spliced end to end (classes taking turns), so that the "
                 "scores include following each change; with --folds/--inner-folds K the search sees changes too");
  tune->add_flag("--walk", tune_options.walk,
                 "Search each log-spaced setting outward from its current value while each step scores better, "
                 "instead of every candidate of its grid: the grid's best with fewer scorings where the score has "
                 "one peak along the setting; it can stop on the nearer of two");
  tune->add_option("--lockbox", tune_options.lockbox,
                   "Logs kept aside (as --log): neither fitted nor tuned on, scored once by the tuned bank; repeatable");
  tune->add_option("--threads", tune_options.threads, "Worker threads (default, and at most: every core)")
      ->transform(finite_number())
      ->check(number_above(0.0, true));
  tune->add_option("--window", tune_options.window, "The window objective's window in seconds (0: one-step)")
      ->transform(finite_number())
      ->check(number_above(0.0, true));
  tune->add_flag("--fit-r", tune_options.fit_r, "Likelihood objective: also fit one R for the bank");
  tune->add_flag("--full-q", tune_options.full_q,
                 "Q with off-diagonal terms (likelihood: fitted; window: the correlations of the one-step errors)");
  tune->add_flag("--parameter-uncertainty", tune_options.parameter_uncertainty,
                 "Window objective: each fitted mode's parameter covariance widens its predictions for inputs unlike "
                 "those it was fitted on (written to --output-bank)");
  tune->add_flag("--uncertainty-per-log", tune_options.uncertainty_per_log, kUncertaintyPerLog)
      ->needs("--parameter-uncertainty");
  tune->add_flag("--residual-correlation", tune_options.residual_correlation,
                 "Window objective: each fitted mode's residual correlation (residual_correlation:), estimated on "
                 "each fold's training runs (written to --output-bank)");
  tune->add_flag("--pooled-q", tune_options.pooled_q, kPooledQ);
  tune->add_flag("--partial-pooling", tune_options.partial_pooling, kPartialPooling)->needs("--parameter-uncertainty");
  tune->add_flag("--hold-unexcited", tune_options.hold_unexcited,
                 "Hold parameters the logs do not excite at their starting values instead of failing the fit");
  tune->add_option("--output-bank", tune_options.output_bank,
                   "Write the tuned bank (fitted on every log but the lockbox) here")
      ->check(file_path());
  tune->add_option("--table", tune_options.table, "Write every log's held-out scores to this CSV")->check(file_path());
  tune->add_option("--estimates", tune_options.estimates,
                   "Write each log's nested-assessment steps under this directory, a folder per protocol (and "
                   "'lockbox'), as `run` does, for `eval --estimates`")
      ->check(file_path("a directory path"));
  std::string tune_range_for;
  tune->add_option("--range-for", tune_range_for,
                   "CLASS=COUNT,...: under each held-out table, the range of accuracy (mean over classes) to expect on "
                   "another set of logs holding this many of each class (default: as many as the table scored)")
      ->check(logs_per_class());
  tune->add_flag("--quiet,-q", tune_options.quiet, "No progress on stderr");
  add_plugin_path(tune);

  EvalOptions eval_options;
  std::string eval_bank;
  CLI::App* eval = app.add_subcommand("eval", "Measure how well a bank identifies the true modes of logs");
  eval->footer(examples({"skidimm eval --bank " + terrains + " --input " + switching + " --input log.csv",
                         "skidimm eval --estimates estimates.csv --decision-enter 0.8 --json",
                         "skidimm eval --estimates estimates.csv --decision-enter 0.6,0.8,0.9 --decision-hold 0.5,1"},
                        "#skidimm-eval"));
  eval->add_option("--bank,-b", eval_bank, "Bank to run over the logs")->check(CLI::ExistingFile);
  eval->add_option("--input,-i", eval_options.inputs,
                   "[MODE=]FILE[@OFFSET][+FILE...], a directory or a '*' pattern of logs; each argument is one group "
                   "(e.g. a scenario or a terrain)");
  add_rate(eval, &eval_options.overrides.rate);
  eval->add_flag("--smooth", eval_options.smooth, "Score the probabilities smoothed over each whole log");
  eval->add_option("--lag", eval_options.lag, "Score the probabilities smoothed with this lag (s)")
      ->transform(finite_number())
      ->check(number_above(0.0, true));
  eval->add_option("--estimates,-e", eval_options.estimates,
                   "Evaluate `skidimm run` outputs (files or directories) instead of running a bank");
  add_decision_options(eval, &eval_options.decision_enter, &eval_options.decision_leave, &eval_options.decision_hold,
                       &eval_options.overrides.decision_stale, "; with --estimates a list (0.6,0.8) compares settings");
  add_filter_overrides(eval, &eval_options.overrides);
  eval->add_flag("--splice", eval_options.splice,
                 "Score the logs spliced end to end into one run, the groups (each --input) taking turns, so that the "
                 "scores include following each change of mode: how soon, and the changes never followed");
  eval->add_flag("--skip-unpaired", eval_options.skip_unpaired, kSkipUnpaired);
  std::string range_for;
  eval->add_option("--range-for", range_for,
                   "CLASS=COUNT,...: the range of accuracy (mean over classes) to expect on another set of logs "
                   "holding this many of each class, drawn like these (default: as many as were scored)")
      ->check(logs_per_class());
  eval->add_flag("--json", eval_options.json, "Print JSON instead of tables");
  add_plugin_path(eval);

  PlotOptions plot_options;
  std::string plot_estimates, plot_output;
  CLI::App* plot = app.add_subcommand("plot", "Draw mode probabilities over time (PNG or SVG, needs gnuplot)");
  plot->footer(examples({"skidimm plot --estimates estimates.csv --output probabilities.png",
                         "skidimm plot --estimates estimates.csv --bank " + terrains + " --log " + switching +
                             " --states --output states.svg"},
                        "#skidimm-plot"));
  plot->add_option("--estimates,-e", plot_estimates, "A `skidimm run` output ('-': standard input)")
      ->required()
      ->check(existing_file_or_stdin);
  plot->add_option("--output,-o", plot_output, "Figure to write: .png or .svg")->required()->check(file_path());
  plot->add_option("--log,-l", plot_options.log,
                   "The input log, to draw measurements and true states; with --bank any log form `run` reads");
  plot->add_option("--bank,-b", plot_options.bank,
                   "The bank the estimates came from: its classes' colours, and --log read with its columns")
      ->check(CLI::ExistingFile);
  add_rate(plot, &plot_options.rate);
  add_plugin_path(plot);
  plot->add_option("--title", plot_options.title, "Figure title");
  plot->add_flag("--states", plot_options.states, "Add a panel per state: estimate, measurement, truth");

  CLI::App* plugins = app.add_subcommand("plugins", "List the motion-model plugins found on the search path");
  plugins->footer(examples({"skidimm plugins", "skidimm plugins --plugin-path ."}, "#skidimm-plugins"));
  add_plugin_path(plugins);

  std::string new_plugin_name, new_plugin_dir = ".";
  CLI::App* new_plugin_command = app.add_subcommand(
      "new-plugin", "Write a buildable out-of-tree plugin project: model, CMakeLists, conformance test, example bank");
  new_plugin_command->footer(examples({"skidimm new-plugin my_model --dir plugins_src"}, "#skidimm-new-plugin"));
  new_plugin_command
      ->add_option("name", new_plugin_name,
                   "The plugin's name: a lowercase letter, then lowercase letters, digits or '_' (at most 64)")
      ->required();
  new_plugin_command->add_option("--dir", new_plugin_dir, "Where to create the project's directory NAME (default: .)");

  std::string bag_file;
  CLI::App* bag = app.add_subcommand(
      "bag", "Show a ROS 2 bag: topics, types, message counts, rates, time span and the columns a bank can name");
  bag->add_option("bag", bag_file,
                  "A .mcap or .db3 file, or a bag directory (" + documentation_path("docs/ros2.md") + ")")
      ->required();
  bag->footer(examples({"skidimm bag recording.mcap", "skidimm bag rosbag2_2024_06_01-10_00_00/"}, "#skidimm-bag"));

  if (argc == 1) {  // a newcomer typing `skidimm` wants the usage, not an error
    std::cout << app.help();
    return kExitOk;
  }
  // What was not expected, in the order given (CLI11's own message lists
  // it backwards: "x --smoth" for "--smoth x").
  const auto not_expected = [&app] {
    const std::vector<std::string> extras = app.remaining(true);
    std::string text =
        extras.size() > 1 ? "The following arguments were not expected:" : "The following argument was not expected:";
    for (const std::string& extra : extras) text += " " + extra;
    return text;
  };
  // A first word that names no command (a typo, or a command of another
  // tool) is named, with the commands there are, rather than CLI11's "not
  // expected ... a subcommand is required".
  if (argc > 1 && argv[1][0] != '-') {
    std::string commands;
    bool known = false;
    for (const CLI::App* command : app.get_subcommands([](CLI::App*) { return true; })) {
      known = known || command->get_name() == argv[1];
      commands += (commands.empty() ? "" : ", ") + command->get_name();
    }
    if (!known) {
      std::cerr << "skidimm: unknown command '" << skidimm::printable(argv[1]) << "'; the commands: " << commands
                << " (skidimm --help says what each does)\n";
      return kExitUsage;
    }
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ExtrasError& e) {
    app.exit(CLI::ExtrasError(not_expected(), e.get_exit_code()));
    return kExitUsage;
  } catch (const CLI::RequiredError& e) {
    // CLI11 checks what is required before what was not expected, so a
    // mistyped required option (--ouput) read "--output is required" and
    // the typo went unnamed. What was not expected is the news.
    if (!app.remaining(true).empty()) std::cerr << not_expected() << "\n";
    app.exit(e);
    return kExitUsage;
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? kExitOk : kExitUsage;
  }

  // A plugin library that crashes or calls exit() while it is loaded is named.
  skidimm::report_plugin_load_faults("skidimm " + app.get_subcommands().front()->get_name());
  std::vector<fs::path> paths(plugin_paths.begin(), plugin_paths.end());
  if (*bag) return skidimm::cli::bag_info(bag_file);
  if (*run) {
    run_options.bank = bank;
    run_options.output = output;
    run_options.plot = run_plot;
    run_options.plugin_paths = paths;
    if (!run_plot.empty()) {
      // Checked before the run, which may be long: the figure is drawn after it.
      const std::string figure = fs::path(run_plot).extension().string();
      if (figure != ".png" && figure != ".svg") {
        std::cerr << "skidimm run: --plot " << run_plot << ": the figure must end in .png or .svg\n";
        return kExitUsage;
      }
      if (fs::path(output).extension() == ".mcap") {
        std::cerr << "skidimm run: --plot draws a CSV output; an .mcap output is for Foxglove ("
                  << documentation_path("docs/foxglove.md") << ")\n";
        return kExitUsage;
      }
      if (skidimm::EstimatesWriter::is_npy(output)) {
        std::cerr << "skidimm run: --plot draws a CSV output; a .npy output is for NumPy (numpy.load): write "
                     "--output X.csv to plot it\n";
        return kExitUsage;
      }
      // The figure reads the estimates again after the run (the log it does
      // not: the probabilities and the decisions are all in the estimates).
      if (skidimm::OutputFile::writes_directly(output)) {
        std::cerr << "skidimm run: --plot reads the estimates again after the run, which --output " << output
                  << " (standard output, a pipe or a device) cannot give: write to a file and run skidimm plot\n";
        return kExitUsage;
      }
    }
    const int code = skidimm::cli::run(run_options);
    if (code != kExitOk || run_plot.empty()) return code;
    PlotOptions figure;
    figure.estimates = output;
    figure.output = run_plot;
    figure.bank = bank;
    figure.plugin_paths = paths;
    figure.title = fs::path(bank).stem().string() + " on " + skidimm::join_log_arguments(run_options.inputs).name();
    return skidimm::cli::plot(figure);
  }
  if (*validate) return skidimm::cli::validate(validate_bank, paths, validate_checks, validate_rate);
  if (*eval) {
    eval_options.bank = eval_bank;
    if (!range_for.empty()) eval_options.range_for = skidimm::evaluation::parse_logs_per_class(range_for);
    eval_options.plugin_paths = paths;
    return skidimm::cli::eval(eval_options);
  }
  if (*plot) {
    if (plot->get_option("--rate")->count() > 0 && (plot_options.bank.empty() || plot_options.log.empty())) {
      // The rate reads --log as the bank's filter read it; a plain log is drawn row by row.
      std::cerr << "skidimm plot: --rate reads --log through the bank's columns, which needs --bank and --log\n";
      return kExitUsage;
    }
    if (!plot_options.log.empty() && !plot_options.states) {
      std::cerr << "skidimm plot: --log is drawn in the panels of --states; add --states or leave out --log\n";
      return kExitUsage;
    }
    plot_options.estimates = plot_estimates;
    plot_options.output = plot_output;
    plot_options.plugin_paths = paths;
    if (plot_options.title.empty()) plot_options.title = fs::path(plot_estimates).filename().string();
    return skidimm::cli::plot(plot_options);
  }
  if (*fit) {
    fit_options.bank = fit_bank;
    fit_options.output_entry = entry_output;
    fit_options.append_to = append_to;
    fit_options.output_bank = bank_output;
    fit_options.plugin_paths = paths;
    fit_options.command_line = "skidimm";
    for (int i = 1; i < argc; ++i) fit_options.command_line += std::string(" ") + argv[i];
    if (!fit_options.name.empty() && fit_options.mode.empty()) {
      // It renames the --mode fitted; with every mode fitted it would rename none.
      std::cerr << "skidimm fit: --name renames the mode of --mode, and every mode is fitted without it; add --mode "
                   "MODE or leave out --name\n";
      return kExitUsage;
    }
    if (fit_options.objective == "window" && fit->get_option("--fit-r")->count() > 0) {
      std::cerr << "skidimm fit: --fit-r is an option of the likelihood objective (the window objective keeps the "
                   "bank's R); leave out --objective window or --fit-r\n";
      return kExitUsage;
    }
    if (fit_options.objective == "likelihood") {
      // The window objective's options would be silently ignored.
      for (const char* name : {"--window", "--loss", "--loss-scale", "--output-noise", "--parameter-uncertainty",
                               "--residual-correlation"}) {
        if (fit->get_option(name)->count() > 0) {
          std::cerr << "skidimm fit: " << name << " is an option of the window objective; add --objective window "
                    << "(the default objective is likelihood: " << documentation_path("docs/fitting.md") << ")\n";
          return 2;
        }
      }
    }
    return skidimm::cli::fit(fit_options);
  }
  if (*tune) {
    if (tune->get_option("--window")->count() > 0) {
      // Ignored without a word by the other objectives.
      bool window = false;
      std::stringstream list(tune_options.objectives);
      for (std::string name; std::getline(list, name, ',');) window = window || name == "window";
      if (!window) {
        std::cerr << "skidimm tune: --window is the window objective's, which --objective (" << tune_options.objectives
                  << ") does not name\n";
        return kExitUsage;
      }
    }
    tune_options.bank = tune_bank;
    if (!tune_range_for.empty()) tune_options.range_for = skidimm::evaluation::parse_logs_per_class(tune_range_for);
    tune_options.plugin_paths = paths;
    tune_options.command_line = "skidimm";
    for (int i = 1; i < argc; ++i) tune_options.command_line += std::string(" ") + argv[i];
    return skidimm::cli::tune(tune_options);
  }
  if (*simulate) {
    simulate_options.scenario = scenario;
    simulate_options.bank = simulate_bank;
    simulate_options.plugin_paths = paths;
    simulate_options.output = simulate_output;
    simulate_options.has_seed = simulate->count("--seed") > 0;
    return skidimm::cli::simulate(simulate_options);
  }
  if (*new_plugin_command) return skidimm::cli::new_plugin(new_plugin_name, new_plugin_dir);
  return skidimm::cli::plugins(paths);
}
