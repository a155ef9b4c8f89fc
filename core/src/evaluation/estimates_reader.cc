// skidimm eval --estimates: a `skidimm run` output read back and scored.
#include "skidimm/evaluation/estimates_reader.h"

#include <charconv>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "skidimm/errors.h"
#include "skidimm/evaluation/mode_metrics.h"
#include "skidimm/log_io.h"

namespace skidimm {
namespace evaluation {

namespace fs = std::filesystem;

namespace {

double parse_cell(const CsvReader& reader, const std::vector<std::string>& fields, int column) {
  const std::string& cell = fields[static_cast<std::size_t>(column)];
  double value = 0.0;
  const char* begin = cell.data();
  const auto parsed = std::from_chars(begin, cell.data() + cell.size(), value);
  if (cell.empty() || parsed.ec != std::errc() || parsed.ptr != cell.data() + cell.size() || !std::isfinite(value)) {
    throw LogError(reader.path().string(), reader.line(),
                   "column '" + reader.header()[static_cast<std::size_t>(column)] + "': expected a finite number, got '" +
                       cell + "'");
  }
  return value;
}

}  // namespace

LogResult evaluate_estimates(const fs::path& file, const BankConfig* bank) {
  CsvReader reader(file);
  const int t = reader.column("t"), truth = reader.column("truth_mode");
  if (t < 0 || truth < 0) {
    throw LogError(file.string(), 1, "expected the columns t and truth_mode of a `skidimm run` output");
  }
  std::vector<int> probability_columns;
  BankConfig modes_only;
  for (std::size_t c = 0; c < reader.header().size(); ++c) {
    if (reader.header()[c].rfind("mu_", 0) == 0) {
      probability_columns.push_back(static_cast<int>(c));
      ModeConfig m;
      m.name = reader.header()[c].substr(3);
      modes_only.modes.push_back(m);
    }
  }
  if (probability_columns.empty()) throw LogError(file.string(), 1, "no mu_<mode> columns: not a `skidimm run` output");
  if (bank != nullptr) {
    for (std::size_t j = 0; j < modes_only.modes.size(); ++j) {
      if (static_cast<int>(j) >= bank->num_modes() || bank->modes[j].name != modes_only.modes[j].name) {
        throw LogError(file.string(), 1, "its modes differ from bank '" + bank->name + "': it was run with another bank");
      }
    }
  }
  const evaluation::ClassScorer scorer(bank != nullptr ? *bank : modes_only);
  const int decision = reader.column("decision");
  std::vector<LabelledStep> steps, decisions;
  std::vector<std::string> f;
  Eigen::VectorXd mu(static_cast<Eigen::Index>(probability_columns.size()));
  double last_t = -std::numeric_limits<double>::infinity();
  while (reader.next(&f)) {
    const double time = parse_cell(reader, f, t);
    if (!(time > last_t)) {
      throw LogError(file.string(), reader.line(), "column 't': time must increase strictly");
    }
    last_t = time;
    for (std::size_t j = 0; j < probability_columns.size(); ++j) {
      mu[static_cast<Eigen::Index>(j)] = parse_cell(reader, f, probability_columns[j]);
      if (mu[static_cast<Eigen::Index>(j)] < 0.0 || mu[static_cast<Eigen::Index>(j)] > 1.0 + 1e-9) {
        throw LogError(file.string(), reader.line(),
                       "column '" + reader.header()[static_cast<std::size_t>(probability_columns[j])] +
                           "': a probability must be in [0, 1]");
      }
    }
    steps.push_back(scorer.score(time, f[static_cast<std::size_t>(truth)], mu));
    if (decision >= 0) {
      decisions.push_back(steps.back());
      decisions.back().estimate = f[static_cast<std::size_t>(decision)];
    }
  }
  if (steps.empty()) throw LogError(file.string(), 1, "the file has a header but no rows");
  LogResult result;
  result.name = file.filename().string();
  result.metrics = evaluation::compute_mode_metrics(steps, scorer.class_names());
  if (!decisions.empty()) result.decision_metrics = evaluation::compute_mode_metrics(decisions, scorer.class_names());
  return result;
}

}  // namespace evaluation
}  // namespace skidimm
