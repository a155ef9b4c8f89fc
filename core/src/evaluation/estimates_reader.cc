// skidimm eval --estimates: a `skidimm run` output read back and scored.
#include "estimates_reader.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "skidimm/engine/decision.h"
#include "skidimm/errors.h"
#include "skidimm/evaluation/mode_metrics.h"
#include "skidimm/io/csv.h"
#include "skidimm/printable.h"

namespace skidimm {
namespace evaluation {

namespace fs = std::filesystem;

namespace {

double parse_cell(const CsvReader& reader, const std::vector<std::string>& fields, int column, const char* expected) {
  const std::string& cell = fields[static_cast<std::size_t>(column)];
  double value = 0.0;
  if (!parse_finite_number(cell, &value)) {  // csv.h: the log reader's rule, subnormals included
    throw LogError(reader.path().string(), reader.line(),
                   "column " + std::to_string(column + 1) + " ('" +
                       reader.header()[static_cast<std::size_t>(column)] + "'): expected " + expected + ", got '" +
                       cell.substr(0, 80) + (cell.size() > 80 ? "...'" : "'"));
  }
  return value;
}

// How far a run's probabilities may stray from [0, 1] and from summing to 1:
// they are written with every digit, so the sum is 1 to a few ulps; anything
// beyond this did not come from `skidimm run`.
constexpr double kProbabilityTolerance = 1e-6;

// A decision cell names a class the probabilities are summed into, or is
// "unknown". Anything else was written with other classes: files of a bank
// with classes (ICE: [ICE_turning, ICE_straight]) read without that bank,
// whose every decision would be scored wrong, and at probability 0.
void check_decision(const CsvReader& reader, int column, const std::string& cell,
                    const std::vector<std::string>& classes, bool with_bank) {
  if (cell == "unknown" || std::find(classes.begin(), classes.end(), cell) != classes.end()) return;
  std::string names;
  for (std::size_t c = 0; c < classes.size() && c < 8; ++c)
    names += (c == 0 ? "'" : ", '") + printable(classes[c]) + "'";
  if (classes.size() > 8) names += " and " + std::to_string(classes.size() - 8) + " more";
  throw LogError(reader.path().string(), reader.line(),
                 "column " + std::to_string(column + 1) + " ('decision'): '" + printable(cell.substr(0, 80)) +
                     "' is neither 'unknown' nor a class of " + (with_bank ? "the bank" : "the file") + " (" + names +
                     ")" +
                     (with_bank ? ""
                                : "; without --bank each mu_ column is a class of its own: give the bank the file "
                                  "was run with (--bank) when its modes form classes"));
}

}  // namespace

namespace {

std::string mode_list(const BankConfig& modes) {
  std::string out;
  for (const ModeConfig& m : modes.modes) out += (out.empty() ? "" : ", ") + m.name;
  return out;
}

}  // namespace

LogResult evaluate_estimates(const fs::path& file, const BankConfig* bank, const DecisionConfig* decide) {
  return evaluate_estimates(file, bank,
                            decide != nullptr ? std::vector<DecisionConfig>{*decide} : std::vector<DecisionConfig>{})
      .front();
}

std::vector<LogResult> evaluate_estimates(const fs::path& file, const BankConfig* bank,
                                          const std::vector<DecisionConfig>& decisions, const std::string& label) {
  CsvReader reader(file);
  const int t = reader.column("t"), truth = reader.column("truth_mode");
  if (t < 0 || (truth < 0 && label.empty())) {
    throw LogError(file.string(), 1,
                   t < 0 ? "expected the columns t and truth_mode of a `skidimm run` output"
                         : "no truth_mode column to score against: the log was run without a truth; label the "
                           "estimates with the mode or class they show (LABEL=" +
                               file.string() + ")");
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
    std::vector<std::string> names;
    for (const ModeConfig& m : modes_only.modes) names.push_back(m.name);
    const std::string problem = bank->estimates_modes_problem(names);
    if (!problem.empty()) throw LogError(file.string(), 1, problem);
  }
  if (!label.empty()) {
    const BankConfig& known = bank != nullptr ? *bank : modes_only;
    if (known.mode_index(label) < 0 && known.class_index(label) < 0) {
      throw LogError(file.string(), 0,
                     bank != nullptr ? bank->unknown_label(label)
                                     : "'" + label + "' is not a mode of these estimates; their modes (mu_ columns): " +
                                           mode_list(modes_only) + "; give --bank for its classes");
    }
  }
  // The probability of the bank's unknown hypothesis, when it has one.
  const int unknown = reader.column("unknown_probability");
  const BankConfig& classes = bank != nullptr ? *bank : modes_only;
  const ClassScorer scorer(classes);
  const int decision = decisions.empty() ? reader.column("decision") : -1;
  // A decision made again goes stale as the run's did (decision.h): a step
  // is measured unless its status says no measurement corrected the filter.
  const int status = decisions.empty() ? -1 : reader.column("status");
  std::vector<char> measured;
  std::vector<LabelledStep> steps, from_column;
  // With decision settings, each step's probabilities (its time is in
  // `steps`), kept to make the decision again with each setting in turn:
  // memory for one setting's decisions at a time, however many are compared.
  std::vector<double> probabilities;
  std::vector<std::string> f;
  Eigen::VectorXd mu(static_cast<Eigen::Index>(probability_columns.size()));
  double last_t = -std::numeric_limits<double>::infinity();
  while (reader.next(&f)) {
    const double time = parse_cell(reader, f, t, "a finite time in seconds");
    if (!(time > last_t)) {
      throw LogError(reader.path().string(), reader.line(),
                     "column " + std::to_string(t + 1) + " ('t'): time must increase strictly, but " +
                         CsvWriter::format(time) + " follows " + CsvWriter::format(last_t));
    }
    last_t = time;
    double sum = 0.0;
    for (std::size_t j = 0; j < probability_columns.size(); ++j) {
      const int column = probability_columns[j];
      const double p = parse_cell(reader, f, column, "a probability in [0, 1]");
      if (p < -kProbabilityTolerance || p > 1.0 + kProbabilityTolerance) {
        throw LogError(reader.path().string(), reader.line(),
                       "column " + std::to_string(column + 1) + " ('" +
                           reader.header()[static_cast<std::size_t>(column)] + "'): expected a probability in [0, 1], got " +
                           f[static_cast<std::size_t>(column)]);
      }
      mu[static_cast<Eigen::Index>(j)] = p;
      sum += p;
    }
    double unknown_probability = 0.0;
    if (unknown >= 0) {
      unknown_probability = parse_cell(reader, f, unknown, "a probability in [0, 1]");
      if (unknown_probability < -kProbabilityTolerance || unknown_probability > 1.0 + kProbabilityTolerance) {
        throw LogError(reader.path().string(), reader.line(),
                       "column " + std::to_string(unknown + 1) +
                           " ('unknown_probability'): expected a probability in [0, 1], got " +
                           f[static_cast<std::size_t>(unknown)]);
      }
      sum += unknown_probability;
    }
    if (std::abs(sum - 1.0) > kProbabilityTolerance) {
      throw LogError(reader.path().string(), reader.line(),
                     "the mode probabilities (mu_ columns" + std::string(unknown >= 0 ? " and unknown_probability" : "") +
                         ") sum to " + CsvWriter::format(sum) + "; in a `skidimm run` output they sum to 1");
    }
    steps.push_back(
        scorer.score(time, label.empty() ? f[static_cast<std::size_t>(truth)] : label, mu, unknown_probability));
    if (!decisions.empty()) {
      probabilities.insert(probabilities.end(), mu.data(), mu.data() + mu.size());
      const auto unmeasured = [&](const std::string& cell) {
        return cell == "predict_only" || cell == "rejected_time" || cell == "rejected_input";
      };
      measured.push_back(status < 0 || !unmeasured(f[static_cast<std::size_t>(status)]));
    } else if (decision >= 0) {
      const std::string& cell = f[static_cast<std::size_t>(decision)];
      check_decision(reader, decision, cell, scorer.class_names(), bank != nullptr);
      from_column.push_back(scorer.decided(steps.back(), cell));
    }
  }
  if (steps.empty()) {
    throw LogError(reader.path().string(), 1, "the file has a header but no rows: no step to evaluate");
  }
  LogResult result;
  result.name = file.filename().string();
  result.source = file.string();
  result.classes = scorer.class_names();
  result.metrics = compute_mode_metrics(steps, scorer.class_names());
  if (decisions.empty()) {
    if (!from_column.empty()) result.decision_metrics = compute_mode_metrics(from_column, scorer.class_names());
    return {result};
  }
  std::vector<LogResult> results(decisions.size(), result);
  const Eigen::Index modes = mu.size();
  std::vector<LabelledStep> decided;
  decided.reserve(steps.size());
  for (std::size_t k = 0; k < decisions.size(); ++k) {
    ModeDecision decider(classes, decisions[k]);
    decided.clear();
    for (std::size_t i = 0; i < steps.size(); ++i) {
      const Eigen::Map<const Eigen::VectorXd> row(probabilities.data() + i * static_cast<std::size_t>(modes), modes);
      decided.push_back(scorer.decided(steps[i], decider.name(decider.update(steps[i].t, row, measured[i] != 0))));
    }
    results[k].decision_metrics = compute_mode_metrics(decided, scorer.class_names());
  }
  return results;
}

}  // namespace evaluation
}  // namespace skidimm
