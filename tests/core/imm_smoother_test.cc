#include "skidimm/engine/imm_smoother.h"

#include <gtest/gtest.h>

#include <cmath>
#include <deque>
#include <filesystem>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "core/test_banks.h"
#include "skidimm/engine/imm.h"
#include "skidimm/io/log_reader.h"

namespace skidimm {
namespace {

using skidimm_test::BankBuilder;
using skidimm_test::ScalarLinearModel;

constexpr double kDt = 0.1;
constexpr double kPi = 3.14159265358979323846;

double gaussian(double x, double mean, double variance) {
  return std::exp(-0.5 * (x - mean) * (x - mean) / variance) / std::sqrt(2.0 * kPi * variance);
}

struct ForwardRun {
  std::vector<double> t, z;
  std::vector<ForwardStep> forward;
};

ForwardRun run_forward(Imm& imm, const std::vector<double>& z, double u = 1.0) {
  ForwardRun run;
  for (std::size_t k = 0; k < z.size(); ++k) {
    const double t = kDt * static_cast<double>(k);
    const Eigen::VectorXd input = Eigen::VectorXd::Constant(1, u);
    const ImmEstimate& e = imm.step(t, input, Eigen::VectorXd::Constant(1, z[k]));
    run.t.push_back(t);
    run.z.push_back(z[k]);
    run.forward.push_back(record_step(t, input, e));
  }
  return run;
}

// Three modes whose prediction does not depend on the state (F = 0): x_next
// = level_j whatever x (a = -1/dt, b = level/dt), with per-step variance
// q_j dt, measured directly.
struct MemorylessBank {
  std::vector<double> level{0.0, 1.0, 2.5};
  std::vector<double> q{0.5, 0.2, 1.0};
  double r = 0.09;
  Eigen::Matrix3d p = (Eigen::Matrix3d() << 0.9, 0.06, 0.04, 0.1, 0.85, 0.05, 0.02, 0.08, 0.9).finished();
  Eigen::Vector3d mu0{0.5, 0.3, 0.2};

  Bank build() const {
    BankBuilder b;
    for (std::size_t j = 0; j < 3; ++j) {
      b.models.push_back(std::make_shared<ScalarLinearModel>(-1.0 / kDt, level[j] / kDt));
      b.q.push_back(Eigen::MatrixXd::Constant(1, 1, q[j]));
    }
    b.r = Eigen::MatrixXd::Constant(1, 1, r);
    b.transition = p;
    b.mu0 = mu0;
    b.floor = 0.0;
    return b.build();
  }
  // Mode j's density of measuring z, its variance times `inflation`.
  double emission(double z, int j, double inflation = 1.0) const {
    const auto i = static_cast<std::size_t>(j);
    return gaussian(z, level[i], inflation * (q[i] * kDt + r));
  }
};

// Modes whose prediction does not depend on the state (F = 0): the IMM is then
// exactly a hidden Markov model with Gaussian emissions, and the smoothed mode
// probabilities must equal the forward-backward algorithm's.
TEST(ImmSmoother, IsTheExactForwardBackwardWhenModesHaveNoMemory) {
  const MemorylessBank b;
  const Eigen::Matrix3d& p = b.p;
  const Bank bank = b.build();
  Imm imm(bank);
  const std::vector<double> z{0.3, 0.1, 1.2, 0.9, 2.8, 2.2, 0.4, 1.1, 2.6, 0.0, -0.2, 1.0};
  const ForwardRun run = run_forward(imm, z);
  std::vector<SmoothedStep> smoothed;
  ImmSmoother(bank).smooth(run.forward, &smoothed);

  // Forward-backward, independently. Step 0 is the prior's update, the same for every mode.
  const std::size_t n = z.size();
  std::vector<Eigen::Vector3d> alpha(n), beta(n), emission(n);
  for (std::size_t k = 0; k < n; ++k) {
    for (int j = 0; j < 3; ++j) {
      emission[k][j] = k == 0 ? 1.0 : b.emission(z[k], j);
    }
  }
  alpha[0] = b.mu0;
  for (std::size_t k = 1; k < n; ++k) {
    alpha[k] = (p.transpose() * alpha[k - 1]).cwiseProduct(emission[k]);
    alpha[k] /= alpha[k].sum();
  }
  beta[n - 1].setOnes();
  for (std::size_t k = n - 1; k-- > 0;) {
    beta[k] = p * emission[k + 1].cwiseProduct(beta[k + 1]);
    beta[k] /= beta[k].sum();
  }
  for (std::size_t k = 0; k < n; ++k) {
    Eigen::Vector3d exact = alpha[k].cwiseProduct(beta[k]);
    exact /= exact.sum();
    EXPECT_LT((run.forward[k].mode_probabilities - alpha[k]).cwiseAbs().maxCoeff(), 1e-10) << "filter, step " << k;
    EXPECT_LT((smoothed[k].mode_probabilities - exact).cwiseAbs().maxCoeff(), 1e-10) << "smoother, step " << k;
  }
}

// The same hidden Markov model with an unknown hypothesis U beside the modes
// (inflation s, enter e, leave l): a chain on four hypotheses, from mode j to
// mode i (1 - e) p(j, i), to U e; from U to each mode l / 3, to U 1 - l. U's
// emission is the best mode's density at s times its variance. With modes
// that have no memory the smoothed probabilities over the four must be the
// forward-backward algorithm's, and the combined state must weigh the modes
// by their probabilities given that some mode holds.
TEST(ImmSmoother, IsTheExactForwardBackwardWithAnUnknownHypothesis) {
  const MemorylessBank b;
  const Eigen::Matrix3d& p = b.p;
  Bank bank = b.build();
  const double s = 50.0, enter = 0.05, leave = 0.3;
  bank.config.unknown.inflation = s;
  bank.config.unknown.enter = enter;
  bank.config.unknown.leave = leave;
  Imm imm(bank);
  // Two far misses (9 and -6) that none of the levels explains.
  const std::vector<double> z{0.3, 0.1, 1.2, 9.0, 2.8, 2.2, -6.0, 1.1, 2.6, 0.0};
  const ForwardRun run = run_forward(imm, z);
  std::vector<SmoothedStep> smoothed;
  ImmSmoother(bank).smooth(run.forward, &smoothed);

  Eigen::Matrix4d chain = Eigen::Matrix4d::Zero();
  chain.topLeftCorner(3, 3) = (1.0 - enter) * p;
  chain.topRightCorner(3, 1).setConstant(enter);
  chain.bottomLeftCorner(1, 3).setConstant(leave / 3.0);
  chain(3, 3) = 1.0 - leave;
  const std::size_t n = z.size();
  std::vector<Eigen::Vector4d> alpha(n), beta(n), emission(n);
  for (std::size_t k = 0; k < n; ++k) {
    double broad = 0.0;
    for (int j = 0; j < 3; ++j) {
      emission[k][j] = k == 0 ? 1.0 : b.emission(z[k], j);
      broad = std::max(broad, b.emission(z[k], j, s));
    }
    emission[k][3] = k == 0 ? 1.0 : broad;
  }
  alpha[0] << b.mu0, 0.0;  // the first step has no transition, and U starts at 0
  for (std::size_t k = 1; k < n; ++k) {
    alpha[k] = (chain.transpose() * alpha[k - 1]).cwiseProduct(emission[k]);
    alpha[k] /= alpha[k].sum();
  }
  beta[n - 1].setOnes();
  for (std::size_t k = n - 1; k-- > 0;) {
    beta[k] = chain * emission[k + 1].cwiseProduct(beta[k + 1]);
    beta[k] /= beta[k].sum();
  }
  for (std::size_t k = 0; k < n; ++k) {
    Eigen::Vector4d exact = alpha[k].cwiseProduct(beta[k]);
    exact /= exact.sum();
    Eigen::Vector4d filtered, smoothed_k;
    filtered << run.forward[k].mode_probabilities, run.forward[k].unknown_probability;
    smoothed_k << smoothed[k].mode_probabilities, smoothed[k].unknown_probability;
    EXPECT_LT((filtered - alpha[k]).cwiseAbs().maxCoeff(), 1e-10) << "filter, step " << k;
    EXPECT_LT((smoothed_k - exact).cwiseAbs().maxCoeff(), 1e-10) << "smoother, step " << k;
    const Eigen::VectorXd given_a_mode = smoothed[k].mode_probabilities / smoothed[k].mode_probabilities.sum();
    double state = 0.0;
    for (int j = 0; j < 3; ++j) state += given_a_mode[j] * smoothed[k].mode_states[static_cast<std::size_t>(j)][0];
    EXPECT_NEAR(smoothed[k].state[0], state, 1e-12) << "step " << k;
  }
  EXPECT_GT(smoothed[3].unknown_probability, 0.5) << "the far miss is U's";
  EXPECT_GT(smoothed[2].unknown_probability, run.forward[2].unknown_probability)
      << "the step before a far miss is more likely U's once the miss is known";
}

// Two linear modes with memory (switching dynamics): the exact posterior,
// by enumerating all 2^K mode sequences with a Kalman filter and RTS smoother
// for each, against the smoother's approximation.
TEST(ImmSmoother, ApproachesTheExactPosteriorOfASwitchingLinearSystem) {
  const double a[2] = {-2.0, -0.2}, bu[2] = {1.0, 3.0}, q[2] = {0.05, 0.3}, r = 0.04;
  BankBuilder b;
  for (int j = 0; j < 2; ++j) {
    b.models.push_back(std::make_shared<ScalarLinearModel>(a[j], bu[j]));
    b.q.push_back(Eigen::MatrixXd::Constant(1, 1, q[j]));
  }
  b.r = Eigen::MatrixXd::Constant(1, 1, r);
  Eigen::Matrix2d p;
  p << 0.8, 0.2, 0.3, 0.7;
  b.transition = p;
  b.floor = 0.0;
  b.p0 = Eigen::MatrixXd::Constant(1, 1, 0.5);
  const Bank bank = b.build();

  // A log from mode sequence 0 0 0 1 1 1 1 0 0 0 (K = 10).
  const std::vector<int> truth{0, 0, 0, 1, 1, 1, 1, 0, 0, 0};
  std::mt19937 rng(7);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<double> z;
  double x = 0.0;
  for (std::size_t k = 0; k < truth.size(); ++k) {
    if (k > 0) x += kDt * (a[truth[k]] * x + bu[truth[k]]) + std::sqrt(q[truth[k]] * kDt) * normal(rng);
    z.push_back(x + std::sqrt(r) * normal(rng));
  }
  Imm imm(bank);
  const ForwardRun run = run_forward(imm, z);
  std::vector<SmoothedStep> smoothed;
  ImmSmoother(bank).smooth(run.forward, &smoothed);

  // Exact: sum over sequences of p(sequence) p(z | sequence), and the RTS means.
  const std::size_t n = z.size();
  std::vector<Eigen::Vector2d> exact_mode(n, Eigen::Vector2d::Zero());
  std::vector<double> exact_state(n, 0.0);
  double evidence = 0.0;
  for (int code = 0; code < (1 << n); ++code) {
    std::vector<int> m(n);
    for (std::size_t k = 0; k < n; ++k) m[k] = (code >> k) & 1;
    double prior = 0.5;
    for (std::size_t k = 1; k < n; ++k) prior *= p(m[k - 1], m[k]);
    // Kalman filter for this sequence; the first step is the prior's update.
    std::vector<double> xf(n), pf(n), xp(n), pp(n);
    double likelihood = 1.0, xs = 0.0, ps = 0.5;
    for (std::size_t k = 0; k < n; ++k) {
      if (k > 0) {
        const double f = 1.0 + a[m[k]] * kDt;
        xs = xs + kDt * (a[m[k]] * xs + bu[m[k]]);
        ps = f * ps * f + q[m[k]] * kDt;
      }
      xp[k] = xs;
      pp[k] = ps;
      likelihood *= gaussian(z[k], xs, ps + r);
      const double gain = ps / (ps + r);
      xs += gain * (z[k] - xs);
      ps *= 1.0 - gain;
      xf[k] = xs;
      pf[k] = ps;
    }
    std::vector<double> xsm(n);
    xsm[n - 1] = xf[n - 1];
    for (std::size_t k = n - 1; k-- > 0;) {
      const double f = 1.0 + a[m[k + 1]] * kDt;
      xsm[k] = xf[k] + pf[k] * f / pp[k + 1] * (xsm[k + 1] - xp[k + 1]);
    }
    const double weight = prior * likelihood;
    evidence += weight;
    for (std::size_t k = 0; k < n; ++k) {
      exact_mode[k][m[k]] += weight;
      exact_state[k] += weight * xsm[k];
    }
  }
  double filter_error = 0.0, smoother_error = 0.0, filter_state_error = 0.0, smoother_state_error = 0.0;
  for (std::size_t k = 1; k < n; ++k) {  // step 0 carries no mode information
    exact_mode[k] /= evidence;
    exact_state[k] /= evidence;
    filter_error += std::abs(run.forward[k].mode_probabilities[1] - exact_mode[k][1]);
    smoother_error += std::abs(smoothed[k].mode_probabilities[1] - exact_mode[k][1]);
    const double filtered_state = run.forward[k].mode_probabilities.dot(
        Eigen::Vector2d(run.forward[k].mode_states[0][0], run.forward[k].mode_states[1][0]));
    filter_state_error += std::abs(filtered_state - exact_state[k]);
    smoother_state_error += std::abs(smoothed[k].state[0] - exact_state[k]);
    // Kim's approximation drops what later measurements say about m_k through
    // x_k: close to the exact posterior, not equal (here within 0.25 per step).
    EXPECT_NEAR(smoothed[k].mode_probabilities[1], exact_mode[k][1], 0.25)
        << "step " << k << ": filter " << run.forward[k].mode_probabilities[1] << ", smoother "
        << smoothed[k].mode_probabilities[1] << ", exact " << exact_mode[k][1];
  }
  // Summed over the steps (this log: filter 1.48, smoother 0.62; states 0.49, 0.15).
  EXPECT_LT(smoother_error, 0.5 * filter_error) << "smoothing closes most of the gap to the exact posterior";
  EXPECT_LT(smoother_state_error, 0.5 * filter_state_error);
}

TEST(ImmSmoother, FixedLagSpansFilterToFixedInterval) {
  BankBuilder b;
  for (double gain : {1.0, 2.0}) {
    b.models.push_back(std::make_shared<ScalarLinearModel>(-1.0, gain));
  }
  b.q = {Eigen::MatrixXd::Constant(1, 1, 0.05)};
  b.r = Eigen::MatrixXd::Constant(1, 1, 0.01);
  const Bank bank = b.build();
  std::vector<double> z;
  for (int k = 0; k < 40; ++k) z.push_back(k < 20 ? 0.1 * k : 2.0 + 0.05 * (k - 20));
  Imm imm(bank);
  const ForwardRun run = run_forward(imm, z);
  std::vector<SmoothedStep> interval;
  ImmSmoother(bank).smooth(run.forward, &interval);

  for (double lag : {0.0, 0.35, 100.0}) {
    FixedLagSmoother lagged(bank, lag);
    std::vector<SmoothedStep> out;
    for (const ForwardStep& step : run.forward) {
      const std::size_t before = out.size();
      lagged.add(step, &out);
      for (std::size_t i = before; i < out.size(); ++i) EXPECT_LE(out[i].t, step.t - lag + 1e-12);
    }
    lagged.finish(&out);
    ASSERT_EQ(out.size(), run.forward.size()) << "lag " << lag;
    for (std::size_t k = 0; k < out.size(); ++k) {
      EXPECT_EQ(out[k].t, run.forward[k].t);
      if (lag == 0.0) {
        EXPECT_LT((out[k].mode_probabilities - run.forward[k].mode_probabilities).norm(), 1e-12) << "lag 0 is filtering";
      } else if (lag == 100.0) {
        EXPECT_LT((out[k].mode_probabilities - interval[k].mode_probabilities).norm(), 1e-12)
            << "a lag longer than the log is fixed-interval smoothing";
      }
    }
  }
}

// Every field of two smoothed steps, bit for bit.
void expect_same_bits(const SmoothedStep& a, const SmoothedStep& b, const std::string& where) {
  const auto same = [](const auto& x, const auto& y) {
    return x.rows() == y.rows() && x.cols() == y.cols() && (x.array() == y.array()).all();
  };
  EXPECT_EQ(a.t, b.t) << where;
  EXPECT_TRUE(same(a.mode_probabilities, b.mode_probabilities)) << where;
  EXPECT_EQ(a.unknown_probability, b.unknown_probability) << where;
  ASSERT_EQ(a.mode_states.size(), b.mode_states.size()) << where;
  for (std::size_t j = 0; j < a.mode_states.size(); ++j) {
    EXPECT_TRUE(same(a.mode_states[j], b.mode_states[j])) << where << ", mode " << j;
    EXPECT_TRUE(same(a.mode_covariances[j], b.mode_covariances[j])) << where << ", mode " << j;
  }
  EXPECT_TRUE(same(a.state, b.state)) << where;
  EXPECT_TRUE(same(a.covariance, b.covariance)) << where;
  EXPECT_EQ(a.most_likely_mode, b.most_likely_mode) << where;
}

// The fixed-lag smoother predicts each of a step's mode pairs once and keeps
// the predictions while its window holds the step, where it smooths the
// window again for every step it releases. Its output must be, bit for bit,
// that of smoothing each window from scratch: with the predictions kept,
// with none kept (a budget of 0) and with a budget that runs out after a
// few steps,
// on the bundled example logs of a 2-state bank and of a 3-state one whose
// heading is an angle (the fixed-size pairs), and of the 1-state bank above
// (the dynamic ones).
TEST(ImmSmoother, FixedLagKeepsPairPredictionsWithoutChangingABit) {
  const std::filesystem::path source = SKIDIMM_SOURCE_DIR;
  std::vector<std::pair<Bank, std::vector<ForwardStep>>> runs;
  for (const auto& [bank_file, log] : {std::pair{"configs/ltc_terrains.yaml", "configs/examples/ltc_switching.csv"},
                                       std::pair{"configs/stc_slip4.yaml", "configs/examples/stc_switching.csv"}}) {
    Bank bank = Bank::load(source / bank_file, {SKIDIMM_PLUGIN_DIR});
    Imm imm(bank);
    LogReader reader(bank.config, {source / log});
    std::vector<ForwardStep> forward;
    LogSample sample;
    while (reader.next(&sample))
      forward.push_back(record_step(sample.t, sample.u, imm.step(sample.t, sample.u, sample.z)));
    runs.emplace_back(std::move(bank), std::move(forward));
  }
  {
    const MemorylessBank b;
    Bank bank = b.build();
    Imm imm(bank);
    std::vector<double> z;
    for (int k = 0; k < 60; ++k) z.push_back(b.level[static_cast<std::size_t>(k / 20)] + 0.3 * std::sin(k));
    std::vector<ForwardStep> forward = run_forward(imm, z).forward;
    runs.emplace_back(std::move(bank), std::move(forward));
  }
  for (const auto& [bank, forward] : runs) {
    const std::string name = bank.config.name;
    ASSERT_GT(forward.size(), 40u) << name;
    const double lag = 10.5 * (forward[1].t - forward[0].t);
    // Each window as FixedLagSmoother holds it, smoothed from scratch.
    std::vector<SmoothedStep> expected;
    ImmSmoother smoother(bank);
    std::deque<ForwardStep> window;
    std::vector<SmoothedStep> smoothed;
    for (const ForwardStep& step : forward) {
      window.push_back(step);
      if (window.front().t > step.t - lag) continue;
      smoother.smooth(window, &smoothed);
      std::size_t released = 0;
      while (released < window.size() && window[released].t <= step.t - lag) expected.push_back(smoothed[released++]);
      window.erase(window.begin(), window.begin() + static_cast<std::ptrdiff_t>(released));
    }
    smoother.smooth(window, &smoothed);
    expected.insert(expected.end(), smoothed.begin(), smoothed.end());
    ASSERT_EQ(expected.size(), forward.size()) << name;

    ImmSmoother::PairPredictions one_step;
    smoother.predict_pairs(forward[0], forward[1].t, &one_step);
    const std::size_t step_bytes = one_step.bytes();
    for (const std::size_t budget : {FixedLagSmoother::kDefaultMostKeptPairBytes, std::size_t{0}, 5 * step_bytes}) {
      FixedLagSmoother lagged(bank, lag, budget);
      std::vector<SmoothedStep> out;
      for (const ForwardStep& step : forward) lagged.add(step, &out);
      lagged.finish(&out);
      ASSERT_EQ(out.size(), expected.size()) << name << ", budget " << budget;
      for (std::size_t k = 0; k < out.size(); ++k) {
        expect_same_bits(out[k], expected[k],
                         name + ", budget " + std::to_string(budget) + ", step " + std::to_string(k));
        if (HasFailure()) return;
      }
    }
  }
}

TEST(ImmSmoother, AnglesStayWrappedAcrossTheSeam) {
  BankBuilder b;
  b.states = {"theta"};
  b.angles = {true};
  for (double rate : {0.5, -0.5}) b.models.push_back(std::make_shared<skidimm_test::HeadingModel>(rate));
  b.q = {Eigen::MatrixXd::Constant(1, 1, 0.01)};
  b.r = Eigen::MatrixXd::Constant(1, 1, 0.01);
  b.x0 = Eigen::VectorXd::Constant(1, 3.0);
  const Bank bank = b.build();
  Imm imm(bank);
  std::vector<double> z;
  for (int k = 0; k < 30; ++k) z.push_back(sdk::wrap_angle(3.0 + 0.05 * k));  // crosses +-pi turning left
  const ForwardRun run = run_forward(imm, z);
  std::vector<SmoothedStep> smoothed;
  ImmSmoother(bank).smooth(run.forward, &smoothed);
  for (std::size_t k = 0; k < smoothed.size(); ++k) {
    EXPECT_LE(std::abs(smoothed[k].state[0]), kPi) << k;
    EXPECT_LT(std::abs(sdk::wrap_angle(smoothed[k].state[0] - z[k])), 0.2) << k;
  }
  EXPECT_GT(smoothed[15].mode_probabilities[0], 0.9) << "turning left all along";
}

}  // namespace
}  // namespace skidimm
