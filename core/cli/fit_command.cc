#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <sstream>

#include "commands.h"
#include "skidimm/config/bank.h"
#include "skidimm/errors.h"
#include "skidimm/fitting/bank_fit.h"
#include "skidimm/fitting/bank_writer.h"
#include "skidimm/fitting/fit_logs.h"
#include "skidimm/fitting/fit_output.h"
#include "skidimm/fitting/likelihood_fitter.h"
#include "skidimm/fitting/model_fitter.h"
#include "skidimm/fitting/solver_messages.h"
#include "skidimm/io/csv.h"
#include "skidimm/io/log_reader.h"
#include "skidimm/io/output_file.h"
#include "skidimm/printable.h"
#include "skidimm/progress.h"

namespace skidimm {
namespace cli {

namespace fs = std::filesystem;
using fitting::FitReport;
using fitting::ModeLogs;

namespace {

std::string fixed(double v, int digits = 4) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.*g", digits, v);
  return buffer;
}

// The measurements whose error is above the no-change baseline's, both
// known ("omega, current"), or "".
std::string worse_than_no_change(const BankConfig& config, const Eigen::VectorXd& rmse,
                                 const Eigen::VectorXd& baseline) {
  std::string out;
  for (Eigen::Index c = 0; c < rmse.size() && c < baseline.size(); ++c) {
    if (std::isfinite(rmse[c]) && std::isfinite(baseline[c]) && rmse[c] > baseline[c]) {
      out += (out.empty() ? "" : ", ") + config.measurement.names[static_cast<std::size_t>(c)];
    }
  }
  return out;
}

void print_report(const BankConfig& config, const std::string& name, const ModeLogs& data, const FitReport& r) {
  const int logs = fitting::log_count(data);
  const int segments = static_cast<int>(data.logs.size());
  std::cerr << "mode '" << name << "': " << logs << " log(s)"
            << (segments != logs ? " (" + std::to_string(segments) + " segments)" : std::string());
  if (r.derivatives.empty() && r.iterations == 0 && r.residuals == 0) {
    // No solve ran (fit_bank's mode with nothing of its own to fit): no
    // "0 iterations, cost 0 -> 0" that would read as a fit that failed.
    std::cerr << ": nothing of its own to fit; evaluated at its parameters\n";
  } else {
    std::cerr << ", " << r.residuals << " residuals, "
              << (r.derivatives == "none" ? std::string("no model parameters (noise only)")
                                          : r.derivatives + " derivatives")
              << ", " << r.iterations << " iterations, cost " << fixed(r.initial_cost) << " -> " << fixed(r.final_cost)
              << ", condition number " << fixed(r.condition_number, 3) << "\n";
  }
  // A standard deviation is NaN when Ceres could not compute the covariance
  // (warned below) or the parameter was held: say so rather than "+- nan".
  auto print_estimate = [](const fitting::ParameterEstimate& p) {
    std::cerr << "  " << p.name << " = " << fixed(p.value, 6)
              << (std::isfinite(p.standard_deviation) ? " +- " + fixed(p.standard_deviation, 2)
                                                      : std::string(" (no standard deviation)"))
              << "\n";
  };
  for (const fitting::ParameterEstimate& p : r.parameters) print_estimate(p);
  for (const fitting::ParameterEstimate& p : r.noise_parameters) print_estimate(p);
  if (std::isfinite(r.negative_log_likelihood)) {
    std::cerr << "  negative log-likelihood " << fixed(r.negative_log_likelihood, 8) << " over " << r.measured_rows
              << " measured rows (" << fixed(r.negative_log_likelihood_per_row) << " per row)\n";
    std::cerr << "  innovation RMSE: " << fitting::measurement_values_text(config, r.rmse) << "\n";
    std::cerr << "  mean NIS (1 when consistent): " << fitting::measurement_values_text(config, r.mean_nis, 3) << "\n";
  } else {
    std::cerr << "  one-step RMSE: " << fitting::measurement_values_text(config, r.rmse) << "\n";
  }
  const Eigen::VectorXd baseline = fitting::persistence_rmse(data);
  std::cerr << "  (no-change baseline: " << fitting::measurement_values_text(config, baseline) << ")\n";
  const std::string worse = worse_than_no_change(config, r.rmse, baseline);
  if (!worse.empty()) {
    std::cerr << "  worse than no change on " << worse
              << ": a motion model that does not beat it is not worth having; a feature that tells classes apart "
                 "by its level may not (docs/fitting.md)\n";
  }
  std::cerr << "  Q = " << fitting::format_matrix(r.q_intensity) << "\n";
  for (const std::string& w : r.warnings) std::cerr << "  warning: " << w << "\n";
}

std::string steps_text(double rate) {
  if (!(rate > 0.0)) return "at every time stamp";
  char seconds[32];
  std::snprintf(seconds, sizeof(seconds), "%.4g", 1.0 / rate);  // 0.3333 s, not 0.3333333333333333 s
  return "every " + std::string(seconds) + " s (" + CsvWriter::format(rate) + " Hz)";
}

// A mode fitted on steps of one length, where the bank's measurements
// aggregate a step's rows (mean(), std()), measures something else on steps
// of another: said before the fit, which cannot be undone by the bank it joins.
void warn_of_a_bank_at_another_rate(const BankConfig& fitted_with, const SamplingConfig& fitted_at,
                                    const std::string& option, const std::filesystem::path& target_file,
                                    const BankConfig& target) {
  if (target.sampling.rate == fitted_at.rate) return;
  const std::vector<std::string> aggregated = LogReader::aggregated_measurements(fitted_with);
  if (aggregated.empty()) return;
  std::string names;
  for (const std::string& n : aggregated) names += (names.empty() ? "" : ", ") + n;
  std::cerr << "skidimm fit: warning: " << option << " " << target_file.string() << " steps "
            << steps_text(target.sampling.rate)
            << (target.sampling.rate > 0.0 ? ", its sampling.rate," : " (it has no sampling.rate)") << " and this fit "
            << steps_text(fitted_at.rate) << ": " << names
            << " aggregate a step's rows, so the fitted mode would measure there something other than what it was "
               "fitted on. Fit at the bank's rate (--rate), or set its sampling.rate to this one\n";
}

// A bank `skidimm tune` wrote carries its tuned scales in every mode (Q
// times the chosen scale, each mode's parameter covariance where tuned with
// parameter uncertainty); a mode fitted alone and appended carries none of
// them, and competes on other terms. Said before the fit, from the header
// tune writes ("Written by skidimm tune", then "Chosen: ...").
void warn_of_appending_to_a_tuned_bank(const std::filesystem::path& target_file) {
  std::ifstream in(target_file);
  std::string line, chosen;
  bool tuned = false;
  for (int n = 0; n < 8 && std::getline(in, line) && line.rfind("#", 0) == 0; ++n) {
    tuned = tuned || line.rfind("# Written by skidimm tune", 0) == 0;
    if (line.rfind("# Chosen: ", 0) == 0) chosen = line.substr(10);
  }
  if (!tuned) return;
  std::cerr << "skidimm fit: warning: --append-to " << target_file.string() << ": a bank skidimm tune wrote"
            << (chosen.empty() ? std::string() : " (chosen: " + chosen + ")")
            << "; its modes carry the tuned scales (each Q times the chosen Q scale, and any parameter uncertainty "
               "it was tuned with), which the appended mode's fit does not, so it competes on other terms. Tune the "
               "bank again with the new mode's logs among the others (skidimm tune --bank "
            << target_file.string() << " ...) so that every mode is scaled alike\n";
}

}  // namespace

int fit(const FitCommandOptions& options) {
  fitting::capture_solver_messages();  // Ceres' glog output, summarised below instead of flooding stderr
  const int code = report_errors("skidimm fit", [&] {
    // Options that cannot go together are a bad command line, said before
    // the bank and the logs are read (the fit would refuse it only then).
    if (options.shared && fitting::objective_from_string(options.objective) == fitting::Objective::kLikelihood) {
      throw UsageError(
          "--shared fits the bank-level (shared:) parameters by the window objective only: add "
          "--objective window (the likelihood objective fits each mode's own parameters and noise)");
    }
    Bank bank = Bank::load(options.bank, options.plugin_paths);
    {
      FatalSignalWording wording;
      wording.lost = "nothing is written";
      wording.every_model_call_marked = false;  // the fits call the models themselves
      wording.several_threads = true;
      name_plugins_in_fatal_signals("skidimm fit", bank, wording);
    }
    const BankConfig& config = bank.config;
    if (options.hold_unexcited) {
      const std::string ignored =
          fitting::hold_unexcited_ignored(config, fitting::objective_from_string(options.objective));
      if (!ignored.empty()) throw UsageError("--hold-unexcited would do nothing: " + ignored + "; leave it out");
    }
    const SamplingConfig sampling = sampling_of(config, options.rate);
    const LogArgumentOptions expansion = unpaired_runs("skidimm fit", options.skip_unpaired);
    // Named for what it is, before any log is read (it was blamed on the first --log).
    if (!options.mode.empty() && config.mode_index(options.mode) < 0 && config.class_index(options.mode) < 0) {
      throw Error("--mode '" + printable(options.mode) + "': the bank (" + options.bank.string() +
                  "): " + config.unknown_label(options.mode));
    }
    const std::vector<ModeLogs> data =
        fitting::load_mode_logs(config, options.logs, options.mode, sampling, "--log", expansion);
    if (data.empty()) throw Error("no logs given (--log)");
    for (const std::string& overridden : fitting::labels_overriding_truth(config, data)) {
      std::cerr << "skidimm fit: warning: " << printable(overridden) << "\n";
    }
    for (const std::string& skipped : fitting::skipped_by_sampling(data)) {
      std::cerr << "skidimm fit: " << printable(skipped) << "\n";
    }
    for (const std::string& short_log : fitting::logs_spanning_under_a_second(config, data)) {
      std::cerr << "skidimm fit: warning: " << printable(short_log) << "\n";
    }
    for (const std::string& unfitted : fitting::classes_leaving_steps_unfitted(config)) {
      std::cerr << "skidimm fit: warning: " << options.bank.string() << ": " << printable(unfitted) << "\n";
    }
    if (!options.output_bank.empty() && options.mode.empty()) {
      // The written bank holds every mode: one the logs gave no step is the
      // start bank's, which reads like a fitted entry.
      std::string unfitted;
      int count = 0;
      for (int j = 0; j < config.num_modes(); ++j) {
        const bool has_data = std::any_of(data.begin(), data.end(), [j](const ModeLogs& d) { return d.mode == j; });
        if (has_data) continue;
        unfitted += std::string(count++ == 0 ? "" : ", ") + "'" + config.modes[static_cast<std::size_t>(j)].name + "'";
      }
      if (count > 0) {
        std::cerr << "skidimm fit: warning: " << (count == 1 ? "mode " : "modes ") << printable(unfitted)
                  << (count == 1 ? " has" : " have")
                  << (count == 1 ? " no step in the logs (no log of its class, or none where its fit_when holds): "
                                 : " no step in the logs (no log of their class, or none where their fit_when "
                                   "holds): ")
                  << options.output_bank.string() << " keeps " << (count == 1 ? "its" : "their")
                  << " starting values from " << options.bank.string() << "\n";
      }
    }
    if (options.fit_r && !options.append_to.empty()) {
      throw Error("--fit-r fits the bank's R, which --append-to cannot change: use --output-bank");
    }
    // Everything the fit is written to or scored on is checked before it
    // starts: a mistyped path or label found after a long fit would lose it.
    if (!options.append_to.empty()) {
      if (data.size() != 1) throw Error("--append-to takes the fit of exactly one mode");
      const BankConfig target = load_bank_config(options.append_to);
      check_output_path(options.append_to, "--append-to");
      warn_of_a_bank_at_another_rate(config, sampling, "--append-to", options.append_to, target);
      warn_of_appending_to_a_tuned_bank(options.append_to);
    }
    if (!options.name.empty()) {
      // Checked before the fit: the written bank would refuse the name
      // only after it, and an --output-entry is written without a check.
      const std::string& name = options.name;
      const std::string problem = name_problem(name);
      if (!problem.empty()) throw Error("--name: " + problem);
      const auto taken = [&](const BankConfig& target, const std::string& renamed, const std::string& where) {
        for (const ModeConfig& m : target.modes) {
          if (m.name == name && m.name != renamed) {
            throw Error("--name '" + name + "': " + where + " already has a mode of that name: pick another");
          }
        }
      };
      // A class's modes keep their names whatever is written; a mode its
      // class lists by name breaks the whole bank written (--output-bank).
      const std::string renaming = fitting::renaming_problem(config, options.mode, name);
      const bool a_class = config.mode_index(options.mode) < 0;
      if (!renaming.empty() && (a_class || !options.output_bank.empty())) {
        throw Error("--name '" + name + "': " + renaming);
      }
      if (!options.output_bank.empty()) taken(config, options.mode, "the bank (" + options.bank.string() + ")");
      if (!options.append_to.empty()) {
        taken(load_bank_config(options.append_to), "", "--append-to " + options.append_to.string());
      }
    } else if (!options.append_to.empty()) {
      // The fitted mode keeps its name: one the bank already has is a clash too.
      const std::string& name = config.modes[static_cast<std::size_t>(data[0].mode)].name;
      for (const ModeConfig& m : load_bank_config(options.append_to).modes) {
        if (m.name == name) {
          throw Error("mode '" + name + "': --append-to " + options.append_to.string() +
                      " already has a mode of that name: give the fitted mode another with --name");
        }
      }
    }
    if (!options.output_bank.empty()) check_output_path(options.output_bank, "--output-bank");
    if (!options.output_entry.empty()) check_output_path(options.output_entry, "--output-entry");
    std::vector<LogSpec> read;
    LogArgumentOptions quietly = expansion;  // the runs it leaves out were told above
    quietly.skipped = nullptr;
    for (const auto* arguments : {&options.logs, &options.held_out}) {
      for (const std::string& argument : *arguments) {
        for (LogSpec& spec : expand_log_argument(argument, quietly)) read.push_back(std::move(spec));
      }
    }
    refuse_output_over_logs(options.append_to, "--append-to", read);
    refuse_output_over_logs(options.output_bank, "--output-bank", read);
    refuse_output_over_logs(options.output_entry, "--output-entry", read);
    // A bank written over the bank it was read from (--output-bank, --append-to)
    // is an update in place; the entries alone would replace it.
    refuse_clashing_files({{"--append-to", options.append_to},
                           {"--output-bank", options.output_bank},
                           {"--output-entry", options.output_entry}});
    refuse_clashing_files({{"--output-entry", options.output_entry}}, {{"--bank", options.bank}});
    std::vector<std::pair<std::string, std::vector<ModeLogs>>> held_out;
    for (const std::string& text : options.held_out) {
      // The argument's logs are read on their own threads. A file that cannot
      // be read is blamed on --held-out, as a label is.
      try {
        held_out.emplace_back(text,
                              fitting::load_mode_logs(config, {text}, options.mode, sampling, "--held-out", expansion));
      } catch (const LogError& e) {
        throw Error("--held-out '" + text + "': " + e.what());
      }
    }

    fitting::FitRequest request;
    fitting::BankFitOptions& fit_options = request.options;
    fit_options.objective = fitting::objective_from_string(options.objective);
    fit_options.window.window = options.window;
    fit_options.window.loss = options.loss;
    fit_options.window.loss_scale = options.loss_scale;
    fit_options.window.hold_unexcited = options.hold_unexcited;
    fit_options.shared = options.shared;
    fit_options.fit_measurement_noise = options.fit_r;
    fit_options.full_process_noise = options.full_q;
    fit_options.output_noise = options.output_noise;
    fit_options.parameter_uncertainty = options.parameter_uncertainty;
    fit_options.uncertainty_per_log = options.uncertainty_per_log;
    fit_options.residual_correlation = options.residual_correlation;
    fit_options.pooled_process_noise = options.pooled_q;
    fit_options.partial_pooling = options.partial_pooling;
    request.mode = options.mode;
    request.name = options.name;
    request.sampling = sampling;
    if (!options.append_to.empty()) {
      // The entry of the starting values joins the bank as the fitted one
      // would: a bank it cannot join is said now, not after the fit.
      FitReport start;
      start.q_intensity = config.modes[static_cast<std::size_t>(data[0].mode)].q_intensity;
      const std::vector<fitting::FittedMode> unfitted{{data[0].mode, fitting::log_count(data[0]), start}};
      try {
        fitting::check_mode_appends(options.append_to, fitting::format_fitted_entries(bank, unfitted, request));
      } catch (const ConfigError& e) {
        throw ConfigError(e.file(), e.line(), e.field(),
                          "--append-to cannot take mode '" + fitting::output_mode_name(config, request, data[0].mode) +
                              "' (nothing was fitted or written): " + e.message() +
                              "; write the entry with --output-entry and add it to the bank by hand");
      }
    }
    // The work up front: a fit on a long log is long, and should say so before it starts.
    std::cerr << "skidimm fit: " << fitting::fit_work(bank, data, fit_options).describe() << "\n";
    // Each solve's iterations, rate and time so far; only on a terminal.
    StagedProgress progress("skidimm fit", "iterations", true);
    if (progress.enabled()) fit_options.progress = std::ref(progress);
    std::map<int, FitReport> reports = fitting::fit_bank(&bank, data, fit_options);
    progress.clear();

    if (options.fit_r) std::cerr << "fitted bank R = " << fitting::format_matrix(bank.config.measurement.r) << "\n";
    std::vector<fitting::FittedMode> fitted;
    for (const ModeLogs& d : data) {
      fitted.push_back(fitting::FittedMode{d.mode, fitting::log_count(d), reports[d.mode]});
      print_report(config, fitting::output_mode_name(config, request, d.mode), d, fitted.back().report);
    }
    const std::string entries = fitting::format_fitted_entries(bank, fitted, request);

    // A held-out log the fitted bank cannot score fails the command, but
    // after the fit is written.
    std::exception_ptr held_out_error;
    for (const auto& [text, logs] : held_out) {
      for (const ModeLogs& held : logs) {
        const std::string& mode_name = config.modes[static_cast<std::size_t>(held.mode)].name;
        // A one-step prediction is scored on two rows in a row: without any
        // (a one-row log, a mode's single row in a truth column), every error
        // would print as 0.
        long rows = 0, pairs = 0;
        for (const fitting::Trajectory& t : held.logs) {
          rows += t.size();
          pairs += std::max(0, t.size() - 1);
        }
        if (pairs == 0) {
          std::cerr << "held out " << text << " (" << mode_name << "): " << rows
                    << " row(s), too few to score a one-step prediction (two in a row)\n";
          continue;
        }
        FitReport r;
        try {
          r = fitting::evaluate(bank, held);
        } catch (const Error& e) {
          held_out_error = std::make_exception_ptr(Error("--held-out '" + text + "': " + e.what()));
          break;
        }
        const Eigen::VectorXd baseline = fitting::persistence_rmse(held);
        const std::string worse = worse_than_no_change(config, r.rmse, baseline);
        std::cerr << "held out " << text << " (" << mode_name << "): one-step RMSE "
                  << fitting::measurement_values_text(config, r.rmse) << " (no-change baseline "
                  << fitting::measurement_values_text(config, baseline)
                  << (worse.empty() ? std::string() : "; worse than no change on " + worse) << ")";
        // The mode's own filter on the held-out log, whichever objective fitted it.
        const fitting::LikelihoodEvaluation e = fitting::evaluate_likelihood(bank, held);
        if (e.failure.empty()) {
          std::cerr << "; negative log-likelihood per measured row " << fixed(e.negative_log_likelihood / e.measured_rows)
                    << ", innovation RMSE " << fitting::measurement_values_text(config, e.rmse);
        } else {
          std::cerr << "; the filter failed: " << e.failure;
        }
        std::cerr << "\n";
        if (r.failed_predictions > 0) {
          std::cerr << "  warning: " << fitting::failed_predictions_text(r) << "; the RMSE leaves them out\n";
        }
      }
      if (held_out_error) break;
    }

    if (!options.append_to.empty()) {
      fitting::append_mode_to_bank(options.append_to, entries);
      std::cerr << "appended mode '" << fitting::output_mode_name(config, request, data[0].mode) << "' to "
                << options.append_to.string() << "\n";
    }
    if (!options.output_bank.empty()) {
      fitting::write_fitted_bank(bank, fitted, request, options.bank, options.output_bank,
                                 {"Written by skidimm fit; reproduce with:", "  " + options.command_line});
      std::cerr << "wrote " << options.output_bank.string() << "\n";
    }
    // Written whole, then renamed (output_file.h): never half a file, and a
    // full disk is an error with its reason.
    if (!options.output_entry.empty()) write_file_atomically(options.output_entry, entries);
    if (options.append_to.empty() && options.output_bank.empty() && sampling.rate != config.sampling.rate) {
      // The entries alone do not carry the rate; the bank they join must.
      std::cerr << "skidimm fit: the entries were fitted on steps " << steps_text(sampling.rate)
                << ": the bank they join should step at that rate (its sampling.rate: "
                << CsvWriter::format(sampling.rate) << ")\n";
    }
    if (options.append_to.empty() && options.output_bank.empty() && options.output_entry.empty()) std::cout << entries;
    if (held_out_error) std::rethrow_exception(held_out_error);
    return kExitOk;
  });
  const std::string solver = fitting::take_solver_messages("");
  if (!solver.empty()) std::cerr << "skidimm fit: " << solver;
  return code;
}

}  // namespace cli
}  // namespace skidimm
