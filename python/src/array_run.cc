#include "array_run.h"

#include <Eigen/Core>
#include <algorithm>

#include "skidimm/engine/decision.h"
#include "skidimm/engine/imm_smoother.h"
#include "skidimm/io/estimates_writer.h"

namespace skidimm {
namespace python {

namespace {

using ConstVectorMap = Eigen::Map<const Eigen::VectorXd>;

bool accepted(StepStatus status) { return status != StepStatus::kRejectedTime && status != StepStatus::kRejectedInput; }

// Writes row k; the decision is left for the caller. `reason` is scratch
// whose capacity is reused (describe_step).
void write_row(long k, double t, const ImmEstimate& e, const std::vector<std::string>& names, std::string* reason,
               RunColumns* out) {
  out->t[k] = t;
  for (std::size_t j = 0; j < out->mu.size(); ++j) out->mu[j][k] = e.mode_probabilities[static_cast<Eigen::Index>(j)];
  if (out->unknown != nullptr) out->unknown[k] = e.unknown_probability;
  for (std::size_t i = 0; i < out->state.size(); ++i) {
    const auto s = static_cast<Eigen::Index>(i);
    out->state[i][k] = e.state[s];
    out->var[i][k] = e.covariance(s, s);
  }
  out->mode[k] = e.unknown_is_most_likely() ? kUnknownMode : e.most_likely_mode;
  out->status[k] = static_cast<std::int8_t>(e.status);
  describe_step(e, names, reason);
  if (!reason->empty()) out->reasons.emplace_back(k, *reason);
}

// Overwrites row k with a smoothed step (the filter's status stays).
void overwrite(long k, const SmoothedStep& s, RunColumns* out) {
  for (std::size_t j = 0; j < out->mu.size(); ++j) out->mu[j][k] = s.mode_probabilities[static_cast<Eigen::Index>(j)];
  if (out->unknown != nullptr) out->unknown[k] = s.unknown_probability;
  for (std::size_t i = 0; i < out->state.size(); ++i) {
    const auto d = static_cast<Eigen::Index>(i);
    out->state[i][k] = s.state[d];
    out->var[i][k] = s.covariance(d, d);
  }
  out->mode[k] = s.unknown_is_most_likely() ? kUnknownMode : s.most_likely_mode;
}

// Decisions over the first `rows` rows, in order, from the columns' probabilities.
void decide(ModeDecision* decision, long rows, RunColumns* out) {
  Eigen::VectorXd mu(static_cast<Eigen::Index>(out->mu.size()));
  for (long k = 0; k < rows; ++k) {
    for (std::size_t j = 0; j < out->mu.size(); ++j) mu[static_cast<Eigen::Index>(j)] = out->mu[j][k];
    out->decision[k] = decision->update(out->t[k], mu);
  }
}

}  // namespace

std::vector<std::string> mode_names(const BankConfig& config) {
  std::vector<std::string> names;
  for (const ModeConfig& m : config.modes) names.push_back(m.name);
  return names;
}

GrowingRunColumns::GrowingRunColumns(const BankConfig& config)
    : mu(static_cast<std::size_t>(config.num_modes())),
      unknown(config.unknown.enabled() ? 1 : 0),
      state(static_cast<std::size_t>(config.state_dim())),
      var(static_cast<std::size_t>(config.state_dim())) {
  point();
}

void GrowingRunColumns::reserve(long rows) {
  const auto n = static_cast<std::size_t>(rows);
  if (n > t.size()) resize(std::max({n, 2 * t.size(), std::size_t{1024}}));
}

void GrowingRunColumns::shrink(long rows) { resize(static_cast<std::size_t>(rows)); }

void GrowingRunColumns::resize(std::size_t rows) {
  t.resize(rows);
  for (auto& c : mu) c.resize(rows);
  for (auto& c : unknown) c.resize(rows);
  for (auto& c : state) c.resize(rows);
  for (auto& c : var) c.resize(rows);
  mode.resize(rows);
  decision.resize(rows);
  status.resize(rows);
  point();
}

void GrowingRunColumns::point() {
  columns_.t = t.data();
  columns_.mu.clear();
  for (auto& c : mu) columns_.mu.push_back(c.data());
  columns_.unknown = unknown.empty() ? nullptr : unknown[0].data();
  columns_.state.clear();
  for (auto& c : state) columns_.state.push_back(c.data());
  columns_.var.clear();
  for (auto& c : var) columns_.var.push_back(c.data());
  columns_.mode = mode.data();
  columns_.decision = decision.data();
  columns_.status = status.data();
}

void run_arrays(Imm* imm, const ArrayLog& log, const EstimatorOptions& estimator, ModeDecision* decision,
                RunColumns* out) {
  const BankConfig& config = imm->config();
  const int m_u = config.input_dim();
  const auto m_z = static_cast<int>(config.measurement.h.rows());
  const std::vector<std::string> names = mode_names(config);
  std::string reason;
  auto u_of = [&](long k) { return ConstVectorMap(log.u + k * m_u, m_u); };
  auto z_of = [&](long k) { return ConstVectorMap(log.z + k * m_z, m_z); };

  if (estimator.kind == EstimatorOptions::Kind::kFilter) {
    for (long k = 0; k < log.rows; ++k) {
      const ImmEstimate& e = imm->step(log.t[k], u_of(k), z_of(k));
      write_row(k, log.t[k], e, names, &reason, out);
      out->decision[k] = decision->update(log.t[k], e.mode_probabilities, e.measured());
    }
    return;
  }

  // The smoothers (as log_run.cc's run_log): every row is written with the
  // filter's estimate as it steps, then the accepted rows, in order, are
  // overwritten by their smoothed estimates; the decisions follow.
  imm->reset();
  decision->reset();
  std::vector<long> accepted_rows;
  std::vector<SmoothedStep> ready;
  std::size_t released = 0;
  auto release = [&](const std::vector<SmoothedStep>& smoothed) {
    for (const SmoothedStep& s : smoothed) overwrite(accepted_rows[released++], s, out);
  };
  if (estimator.kind == EstimatorOptions::Kind::kFixedInterval) {
    std::vector<ForwardStep> forward;
    for (long k = 0; k < log.rows; ++k) {
      const ImmEstimate& e = imm->step(log.t[k], u_of(k), z_of(k));
      write_row(k, log.t[k], e, names, &reason, out);
      if (!accepted(e.status)) continue;
      accepted_rows.push_back(k);
      forward.push_back(record_step(log.t[k], u_of(k), e));
    }
    ImmSmoother(imm->bank()).smooth(forward, &ready);
    release(ready);
  } else {
    FixedLagSmoother smoother(imm->bank(), estimator.lag);
    for (long k = 0; k < log.rows; ++k) {
      const ImmEstimate& e = imm->step(log.t[k], u_of(k), z_of(k));
      write_row(k, log.t[k], e, names, &reason, out);
      if (!accepted(e.status)) continue;
      accepted_rows.push_back(k);
      ready.clear();
      smoother.add(record_step(log.t[k], u_of(k), e), &ready);
      release(ready);
    }
    ready.clear();
    smoother.finish(&ready);
    release(ready);
  }
  decide(decision, log.rows, out);
}

double step_loop(Imm* imm, const ArrayLog& log) {
  const int m_u = imm->config().input_dim();
  const auto m_z = static_cast<int>(imm->config().measurement.h.rows());
  double sum = 0.0;
  for (long k = 0; k < log.rows; ++k) {
    sum += imm->step(log.t[k], ConstVectorMap(log.u + k * m_u, m_u), ConstVectorMap(log.z + k * m_z, m_z))
               .mode_probabilities[0];
  }
  return sum;
}

long run_log_file(const Bank& bank, LogReader* reader, const EstimatorOptions& estimator,
                  const DecisionConfig& settings, const std::string& label, bool with_truth, GrowingRunColumns* out,
                  std::vector<std::string>* truth) {
  const BankConfig& config = bank.config;
  const std::vector<std::string> names = mode_names(config);
  std::string reason;
  ModeDecision decision(config, settings);
  long rows = 0;
  try {
    run_log(bank, reader, estimator, [&](const LogSample& sample, const ImmEstimate& e) {
      out->reserve(rows + 1);
      write_row(rows, sample.t, e, names, &reason, &out->columns());
      // A smoothed step carries the measurements after it: it does not go stale.
      const bool current = estimator.kind != EstimatorOptions::Kind::kFilter || e.measured();
      out->columns().decision[rows] = decision.update(sample.t, e.mode_probabilities, current);
      if (with_truth) truth->push_back(label.empty() ? sample.truth_mode : label);
      ++rows;
    });
  } catch (...) {
    out->shrink(rows);  // the whole rows before the error, for the caller to keep
    throw;
  }
  out->shrink(rows);
  return rows;
}

}  // namespace python
}  // namespace skidimm
