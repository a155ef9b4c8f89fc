#include <cmath>
#include <cstdio>
#include <exception>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>

#include "commands.h"
#include "log_arguments.h"
#include "skidimm/bank.h"
#include "skidimm/errors.h"
#include "skidimm/fitting/bank_fit.h"
#include "skidimm/fitting/bank_writer.h"
#include "skidimm/fitting/likelihood_fitter.h"
#include "skidimm/fitting/model_fitter.h"
#include "skidimm/fitting/solver_messages.h"
#include "skidimm/fitting/trajectory.h"
#include "skidimm/output_file.h"
#include "skidimm/parallel.h"

namespace skidimm {
namespace cli {

namespace fs = std::filesystem;
using fitting::FitReport;
using fitting::ModeLogs;

namespace {

// The logs of the --log (or --held-out) arguments, by mode (mode_segments).
// Each log is read on its own thread (parallel.h), then merged in argument
// order: the same segments, in the same order, as one thread reads them, and
// the same first error.
std::vector<ModeLogs> load_logs(const BankConfig& config, const std::vector<std::string>& arguments,
                                const std::string& default_mode, const SamplingConfig& sampling,
                                const std::string& option = "--log") {
  struct Job {
    LogSpec log;
    std::exception_ptr error;  // expanding its argument failed
  };
  std::vector<Job> jobs;
  for (const std::string& argument : arguments) {
    try {
      for (const LogSpec& log : expand_log_argument(argument)) jobs.push_back(Job{log, nullptr});
    } catch (...) {
      jobs.push_back(Job{LogSpec{}, std::current_exception()});
      break;
    }
  }
  std::vector<std::vector<ModeLogs>> segments(jobs.size());
  parallel_for(static_cast<int>(jobs.size()), worker_count(), [&](int i, int) {
    const Job& job = jobs[static_cast<std::size_t>(i)];
    if (job.error) std::rethrow_exception(job.error);
    segments[static_cast<std::size_t>(i)] = mode_segments(config, job.log, default_mode, sampling, option);
  });
  std::map<int, ModeLogs> by_mode;
  for (std::vector<ModeLogs>& log : segments) {
    for (ModeLogs& d : log) {
      by_mode[d.mode].mode = d.mode;
      for (auto& t : d.logs) by_mode[d.mode].logs.push_back(std::move(t));
    }
  }
  std::vector<ModeLogs> out;
  for (auto& [j, logs] : by_mode) out.push_back(std::move(logs));
  return out;
}

std::string fixed(double v, int digits = 4) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.*g", digits, v);
  return buffer;
}

// One-step RMSE of "nothing changes" (x_{k+1} = x_k): the baseline a model must beat.
Eigen::VectorXd persistence_rmse(const ModeLogs& data) {
  const Eigen::Index m = data.logs.empty() ? 0 : data.logs[0].z.rows();
  Eigen::VectorXd squared = Eigen::VectorXd::Zero(m), counts = Eigen::VectorXd::Zero(m);
  for (const fitting::Trajectory& t : data.logs) {
    std::vector<int> last(static_cast<std::size_t>(m), -1);
    for (int k = 0; k < t.size(); ++k) {
      for (Eigen::Index c = 0; c < m; ++c) {
        if (!std::isfinite(t.z(c, k))) continue;
        if (last[static_cast<std::size_t>(c)] >= 0) {
          const double e = t.z(c, k) - t.z(c, last[static_cast<std::size_t>(c)]);
          squared[c] += e * e;
          counts[c] += 1.0;
        }
        last[static_cast<std::size_t>(c)] = k;
      }
    }
  }
  return (squared.array() / counts.array().max(1.0)).sqrt();
}

std::string rmse_text(const BankConfig& config, const Eigen::VectorXd& rmse) {
  std::string out;
  for (Eigen::Index c = 0; c < rmse.size(); ++c) {
    out += (c ? ", " : "") + config.measurement.names[static_cast<std::size_t>(c)] + " " + fixed(rmse[c]);
  }
  return out;
}

void print_report(const BankConfig& config, const std::string& name, const ModeLogs& data, const FitReport& r) {
  std::cerr << "mode '" << name << "': " << data.logs.size() << " log(s), " << r.residuals << " residuals, "
            << r.derivatives << " derivatives, " << r.iterations << " iterations, cost " << fixed(r.initial_cost)
            << " -> " << fixed(r.final_cost) << ", condition number " << fixed(r.condition_number, 3) << "\n";
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
    std::cerr << "  innovation RMSE: " << rmse_text(config, r.rmse) << "\n";
    std::string nis;
    for (Eigen::Index c = 0; c < r.mean_nis.size(); ++c) {
      nis += (c ? ", " : "") + config.measurement.names[static_cast<std::size_t>(c)] + " " + fixed(r.mean_nis[c], 3);
    }
    std::cerr << "  mean NIS (1 when consistent): " << nis << "\n";
  } else {
    std::cerr << "  one-step RMSE: " << rmse_text(config, r.rmse) << "\n";
  }
  std::cerr << "  (no-change baseline: " << rmse_text(config, persistence_rmse(data)) << ")\n";
  std::cerr << "  Q = " << fitting::format_matrix(r.q_intensity) << "\n";
  for (const std::string& w : r.warnings) std::cerr << "  warning: " << w << "\n";
}

}  // namespace

int fit(const FitCommandOptions& options) {
  fitting::capture_solver_messages();  // Ceres' glog output, summarised below instead of flooding stderr
  const int code = report_errors("skidimm fit", [&] {
    Bank bank = Bank::load(options.bank, options.plugin_paths);
    const BankConfig& config = bank.config;
    const SamplingConfig sampling = sampling_of(config, options.rate);
    const std::vector<ModeLogs> data = load_logs(config, options.logs, options.mode, sampling, "--log");
    if (data.empty()) throw Error("no logs given (--log)");
    if (options.fit_r && !options.append_to.empty()) {
      throw Error("--fit-r fits the bank's R, which --append-to cannot change: use --output-bank");
    }

    fitting::BankFitOptions fit_options;
    fit_options.objective = fitting::objective_from_string(options.objective);
    fit_options.window.window = options.window;
    fit_options.window.loss = options.loss;
    fit_options.window.loss_scale = options.loss_scale;
    fit_options.window.hold_unexcited = options.hold_unexcited;
    fit_options.shared = options.shared;
    fit_options.fit_measurement_noise = options.fit_r;
    fit_options.full_process_noise = options.full_q;
    fit_options.output_noise = options.output_noise;
    std::map<int, FitReport> reports = fitting::fit_bank(&bank, data, fit_options);

    if (options.fit_r) std::cerr << "fitted bank R = " << fitting::format_matrix(bank.config.measurement.r) << "\n";
    auto output_name = [&](int j) {
      const std::string& original = config.modes[static_cast<std::size_t>(j)].name;
      return !options.name.empty() && original == options.mode ? options.name : original;
    };
    std::string logs_text;
    for (const std::string& l : options.logs) logs_text += (logs_text.empty() ? "" : " ") + l;
    std::string entries;
    for (const ModeLogs& d : data) {
      const FitReport& r = reports[d.mode];
      print_report(config, output_name(d.mode), d, r);
      const bool likelihood = fit_options.objective == fitting::Objective::kLikelihood;
      std::string comment = (likelihood ? std::string("fitted by skidimm fit (likelihood) from ")
                                        : "fitted by skidimm fit (window " + fixed(options.window) + " s, " +
                                              options.loss + ") from ") +
                            std::to_string(d.logs.size()) + " log(s); " +
                            (likelihood ? "innovation RMSE " : "one-step RMSE ") + rmse_text(config, r.rmse);
      const ModeConfig& mode = config.modes[static_cast<std::size_t>(d.mode)];
      entries +=
          fitting::format_mode_entry(output_name(d.mode), mode.model, *bank.models[static_cast<std::size_t>(d.mode)],
                                     r.q_intensity, {comment}, mode.params, mode.fit_when, mode.r);
    }

    for (const std::string& text : options.held_out) {
      // load_logs reads the argument's logs on their own threads.
      for (const ModeLogs& held : load_logs(config, {text}, options.mode, sampling, "--held-out")) {
        FitReport r;
        try {
          r = fitting::evaluate(bank, held);
        } catch (const Error& e) {
          throw Error("--held-out '" + text + "': " + e.what());
        }
        std::cerr << "held out " << text << " (" << config.modes[static_cast<std::size_t>(held.mode)].name
                  << "): one-step RMSE " << rmse_text(config, r.rmse) << " (no-change baseline "
                  << rmse_text(config, persistence_rmse(held)) << ")";
        // The mode's own filter on the held-out log, whichever objective fitted it.
        const fitting::LikelihoodEvaluation e = fitting::evaluate_likelihood(bank, held);
        if (e.failure.empty()) {
          std::cerr << "; negative log-likelihood per measured row " << fixed(e.negative_log_likelihood / e.measured_rows)
                    << ", innovation RMSE " << rmse_text(config, e.rmse);
        } else {
          std::cerr << "; the filter failed: " << e.failure;
        }
        std::cerr << "\n";
      }
    }

    if (!options.append_to.empty()) {
      if (data.size() != 1) throw Error("--append-to takes the fit of exactly one mode");
      fitting::append_mode_to_bank(options.append_to, entries);
      std::cerr << "appended mode '" << output_name(data[0].mode) << "' to " << options.append_to.string() << "\n";
    }
    if (!options.output_bank.empty()) {
      std::string modes_block = "modes:\n";
      for (int j = 0; j < config.num_modes(); ++j) {
        const ModeConfig& mode = config.modes[static_cast<std::size_t>(j)];
        const sdk::MotionModel& model = *bank.models[static_cast<std::size_t>(j)];
        const auto fitted = reports.find(j);
        if (fitted != reports.end()) {
          for (const ModeLogs& d : data) {
            if (d.mode != j) continue;
            std::string comment = std::string(fit_options.objective == fitting::Objective::kLikelihood
                                                  ? "innovation RMSE "
                                                  : "one-step RMSE ") +
                                  rmse_text(config, fitted->second.rmse) + " on " +
                                  std::to_string(d.logs.size()) + " log(s)";
            modes_block += fitting::format_mode_entry(output_name(j), mode.model, model, fitted->second.q_intensity,
                                                      {comment}, mode.params, mode.fit_when, mode.r);
          }
        } else {
          modes_block += fitting::format_mode_entry(output_name(j), mode.model, model, mode.q_intensity,
                                                    {"not fitted: no log given for this mode"}, mode.params,
                                                    mode.fit_when, mode.r);
        }
      }
      std::vector<std::pair<std::string, std::string>> blocks;
      if (options.shared) {
        blocks.emplace_back(
            "shared", "shared: " +
                          fitting::format_parameters(*bank.models[0], sdk::ParameterScope::kBank, config.shared) + "\n");
      }
      if (options.fit_r) blocks.emplace_back("measurement", fitting::format_measurement_block(bank.config));
      blocks.emplace_back("modes", modes_block);
      fitting::write_bank_from_template(options.bank, options.output_bank,
                                        {"Written by skidimm fit; reproduce with:", "  " + options.command_line}, blocks);
      std::cerr << "wrote " << options.output_bank.string() << "\n";
    }
    // Written whole, then renamed (output_file.h): never half a file, and a
    // full disk is an error with its reason.
    if (!options.output_entry.empty()) write_file_atomically(options.output_entry, entries);
    if (options.append_to.empty() && options.output_bank.empty() && options.output_entry.empty()) std::cout << entries;
    return kExitOk;
  });
  const std::string solver = fitting::take_solver_messages("");
  if (!solver.empty()) std::cerr << "skidimm fit: " << solver;
  return code;
}

}  // namespace cli
}  // namespace skidimm
