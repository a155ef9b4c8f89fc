// The CLI's fit command, compiled here for its log loading and the texts it
// writes (load_logs, fixed, rmse_text in an unnamed namespace there), so that
// skidimm.fit writes what `skidimm fit` writes. A stopgap like
// eval_reduction.cc's include (see the report of issue 14).
#include "fit_and_simulate.h"

#include <charconv>
#include <fstream>
#include <sstream>

#include "fit_command.cc"  // NOLINT(bugprone-suspicious-include)
#include "skidimm/log_io.h"
#include "skidimm/simulation/scenario.h"

namespace skidimm {
namespace python {

namespace fs = std::filesystem;

std::vector<fitting::ModeLogs> load_fit_logs(const BankConfig& config, const std::vector<std::string>& arguments,
                                             const std::string& default_mode, const SamplingConfig& sampling) {
  return cli::load_logs(config, arguments, default_mode, sampling);
}

// As cli::fit's texts.
FitTexts fit_texts(const Bank& bank, const std::vector<FittedMode>& fitted, const FitRequest& request,
                   const fs::path& output) {
  const BankConfig& config = bank.config;
  auto output_name = [&](int j) {
    const std::string& original = config.modes[static_cast<std::size_t>(j)].name;
    return !request.name.empty() && original == request.mode ? request.name : original;
  };
  const fitting::FitOptions& window = request.options.window;
  FitTexts texts;
  for (const FittedMode& f : fitted) {
    const bool likelihood = request.options.objective == fitting::Objective::kLikelihood;
    const std::string comment =
        (likelihood ? std::string("fitted by skidimm fit (likelihood) from ")
                    : "fitted by skidimm fit (window " + cli::fixed(window.window) + " s, " + window.loss + ") from ") +
        std::to_string(f.logs) + " log(s); " + (likelihood ? "innovation RMSE " : "one-step RMSE ") +
        cli::rmse_text(config, f.report.rmse);
    const ModeConfig& mode = config.modes[static_cast<std::size_t>(f.mode)];
    texts.entries +=
        fitting::format_mode_entry(output_name(f.mode), mode.model, *bank.models[static_cast<std::size_t>(f.mode)],
                                   f.report.q_intensity, {comment}, mode.params, mode.fit_when, mode.r);
  }
  std::string modes_block = "modes:\n";
  for (int j = 0; j < config.num_modes(); ++j) {
    const ModeConfig& mode = config.modes[static_cast<std::size_t>(j)];
    const FittedMode* f = nullptr;
    for (const FittedMode& candidate : fitted) {
      if (candidate.mode == j) f = &candidate;
    }
    if (f != nullptr) {
      const std::string comment =
          std::string(request.options.objective == fitting::Objective::kLikelihood ? "innovation RMSE "
                                                                                    : "one-step RMSE ") +
          cli::rmse_text(config, f->report.rmse) + " on " + std::to_string(f->logs) + " log(s)";
      modes_block += fitting::format_mode_entry(output_name(j), mode.model, *bank.models[static_cast<std::size_t>(j)],
                                                f->report.q_intensity, {comment}, mode.params, mode.fit_when, mode.r);
    } else {
      modes_block += fitting::format_mode_entry(output_name(j), mode.model, *bank.models[static_cast<std::size_t>(j)],
                                                mode.q_intensity, {"not fitted: no log given for this mode"},
                                                mode.params, mode.fit_when, mode.r);
    }
  }
  std::vector<std::pair<std::string, std::string>> blocks;
  if (request.options.shared) {
    blocks.emplace_back(
        "shared",
        "shared: " + fitting::format_parameters(*bank.models[0], sdk::ParameterScope::kBank, config.shared) + "\n");
  }
  if (request.options.fit_measurement_noise) {
    blocks.emplace_back("measurement", fitting::format_measurement_block(config));
  }
  blocks.emplace_back("modes", modes_block);
  fitting::write_bank_from_template(config.file, output, request.header, blocks);
  std::ifstream in(output, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  texts.bank_yaml = text.str();
  return texts;
}

void simulate_scenario(const fs::path& scenario_file, bool has_seed, unsigned long long seed, double duration,
                       const fs::path& output) {
  simulation::Scenario scenario = simulation::load_scenario(scenario_file);
  if (duration > 0.0) scenario.duration = duration;
  simulation::simulate(scenario, has_seed ? seed : scenario.seed, output);
}

CsvColumns read_csv_columns(const fs::path& file) {
  CsvReader reader(file);
  CsvColumns out;
  out.names = reader.header();
  const std::size_t n = out.names.size();
  std::vector<std::vector<std::string>> cells(n);
  out.numbers.assign(n, {});
  out.text.assign(n, {});
  out.is_text.assign(n, false);
  // The text columns of a `skidimm run` output stay text even when every
  // cell is empty (a run's reason column usually is), so a run read back
  // compares equal to the same run done in Python.
  for (std::size_t c = 0; c < n; ++c) {
    for (const char* text : {"mode", "decision", "truth_mode", "status", "reason"}) {
      if (out.names[c] == text) out.is_text[c] = true;
    }
  }
  std::vector<std::string> fields;
  while (reader.next(&fields)) {
    for (std::size_t c = 0; c < n; ++c) {
      const std::string& cell = fields[c];
      if (!out.is_text[c]) {
        double value = std::numeric_limits<double>::quiet_NaN();
        bool number = cell.empty() || cell == "nan" || cell == "NaN" || cell == "NA";
        if (!number) {
          const auto parsed = std::from_chars(cell.data(), cell.data() + cell.size(), value);
          number = parsed.ec == std::errc() && parsed.ptr == cell.data() + cell.size();
        }
        if (number) {
          out.numbers[c].push_back(value);
        } else {
          out.is_text[c] = true;  // from here on, every cell of the column is kept as text
        }
      }
      cells[c].push_back(cell);
    }
  }
  for (std::size_t c = 0; c < n; ++c) {
    if (out.is_text[c]) {
      out.text[c] = std::move(cells[c]);
      out.numbers[c].clear();
    }
  }
  return out;
}

}  // namespace python
}  // namespace skidimm
