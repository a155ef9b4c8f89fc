#include "skidimm/fitting/fit_output.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "not_a_number.h"
#include "skidimm/fitting/bank_writer.h"

namespace skidimm {
namespace fitting {

namespace {

std::string significant(double v, int digits = 4) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.*g", digits, v);
  return buffer;
}

bool likelihood(const FitRequest& request) { return request.options.objective == Objective::kLikelihood; }

// The order mode j's parameters are written in (bank_writer.h).
const std::vector<std::string>& parameter_table(const Bank& bank, int j) {
  static const std::vector<std::string> none;
  return static_cast<std::size_t>(j) < bank.model_sources.size()
             ? bank.model_sources[static_cast<std::size_t>(j)].parameter_keys
             : none;
}

const FittedMode* find_fitted(const std::vector<FittedMode>& fitted, int j) {
  for (const FittedMode& f : fitted) {
    if (f.mode == j) return &f;
  }
  return nullptr;
}

}  // namespace

std::string output_mode_name(const BankConfig& config, const FitRequest& request, int j) {
  const std::string& original = config.modes[static_cast<std::size_t>(j)].name;
  return !request.name.empty() && original == request.mode ? request.name : original;
}

std::string renaming_problem(const BankConfig& config, const std::string& mode, const std::string& name) {
  if (name.empty() || name == mode) return "";
  if (config.class_index(mode) >= 0 && config.mode_index(mode) < 0) {
    return "the name renames one mode, and '" + mode + "' is a class of " + config.shown_file() +
           ", whose modes would keep their names: give one of its modes, or leave the name out";
  }
  const int renamed = config.mode_index(mode);
  if (renamed < 0) return "";
  for (const ClassConfig& c : config.classes) {
    if (std::find(c.modes.begin(), c.modes.end(), renamed) != c.modes.end()) {
      return "the written bank would rename mode '" + mode + "' to '" + name + "', and class " + c.name + " of " +
             config.shown_file() +
             " lists it by its old name (classes:): fit a copy of the bank with the new mode and its class in it, "
             "or write the entry alone (fit --output-entry) and add it by hand (docs/fitting.md)";
    }
  }
  return "";
}

std::string measurement_values_text(const BankConfig& config, const Eigen::VectorXd& values, int digits) {
  std::string out;
  for (Eigen::Index c = 0; c < values.size(); ++c) {
    out += (c ? ", " : "") + config.measurement.names[static_cast<std::size_t>(c)] + " " +
           (std::isnan(values[c]) ? std::string("not measured") : significant(values[c], digits));
  }
  return out;
}

Eigen::VectorXd persistence_rmse(const ModeLogs& data) {
  const Eigen::Index m = data.logs.empty() ? 0 : data.logs[0].z.rows();
  Eigen::VectorXd squared = Eigen::VectorXd::Zero(m), counts = Eigen::VectorXd::Zero(m);
  for (const Trajectory& t : data.logs) {
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
  return (counts.array() > 0.0).select((squared.array() / counts.array().max(1.0)).sqrt(), ::skidimm::internal::kNaN);
}

namespace {

// Mode f.mode as the fit leaves it: its output name and fitted Q.
ModeConfig fitted_mode(const BankConfig& config, const FittedMode& f, const FitRequest& request) {
  ModeConfig mode = config.modes[static_cast<std::size_t>(f.mode)];
  mode.name = output_mode_name(config, request, f.mode);
  mode.q_intensity = f.report.q_intensity;
  return mode;
}

}  // namespace

std::string format_fitted_entries(const Bank& bank, const std::vector<FittedMode>& fitted, const FitRequest& request) {
  const BankConfig& config = bank.config;
  const FitOptions& window = request.options.window;
  std::string entries;
  for (const FittedMode& f : fitted) {
    const std::string comment =
        (likelihood(request) ? std::string("fitted by skidimm fit (likelihood) from ")
                             : "fitted by skidimm fit (window " + significant(window.window) + " s, " + window.loss +
                                   ") from ") +
        std::to_string(f.logs) + " log(s); " + (likelihood(request) ? "innovation RMSE " : "one-step RMSE ") +
        measurement_values_text(config, f.report.rmse);
    entries += format_mode_entry(fitted_mode(config, f, request), *bank.models[static_cast<std::size_t>(f.mode)],
                                 {comment}, parameter_table(bank, f.mode), config.input_names);
  }
  return entries;
}

void write_fitted_bank(const Bank& bank, const std::vector<FittedMode>& fitted, const FitRequest& request,
                       const std::filesystem::path& template_file, const std::filesystem::path& output,
                       const std::vector<std::string>& header) {
  const BankConfig& config = bank.config;
  std::string modes_block = "modes:\n";
  for (int j = 0; j < config.num_modes(); ++j) {
    const sdk::MotionModel& model = *bank.models[static_cast<std::size_t>(j)];
    if (const FittedMode* f = find_fitted(fitted, j)) {
      const std::string comment = std::string(likelihood(request) ? "innovation RMSE " : "one-step RMSE ") +
                                  measurement_values_text(config, f->report.rmse) + " on " + std::to_string(f->logs) +
                                  " log(s)";
      modes_block += format_mode_entry(fitted_mode(config, *f, request), model, {comment}, parameter_table(bank, j),
                                       config.input_names);
    } else {
      ModeConfig mode = config.modes[static_cast<std::size_t>(j)];
      mode.name = output_mode_name(config, request, j);
      modes_block += format_mode_entry(mode, model, {"not fitted: no log given for this mode"},
                                       parameter_table(bank, j), config.input_names);
    }
  }
  std::vector<std::pair<std::string, std::string>> blocks;
  if (request.options.shared) {
    blocks.emplace_back(
        "shared", "shared: " +
                      format_parameters(*bank.models[0], sdk::ParameterScope::kBank, config.shared,
                                        parameter_table(bank, 0)) +
                      "\n");
  }
  if (request.options.fit_measurement_noise) blocks.emplace_back("measurement", format_measurement_block(config));
  if (request.sampling && request.sampling->rate != config.sampling.rate) {
    blocks.emplace_back("sampling", format_sampling_block(*request.sampling));
  }
  blocks.emplace_back("modes", modes_block);
  write_bank_from_template(template_file, output, header, blocks);
}

}  // namespace fitting
}  // namespace skidimm
