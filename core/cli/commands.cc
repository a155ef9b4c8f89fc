#include "commands.h"

#include <signal.h>

#include <algorithm>
#include <csignal>
#include <cstdio>
#include <exception>
#include <iostream>
#include <optional>
#include <string_view>

#include "skidimm/config/bank.h"
#include "skidimm/engine/decision.h"
#include "skidimm/engine/fatal_signal_report.h"
#include "skidimm/engine/imm.h"
#include "skidimm/engine/input_envelope.h"
#include "skidimm/engine/log_run.h"
#include "skidimm/engine/mode_timeline.h"
#include "skidimm/engine/model_conformance.h"
#include "skidimm/engine/plugin_registry.h"
#include "skidimm/errors.h"
#include "skidimm/evaluation/evaluation_report.h"
#include "skidimm/fitting/fit_logs.h"
#include "skidimm/io/checkpoint_file.h"
#include "skidimm/io/csv.h"
#include "skidimm/io/estimates_writer.h"
#include "skidimm/io/log_arguments.h"
#include "skidimm/io/ros/bag_reader.h"
#include "skidimm/io/ros/live_estimates.h"
#include "skidimm/progress.h"
#include "skidimm/stop_request.h"
#include "skidimm/time_origin.h"

namespace skidimm {
namespace cli {

namespace fs = std::filesystem;

namespace {

std::string join(const std::vector<std::string>& items, const char* separator = ", ") {
  std::string out;
  for (const std::string& s : items) out += (out.empty() ? "" : separator) + s;
  return out;
}

// "plugin ltc_linear 1.0.0 (/path/skidimm_ltc_linear.so)" for mode j.
std::string plugin_of(const Bank& bank, std::size_t j) {
  if (j >= bank.model_sources.size()) return "model " + bank.config.modes[j].model;
  return bank.model_sources[j].describe();
}

}  // namespace

void name_plugins_in_fatal_signals(const std::string& program, const Bank& bank, FatalSignalWording wording) {
  std::vector<std::string> modes;
  std::vector<std::string> plugins;
  for (std::size_t j = 0; j < bank.config.modes.size(); ++j) {
    const std::string plugin = plugin_of(bank, j);
    modes.push_back("mode '" + printable(bank.config.modes[j].name) + "' (" + plugin + ")");
    if (std::find(plugins.begin(), plugins.end(), plugin) == plugins.end()) plugins.push_back(plugin);
  }
  wording.plugins = join(plugins);
  report_fatal_signals(program, std::move(modes), wording);
}

namespace {

// Whether paths `a` and `b` are one regular file, or will be: both existing,
// the same file; neither, the same path once made absolute (a path through
// a link to a directory included).
bool same_regular_file(const fs::path& a, const fs::path& b) {
  std::error_code ec;
  const bool a_exists = fs::exists(a, ec);
  const bool b_exists = fs::exists(b, ec);
  if (a_exists && b_exists) {
    return fs::is_regular_file(a, ec) && fs::is_regular_file(b, ec) && fs::equivalent(a, b, ec);
  }
  if (a_exists || b_exists) return false;
  const fs::path canonical_a = fs::weakly_canonical(a, ec);
  if (ec) return false;
  const fs::path canonical_b = fs::weakly_canonical(b, ec);
  return !ec && canonical_a == canonical_b;
}

}  // namespace

void print_rejections(const Bank& bank, const std::vector<ModeRejections>& rejections,
                      const std::vector<std::string>& first_logs) {
  for (std::size_t j = 0; j < rejections.size(); ++j) {
    const ModeRejections& r = rejections[j];
    const long gated = r.by_failure[static_cast<int>(ModeFailure::kGated)];
    if (gated > 0) {
      std::cerr << "  mode '" << bank.config.modes[j].name << "' gated the measurement on " << gated << " row(s)\n";
    }
    if (r.rows == 0) continue;
    std::cerr << "  mode '" << bank.config.modes[j].name << "' (" << plugin_of(bank, j) << ") was rejected on "
              << r.rows << " row(s):";
    const char* separator = " ";
    for (ModeFailure f : {ModeFailure::kModel, ModeFailure::kNotFinite, ModeFailure::kUpdate, ModeFailure::kDiverged}) {
      const long count = r.by_failure[static_cast<int>(f)];
      if (count == 0) continue;
      std::cerr << separator << count << " because " << to_string(f);
      separator = "; ";
    }
    std::cerr << "\n    first " << (j < first_logs.size() ? "in " + printable(first_logs[j]) + " " : std::string())
              << "on row " << r.first_row << " (t = " << CsvWriter::format(r.first_t)
              << "): " << to_string(r.first_failure) << (r.first_reason.empty() ? "" : ": " + r.first_reason) << "\n";
  }
}

LogArgumentOptions unpaired_runs(const char* command, bool skip) {
  LogArgumentOptions options;
  options.skip_unpaired = skip;
  options.skipped = [command](const std::string& message) {
    std::cerr << command << ": " << printable(message) << "\n";
  };
  return options;
}

void warn_of_rate_unlike_the_banks(const char* command, const std::filesystem::path& bank_file, const BankConfig& bank,
                                   std::optional<double> rate) {
  const std::string why = rate_unlike_the_banks(bank, rate);
  if (why.empty()) return;
  std::cerr << command << ": warning: --rate " << CsvWriter::format(*rate) << " Hz steps " << bank_file.string() << " "
            << why << ". Leave --rate out, or fit the bank at this rate (fit --rate, which writes it as the bank's "
            << "sampling.rate)\n";
}

EstimatorOptions command_line_estimator(bool smooth, std::optional<double> lag, const RunOverrides& overrides) {
  EstimatorOptions estimator;
  try {
    estimator = estimator_options(smooth, lag);
  } catch (const Error& e) {  // what it refuses, --smooth with --lag, is a bad command line here
    throw UsageError(std::string("--smooth, --lag: ") + e.what());
  }
  // A smoothed step has seen the measurements after it: its decision never
  // goes stale (decision.h), and the option would do nothing.
  if ((smooth || lag) && overrides.decision_stale) {
    throw UsageError(std::string("--decision-stale-after does nothing with ") + (smooth ? "--smooth" : "--lag") +
                     ": a smoothed decision has seen the measurements after each step and never goes stale");
  }
  return estimator;
}

void refuse_output_over_logs(const fs::path& output, const std::string& option, const std::vector<LogSpec>& logs) {
  if (output.empty()) return;
  for (const LogSpec& log : logs) {
    for (const LogFile& file : log.files) {
      std::error_code ec;
      // Renaming the output over a log being read would replace the log.
      if (fs::is_regular_file(file.path, ec) && fs::equivalent(file.path, output, ec)) {
        throw Error(option + " " + output.string() + " is the log file " + file.path.string() +
                    " itself: writing it would replace the log; give another output file");
      }
    }
  }
}

void refuse_clashing_files(const std::vector<NamedFile>& outputs, const std::vector<NamedFile>& inputs) {
  for (std::size_t i = 0; i < outputs.size(); ++i) {
    const NamedFile& output = outputs[i];
    if (output.path.empty()) continue;
    for (const NamedFile& input : inputs) {
      if (!input.path.empty() && same_regular_file(output.path, input.path)) {
        throw Error(output.option + " " + output.path.string() + " is the file of " + input.option + " (" +
                    input.path.string() + "), which this command reads: writing it would replace it; give " +
                    output.option + " another file");
      }
    }
    for (std::size_t j = 0; j < i; ++j) {
      if (!outputs[j].path.empty() && same_regular_file(output.path, outputs[j].path)) {
        throw Error(outputs[j].option + " and " + output.option + " name the same file (" + output.path.string() +
                    "): one would replace the other; give each its own file");
      }
    }
  }
}

namespace {

// While a run goes on, SIGINT and SIGTERM ask it to stop at its next row and
// keep its rows so far (stop_request.h); the handler is then the default
// again (SA_RESETHAND), so a second signal ends the program at once. No
// SA_RESTART: a read waiting on a pipe returns, and sees the request.
class StopOnSignals {
 public:
  StopOnSignals() {
    clear_stop_request();
    struct sigaction action {};
    action.sa_handler = [](int signal) { request_stop(signal); };
    sigemptyset(&action.sa_mask);
    action.sa_flags = SA_RESETHAND;
    for (std::size_t i = 0; i < 2; ++i) {
      installed_[i] = ::sigaction(kSignals[i], &action, &previous_[i]) == 0;
      // A signal ignored by whoever started us (nohup, a background job of
      // a script) stays ignored.
      if (installed_[i] && previous_[i].sa_handler == SIG_IGN) {
        ::sigaction(kSignals[i], &previous_[i], nullptr);
        installed_[i] = false;
      }
    }
  }
  ~StopOnSignals() {
    for (std::size_t i = 0; i < 2; ++i) {
      if (installed_[i]) ::sigaction(kSignals[i], &previous_[i], nullptr);
    }
  }
  StopOnSignals(const StopOnSignals&) = delete;
  StopOnSignals& operator=(const StopOnSignals&) = delete;

 private:
  static constexpr int kSignals[2] = {SIGINT, SIGTERM};
  struct sigaction previous_[2]{};
  bool installed_[2] = {false, false};
};

}  // namespace

int run(const RunOptions& options) {
  std::optional<ros::LiveEstimates> live;
  std::optional<EstimatesWriter> writer;
  RunSummary summary;
  std::optional<ImmCheckpoint> resumed, last_checkpoint;
  long checkpoint_failures = 0;
  const StopOnSignals stop_on_signals;
  int code = report_errors("skidimm run", [&] {
    const EstimatorOptions estimator = command_line_estimator(options.smooth, options.lag, options.overrides);
    if ((!options.resume.empty() || !options.save_checkpoint.empty()) &&
        estimator.kind != EstimatorOptions::Kind::kFilter) {
      throw UsageError(
          "--resume and --save-checkpoint carry the filter from one run to the next; --smooth and --lag "
          "smooth a log as a whole");
    }
    if (options.flush && (EstimatesWriter::is_npy(options.output) || options.output.extension() == ".mcap")) {
      // Before the output is opened: it left an empty .partial behind.
      throw UsageError(
          "--flush writes CSV rows as they are computed; a .npy or .mcap file is complete only at the end");
    }
    const LogSpec log = join_log_arguments(options.inputs);
    if (options.copy_topics) {
      // Found after the run, either would cost the whole run.
      if (options.output.extension() != ".mcap") {
        throw UsageError("--copy-topics copies a bag's topics into an MCAP output (--output ending in .mcap)");
      }
      bool bag = false;
      for (const LogFile& f : log.files) bag = bag || ros::BagReader::is_bag(f.path);
      if (!bag)
        throw UsageError("--copy-topics copies the topics of a bag the log is read from, and no --input is a bag");
    }
    Bank bank = Bank::load(options.bank, options.plugin_paths);
    settings_given_on_the_command_line([&] { apply_overrides(options.overrides, &bank.config); });
    {
      // A CSV output's rows computed before a crash are written on the way
      // down (CsvWriter::write_rows_on_a_crash()); the others are whole or
      // nothing.
      FatalSignalWording wording;
      if (options.smooth) {
        wording.lost = "the output, written only once the whole log is smoothed, and the checkpoint are lost";
      } else if (!EstimatesWriter::is_npy(options.output) && options.output.extension() != ".mcap") {
        wording.lost = "the rows computed before it are kept (" +
                       (options.output == "-"                         ? std::string("written to standard output")
                        : OutputFile::writes_directly(options.output) ? "written to " + options.output.string()
                                                                      : "in " + options.output.string() + ".partial") +
                       "), the checkpoint is not written";
      } else {
        wording.lost = "a .npy or .mcap output is complete only at the end, and is lost";
      }
      name_plugins_in_fatal_signals("skidimm run", bank, wording);
    }
    const BankConfig& config = bank.config;
    if (!log.label.empty() && config.class_index(log.label) < 0) {
      throw Error(log.text + ": " + config.unknown_label(log.label));
    }
    refuse_output_over_logs(options.output, "--output", {log});
    refuse_output_over_logs(options.plot, "--plot", {log});
    // A .npy output writes its reason table beside it.
    const fs::path reasons =
        EstimatesWriter::is_npy(options.output) ? EstimatesWriter::reasons_path(options.output) : fs::path();
    refuse_output_over_logs(reasons, "--output's reason table", {log});
    refuse_output_over_logs(options.save_checkpoint, "--save-checkpoint", {log});
    // --resume and --save-checkpoint may be one file: the run goes on from it and leaves it one run later.
    refuse_clashing_files({{"--output", options.output},
                           {"--output's reason table", reasons},
                           {"--plot", options.plot},
                           {"--save-checkpoint", options.save_checkpoint}},
                          {{"--bank", options.bank}});
    // The figure is drawn after the run: a path it cannot be written to is said now.
    if (!options.plot.empty()) check_output_path(options.plot, "--plot");
    if (!options.save_checkpoint.empty()) check_output_path(options.save_checkpoint, "--save-checkpoint");
    if (!options.resume.empty()) {
      // Checked against the bank before the output is opened.
      resumed = load_checkpoint(options.resume);
      try {
        Imm(bank).restore(*resumed);
        if (resumed->decision) ModeDecision(config, config.decision).restore(*resumed->decision);
      } catch (const Error& e) {
        throw Error("--resume " + options.resume.string() + ": " + e.what());
      }
    }
    // Listening first: a log through a pipe may wait for its first line.
    if (!options.serve.empty()) {
      std::string host;
      std::uint16_t port = 0;
      ros::LiveEstimates::parse_address(options.serve, &host, &port);
      live.emplace(host, port, config.name);
      std::cerr << "skidimm run: serving Foxglove WebSocket on ws://" << host << ":" << live->port() << std::endl;
    }
    LogReader reader(config, log.files, sampling_of(config, options.overrides.rate));
    warn_of_rate_unlike_the_banks("skidimm run", options.bank, config, options.overrides.rate);
    const bool with_truth = reader.has_truth() || !log.label.empty();
    // A path ending in .npy gets a NumPy array, .mcap an MCAP file (estimates_writer.h), anything else CSV.
    writer.emplace(options.output, config, with_truth);
    if (options.flush) writer->flush_each_row();
    writer->write_rows_on_a_crash();
    if (live) {
      // Paced to the log's clock when replaying files; a pipe is live already.
      bool replay = true;
      for (const LogFile& f : log.files) replay = replay && is_rereadable(f.path);
      live->advertise(config, with_truth, replay ? options.serve_speed : 0.0);
      writer->set_observer([&live](double t, const ImmEstimate& e, const std::string& decision,
                                   const std::string& truth) { live->publish(t, e, decision, truth); });
    }

    std::vector<std::string> mode_names;
    for (const ModeConfig& mode : config.modes) mode_names.push_back(mode.name);
    const int num_modes = config.num_modes();
    const DecisionConfig& decision_settings = config.decision;
    // Percent of the log read, rows, rows per second and time left; only on a terminal.
    ProgressLine progress("skidimm run", "rows", options.progress && !options.quiet);
    RunContinuation continuation;
    continuation.resume = resumed ? &*resumed : nullptr;
    if (!options.save_checkpoint.empty()) continuation.last = &last_checkpoint;
    if (options.checkpoint_every > 0.0) {
      // A checkpoint that cannot be written does not stop the estimates: the
      // first failure is said at once, how many failed at the end.
      continuation.every = options.checkpoint_every;
      continuation.save = [&](const ImmCheckpoint& checkpoint) {
        try {
          save_checkpoint(options.save_checkpoint, checkpoint);
        } catch (const Error& e) {
          if (checkpoint_failures++ == 0) {
            std::cerr << "skidimm run: warning: --checkpoint-every: " << printable(e.what()) << "; the run goes on\n";
          }
        }
      };
    }
    // The loop (log_run.h) allocates nothing per row (but for the checkpoints --checkpoint-every writes).
    write_estimates(
        bank, &reader, estimator, decision_settings, log.label, with_truth, &*writer, &summary,
        [&] { progress.update(summary.rows, 0, reader.progress()); }, options.strict, continuation);
    progress.clear();
    const long rows = summary.rows;
    if (rows == 0) {
      throw LogError(log.text, 0, "the log gives no step: no data rows, or no row where every input has a value");
    }
    if (options.copy_topics) {
      std::vector<std::string> texts = config.columns.inputs;
      texts.insert(texts.end(), config.columns.measurements.begin(), config.columns.measurements.end());
      for (const LogFile& f : log.files) {
        if (ros::BagReader::is_bag(f.path)) writer->copy_topics(f.path, texts);
      }
    }
    writer->commit();
    if (live) {
      live->close();
      if (live->dropped() > 0) {
        std::cerr << "skidimm run: --serve: " << live->dropped()
                  << " message(s) not sent to a viewer that fell more than 1024 steps behind\n";
      }
    }

    if (!options.quiet) {
      const ModeTimeline& timeline = summary.timeline;
      std::cerr << "skidimm run: bank '" << config.name << "' (" << num_modes << " modes), " << rows << " rows -> "
                << options.output.string()
                << (options.smooth ? " (smoothed over the whole log)"
                    : options.lag ? " (smoothed with a lag of " + CsvWriter::format(*options.lag) + " s)"
                                         : "")
                << "\n";
      for (std::size_t j = 0; j < bank.model_sources.size(); ++j) {
        std::cerr << "  mode '" << config.modes[j].name << "': " << plugin_of(bank, j) << "\n";
      }
      std::cerr << "dominant mode over time"
                << (timeline.origin() != 0.0 ? " (s from the first step, t = " + time_text(timeline.origin()) + " s)"
                                             : std::string())
                << ":\n"
                << timeline.format(mode_names);
      // The stale time is said where one was given and the decision can go stale (not smoothed).
      DecisionConfig said = decision_settings;
      if (!(said.stale_after > 0.0 && !options.smooth && !options.lag)) said.stale_after = -1.0;
      const double unknown = static_cast<double>(summary.decision_unknown) / static_cast<double>(rows);
      std::fprintf(stderr,
                   "  the decision (%s) changed %ld time(s) and was `unknown` on %.1f%% of the rows, the most "
                   "likely mode changed %ld time(s)\n",
                   evaluation::decision_settings_text(said).c_str(), summary.decision_changes, 100.0 * unknown,
                   timeline.changes());
      if (unknown > 0.25) {
        std::fprintf(stderr,
                     "  (a decision is taken when a mode's (class's) probability reaches decision.enter, %s: a bank "
                     "whose likelihood weight keeps its probabilities honest decides more often with a lower enter, "
                     "--decision-enter or the bank's decision.enter; `skidimm eval --decision-enter 0.5,0.7,0.9` "
                     "compares them on labelled logs)\n",
                     CsvWriter::format(said.enter).c_str());
      }
      // Stamps in another unit than the bank reads (seconds read as ms) make a run of minutes a fraction of a second.
      if (summary.last_t - summary.first_t < 1.0) {
        std::fprintf(
            stderr, "  the log spans %s s in %ld step(s): are its time stamps in %s? (%s)\n",
            CsvWriter::format(summary.last_t - summary.first_t).c_str(), rows, config.columns.time_unit_name.c_str(),
            config.columns.time_units_per_second == 1.0 ? "columns.time_unit: ms, us or ns reads them in another unit"
                                                        : "columns.time_unit reads them so; without it, in s");
      }
      std::cerr << reader.describe_stats(config);
      if (summary.predict_only > 0) {
        std::cerr << "  " << summary.predict_only << " rows had no measurement (predict only)\n";
      }
      if (summary.rejected > 0) {
        std::cerr << "  " << summary.rejected << " rows had at least one mode's filter rejected and reset\n";
      }
      if (config.innovation_gate > 0.0) {
        std::cerr << "  innovation gate " << CsvWriter::format(config.innovation_gate) << ": " << summary.gated
                  << " measurement(s) gated by every mode (status gated), " << summary.mode_gated
                  << " by some modes only\n";
      }
      if (summary.truth_rows > 0) {
        std::fprintf(stderr, "most likely mode equals %s on %.1f%% of %ld labelled rows%s\n",
                     log.label.empty() ? ("column '" + config.columns.truth_mode + "'").c_str() : "the log's label",
                     100.0 * summary.truth_matches / summary.truth_rows, summary.truth_rows,
                     config.classes.empty() ? ""
                                            : " (a mode counts for its class; `skidimm eval` scores the most "
                                              "likely class, its modes' probabilities summed, over time)");
      } else if (!with_truth && !config.columns.truth_mode.empty()) {
        // Optional (a robot's own logs have no truth), but a misspelt name
        // would otherwise go unnoticed until `eval --estimates` needs it.
        std::cerr << "no accuracy: the log has no column '" << printable(config.columns.truth_mode)
                  << "' (the bank's columns.truth_mode) and no MODE= label\n";
      } else if (with_truth && summary.rows > 0) {
        // The column is there but labels nothing: a logger that never filled
        // it, or labels the reader does not take for values.
        std::cerr << "no accuracy: the log's column '" << printable(config.columns.truth_mode)
                  << "' (the bank's columns.truth_mode) is blank at every step\n";
      }
      if (summary.outside_fitted_inputs > 0) {
        std::fprintf(stderr,
                     "  inputs outside the ranges the most likely class was fitted on: %.1f%% of the rows "
                     "(farthest: %s)\n",
                     100.0 * summary.outside_fitted_inputs / summary.rows,
                     InputEnvelope(config).describe(summary.farthest_outside_class, summary.farthest_outside).c_str());
      }
      print_rejections(bank, summary.rejections);
    }
    return kExitOk;
  });
  if (const int signal = stop_requested()) code = 128 + signal;  // as the signal's default ending reports it
  if (code != kExitOk && writer && summary.rows > 0) {
    if (options.output == "-") {
      // The rows of the block the reader refused are not among them: no count.
      std::cerr << "skidimm run: the rows handed over before the error went to standard output\n";
    } else {
      std::cerr << "skidimm run: the " << summary.rows << " rows computed before the error are in "
                << writer->partial_path().string() << "\n";
    }
  }
  if (checkpoint_failures > 1) {
    std::cerr << "skidimm run: warning: --checkpoint-every: " << checkpoint_failures
              << " checkpoints of the run could not be written\n";
  }
  if (!options.save_checkpoint.empty() && !last_checkpoint && summary.rows > 0) {
    std::cerr << "skidimm run: no checkpoint written: the filter went past a row the output refused; "
              << options.save_checkpoint.string() << " is as it was\n";
  }
  // After an error too: the filter as it was after the last row computed.
  if (last_checkpoint && summary.rows > 0) {
    const int saved = report_errors("skidimm run", [&] {
      save_checkpoint(options.save_checkpoint, *last_checkpoint);
      if (!options.quiet || code != kExitOk) {
        std::cerr << "skidimm run: the filter after its last step (t = " << CsvWriter::format(last_checkpoint->t)
                  << " s) is in " << options.save_checkpoint.string() << " (--resume goes on from it)\n";
      }
      return kExitOk;
    });
    if (code == kExitOk) code = saved;
  }
  return code;
}

int validate(const fs::path& bank_file, const std::vector<fs::path>& plugin_paths,
             const std::vector<std::string>& checks, double rate) {
  return report_errors("skidimm validate", [&] {
    Bank bank = Bank::load(bank_file, plugin_paths);
    {
      FatalSignalWording wording;
      wording.lost = "the check ends there";
      wording.every_model_call_marked = false;  // the conformance checks call the models themselves
      name_plugins_in_fatal_signals("skidimm validate", bank, wording);
    }
    bank.config.sampling = sampling_of(bank.config, rate);
    const BankConfig& c = bank.config;
    // Without a log, the column texts any log would be refused for. (With
    // --check each log is read through the columns, which decides for certain.)
    const std::vector<std::string> unreadable =
        checks.empty() ? LogReader::unreadable_column_texts(c) : std::vector<std::string>();
    // A measurement that aggregates a step's rows needs a fixed step, which
    // `run --rate` can give: a warning here, an error where it runs without one.
    const std::vector<std::string> aggregated =
        c.sampling.rate <= 0.0 ? LogReader::aggregated_measurements(c) : std::vector<std::string>();
    const std::vector<std::string> unfitted = fitting::classes_leaving_steps_unfitted(c);
    // "OK" alone reads as "will run": the verdict counts every warning, and
    // with --check it comes last, after the logs' own.
    std::vector<std::string> buts;
    if (!unreadable.empty()) {
      buts.push_back(std::to_string(unreadable.size()) +
                     " column text(s) a log can give only as a column of exactly that text");
    }
    if (!aggregated.empty()) {
      buts.push_back(std::to_string(aggregated.size()) + " aggregated measurement(s) that need a fixed step");
    }
    if (!unfitted.empty()) {
      buts.push_back(std::to_string(unfitted.size()) + " class(es) with steps that no mode is fitted on");
    }
    const auto verdict = [&] {
      std::cout << bank_file.string() << ": "
                << (buts.empty() ? std::string("OK")
                                 : "OK as a bank, but " + join(buts, "; ") + " (warnings on stderr)")
                << "\n";
    };
    if (checks.empty()) {
      verdict();
    } else {
      std::cout << bank_file.string() << ":\n";
    }
    for (const std::string& problem : unfitted) {
      std::cerr << "skidimm validate: warning: " << bank_file.string() << ": " << printable(problem) << "\n";
    }
    // Warnings, not errors: a log may have a column of exactly such a text.
    for (const std::string& problem : unreadable) {
      std::cerr << "skidimm validate: warning: " << problem
                << " (a log can give it only as a column of exactly this text; --check LOG reads one)\n";
    }
    for (const std::string& field : aggregated) {
      // At the text's line, as the loader's errors are located.
      const std::string name = field.substr(field.rfind('.') + 1);
      const auto at = std::find(c.measurement.names.begin(), c.measurement.names.end(), name);
      const std::size_t i = static_cast<std::size_t>(at - c.measurement.names.begin());
      const int line = i < c.columns.measurement_lines.size() ? c.columns.measurement_lines[i] : 0;
      std::cerr << "skidimm validate: warning: " << bank_file.string()
                << (line > 0 ? ":" + std::to_string(line) : std::string()) << ": " << field
                << " aggregates the rows of a filter step, which needs a fixed step: run, eval, fit and tune "
                   "refuse this bank without --rate (unless a log has a column of exactly this text); set "
                   "sampling.rate (Hz) in the bank, or give --rate\n";
    }
    std::cout << "  bank:        " << c.name << (c.description.empty() ? "" : " - " + c.description) << "\n";
    std::cout << "  states:      [" << join(c.state_names) << "]";
    std::vector<std::string> angles;
    for (int s = 0; s < c.state_dim(); ++s) {
      if (c.angle_mask[s]) angles.push_back(c.state_names[s]);
    }
    if (!angles.empty()) std::cout << ", angles [" << join(angles) << "]";
    std::cout << "\n  inputs:      [" << join(c.input_names) << "] from columns [" << join(c.columns.inputs) << "]\n";
    std::cout << "  measurement: [" << join(c.measurement.names) << "] from columns [" << join(c.columns.measurements)
              << "]\n";
    std::cout << "  time column: " << c.columns.time
              << (c.columns.time_units_per_second == 1.0 ? "" : " (in " + c.columns.time_unit_name + ")")
              << (c.columns.truth_mode.empty() ? "" : ", truth column: " + c.columns.truth_mode) << "\n";
    std::cout << "  modes:\n";
    for (std::size_t j = 0; j < c.modes.size(); ++j) {
      std::printf("    %-24s %-16s p0 = %.3f\n", c.modes[j].name.c_str(), c.modes[j].model.c_str(),
                  c.initial_mode_probabilities[static_cast<Eigen::Index>(j)]);
    }
    std::cout << "  plugins:\n";
    for (std::size_t j = 0; j < bank.model_sources.size(); ++j) {
      std::cout << "    " << c.modes[j].name << ": " << plugin_of(bank, j) << "\n";
    }
    if (checks.empty()) return kExitOk;

    std::vector<LogOperatingPoint> points;
    std::size_t logs = 0, log_warnings = 0;
    for (const std::string& argument : checks) {
      for (const LogSpec& log : expand_log_argument(argument, unpaired_runs("skidimm validate", false))) {
        std::vector<std::string> unmeasured, labels;
        const std::vector<LogOperatingPoint> found = operating_points_from_log(c, log, 20, &unmeasured, &labels);
        points.insert(points.end(), found.begin(), found.end());
        // A truth the bank cannot score or fit by: a typo fit and tune refuse later, or a new terrain's name.
        for (const std::string& label : labels) {
          if (c.class_index(label) >= 0) continue;
          unmeasured.push_back((log.label.empty() ? "its truth column '" + c.columns.truth_mode + "' holds a label "
                                                  : std::string("its label is one ")) +
                               "the bank does not know: " + c.unknown_label(label) +
                               " (fit and tune refuse the log; eval reports those steps as a truth the bank lacks)");
        }
        // Checked against this log, the bank names a column it never gives.
        for (const std::string& line : unmeasured) {
          std::cerr << "skidimm validate: warning: " << printable(log.text) << ": " << printable(line) << "\n";
        }
        log_warnings += unmeasured.size();
        ++logs;
      }
    }
    if (log_warnings > 0) buts.push_back(std::to_string(log_warnings) + " warning(s) about the log(s) of --check");
    std::cout << "  model checks (the conformance kit's) at " << points.size() << " operating points of " << logs
              << " log(s):\n";
    bool all_ok = true;
    for (const ModeConformance& mode : check_models(bank, points)) {
      if (mode.ok()) {
        std::cout << "    " << mode.mode << ": ok\n";
        continue;
      }
      all_ok = false;
      std::cout << "    " << mode.mode << ": FAILED at " << mode.failed_points << " of " << mode.points
                << " points; first at " << mode.first_failure_at << ":\n";
      // The kit's messages span lines (the differing entries, both matrices);
      // a plugin's reason inside them is text from outside, made printable.
      for (const std::string& failure : mode.failures) {
        std::size_t begin = 0;
        while (begin <= failure.size()) {
          const std::size_t end = std::min(failure.find('\n', begin), failure.size());
          std::cout << "      " << printable(std::string_view(failure).substr(begin, end - begin)) << "\n";
          begin = end + 1;
        }
      }
    }
    if (!all_ok) {
      std::cerr << "skidimm validate: a mode's model fails the checks at operating points of the log(s): its "
                   "filter runs, but on a wrong model (see the reasons above: a derivative that differs is the "
                   "plugin's to fix; one that cannot be checked comes of a value too large to difference, often a "
                   "parameter of "
                << bank_file.string() << " out of scale)\n";
      return kExitFailure;
    }
    verdict();
    return kExitOk;
  });
}

int plugins(const std::vector<fs::path>& plugin_paths) {
  PluginRegistry registry(PluginRegistry::standard_search_path(plugin_paths));
  std::cout << "search path (first match wins):\n";
  for (const fs::path& p : registry.search_path()) {
    std::error_code ec;
    std::cout << "  " << p.string() << (fs::exists(p, ec) ? "" : "  (missing)") << "\n";
  }
  const std::vector<PluginDescriptor>& found = registry.plugins();
  if (found.empty()) {
    std::cout << "no plugins found\n";
    return kExitOk;
  }
  for (const PluginDescriptor& d : found) {
    std::cout << "\n";
    if (!d.error.empty()) {
      std::cout << (d.name.empty() ? "?" : d.name) << "  UNUSABLE  " << d.path.string() << "\n    " << d.error << "\n";
      continue;
    }
    std::cout << d.name << " " << d.version << (d.shadowed ? "  (shadowed by an earlier plugin of this name)" : "")
              << "\n    " << d.description << "\n    file: " << d.path.string() << "\n";
    if (!d.duplicate_of.empty()) {
      std::cout << "    DUPLICATE: " << d.duplicate_of.string() << " in the same directory is also named '" << d.name
                << "'; a bank using it fails until one is removed or renamed\n";
    }
    auto variables = [](const char* title, const std::vector<PluginVariable>& list, const char* none) {
      std::cout << "    " << title << ":";
      if (list.empty()) {
        std::cout << " " << none << "\n";
        return;
      }
      std::cout << "\n";
      for (const PluginVariable& v : list) {
        std::cout << "      " << v.name << (v.is_angle ? " (angle, wrapped to [-pi, pi))" : "")
                  << (v.description.empty() ? "" : ": " + v.description) << "\n";
      }
    };
    variables("states", d.states, "the bank's own (not declared by the plugin)");
    variables("inputs", d.inputs, "the bank's own (not declared by the plugin)");
    if (!d.outputs.empty()) variables("outputs", d.outputs, "");
    if (!d.parameter_docs.empty()) {
      std::cout << "    parameters:\n";
      for (const std::string& doc : d.parameter_docs) std::cout << "      " << doc << "\n";
    }
  }
  return kExitOk;
}

}  // namespace cli
}  // namespace skidimm
