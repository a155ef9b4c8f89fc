#include "array_run.h"

#include <Eigen/Core>

#include "skidimm/decision.h"
#include "skidimm/estimates_writer.h"
#include "skidimm/imm_smoother.h"

namespace skidimm {
namespace python {

namespace {

using ConstVectorMap = Eigen::Map<const Eigen::VectorXd>;

bool accepted(StepStatus status) { return status != StepStatus::kRejectedTime && status != StepStatus::kRejectedInput; }

// Appends one row; the decision is left for the caller.
void append(double t, const ImmEstimate& e, RunColumns* out) {
  out->t.push_back(t);
  for (std::size_t j = 0; j < out->mu.size(); ++j)
    out->mu[j].push_back(e.mode_probabilities[static_cast<Eigen::Index>(j)]);
  for (std::size_t i = 0; i < out->state.size(); ++i) {
    const auto s = static_cast<Eigen::Index>(i);
    out->state[i].push_back(e.state[s]);
    out->var[i].push_back(e.covariance(s, s));
  }
  out->mode.push_back(e.most_likely_mode);
  out->status.push_back(static_cast<std::int8_t>(e.status));
  out->reason.emplace_back();
  describe_step(e, out->mode_names, &out->reason.back());
}

// Overwrites row k with a smoothed step (the filter's status stays).
void overwrite(long k, const SmoothedStep& s, RunColumns* out) {
  const auto row = static_cast<std::size_t>(k);
  for (std::size_t j = 0; j < out->mu.size(); ++j) out->mu[j][row] = s.mode_probabilities[static_cast<Eigen::Index>(j)];
  for (std::size_t i = 0; i < out->state.size(); ++i) {
    const auto d = static_cast<Eigen::Index>(i);
    out->state[i][row] = s.state[d];
    out->var[i][row] = s.covariance(d, d);
  }
  out->mode[row] = s.most_likely_mode;
}

// Decisions over the rows from `first` on, in order, from the columns' probabilities.
void decide(ModeDecision* decision, long first, RunColumns* out) {
  Eigen::VectorXd mu(static_cast<Eigen::Index>(out->mu.size()));
  out->decision.resize(out->t.size());
  for (long k = first; k < out->rows(); ++k) {
    const auto row = static_cast<std::size_t>(k);
    for (std::size_t j = 0; j < out->mu.size(); ++j) mu[static_cast<Eigen::Index>(j)] = out->mu[j][row];
    out->decision[row] = decision->update(out->t[row], mu);
  }
}

}  // namespace

void RunColumns::reserve(const BankConfig& config, std::size_t rows) {
  mu.assign(static_cast<std::size_t>(config.num_modes()), {});
  state.assign(static_cast<std::size_t>(config.state_dim()), {});
  var.assign(static_cast<std::size_t>(config.state_dim()), {});
  t.reserve(rows);
  for (auto& c : mu) c.reserve(rows);
  for (auto& c : state) c.reserve(rows);
  for (auto& c : var) c.reserve(rows);
  mode.reserve(rows);
  decision.reserve(rows);
  status.reserve(rows);
  reason.reserve(rows);
  mode_names.clear();
  for (const ModeConfig& m : config.modes) mode_names.push_back(m.name);
}

void run_arrays(Imm* imm, const ArrayLog& log, const EstimatorOptions& estimator, ModeDecision* decision,
                RunColumns* out) {
  const BankConfig& config = imm->config();
  const int m_u = config.input_dim();
  const auto m_z = static_cast<int>(config.measurement.h.rows());
  out->reserve(config, static_cast<std::size_t>(log.rows));
  auto u_of = [&](long k) { return ConstVectorMap(log.u + k * m_u, m_u); };
  auto z_of = [&](long k) { return ConstVectorMap(log.z + k * m_z, m_z); };

  if (estimator.kind == EstimatorOptions::Kind::kFilter) {
    for (long k = 0; k < log.rows; ++k) {
      const ImmEstimate& e = imm->step(log.t[k], u_of(k), z_of(k));
      append(log.t[k], e, out);
      out->decision.push_back(decision->update(log.t[k], e.mode_probabilities));
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
      append(log.t[k], e, out);
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
      append(log.t[k], e, out);
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
  decide(decision, 0, out);
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

void run_log_file(const Bank& bank, LogReader* reader, const EstimatorOptions& estimator,
                  const DecisionConfig& settings, const std::string& label, bool with_truth, RunColumns* out) {
  const BankConfig& config = bank.config;
  out->reserve(config, 0);
  out->with_truth = with_truth;
  ModeDecision decision(config, settings);
  run_log(bank, reader, estimator, [&](const LogSample& sample, const ImmEstimate& e) {
    append(sample.t, e, out);
    out->decision.push_back(decision.update(sample.t, e.mode_probabilities));
    if (with_truth) out->truth.push_back(label.empty() ? sample.truth_mode : label);
  });
}

}  // namespace python
}  // namespace skidimm
