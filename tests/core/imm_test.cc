#include "skidimm/engine/imm.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <unsupported/Eigen/MatrixFunctions>
#include <utility>

#include "core/reference_imm.h"
#include "core/sanitizer.h"
#include "core/test_banks.h"
#include "fixed_size_shapes.h"
#include "skidimm/sdk/failure.h"
#include "stc_kinematic/stc_kinematic_model.h"

namespace skidimm {
namespace {

using skidimm_test::BankBuilder;
using skidimm_test::HeadingModel;
using skidimm_test::ScalarLinearModel;
using skidimm_test::vec;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double min_eigenvalue(const Eigen::MatrixXd& m) {
  return Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(m).eigenvalues().minCoeff();
}

// Two scalar linear modes: x' = a x + b u with (a, b) = (-1, 1) and (-2, 0.5).
BankBuilder two_mode_scalar_bank() {
  BankBuilder b;
  b.models = {std::make_shared<ScalarLinearModel>(-1.0, 1.0), std::make_shared<ScalarLinearModel>(-2.0, 0.5)};
  b.q = {Eigen::MatrixXd::Constant(1, 1, 0.1), Eigen::MatrixXd::Constant(1, 1, 0.4)};
  b.r = Eigen::MatrixXd::Constant(1, 1, 0.25);
  b.transition.resize(2, 2);
  b.transition << 0.9, 0.1, 0.2, 0.8;
  b.x0 = vec({0.5});
  b.p0 = Eigen::MatrixXd::Constant(1, 1, 1.0);
  b.mu0 = vec({0.6, 0.4});
  b.floor = 0.0;
  return b;
}

// Textbook scalar IMM in the linear domain (Bar-Shalom 11.6.6), written out
// independently of the library, for the two-mode bank above.
struct ReferenceImm {
  double a[2] = {-1.0, -2.0}, b[2] = {1.0, 0.5}, q[2] = {0.1, 0.4}, r[2] = {0.25, 0.25};  // r: per mode
  double p[2][2] = {{0.9, 0.1}, {0.2, 0.8}};
  double mu[2] = {0.6, 0.4}, x[2] = {0.5, 0.5}, var[2] = {1.0, 1.0};
  double x_combined = 0.5, var_combined = 1.0;
  double likelihood_weight = 1.0;  // mu_j proportional to c_j * likelihood_j^weight
  // > 0: the measurement's likelihood is the Student-t density with this many
  // degrees of freedom and scale s (the innovation variance), not N(nu; 0, s).
  double likelihood_dof = 0.0;
  // A measured output y = gain_j u (this step's input) with variance
  // output_r[j]: it multiplies mode j's likelihood by N(y - gain_j u; 0, output_r[j]).
  double output_gain[2] = {0.0, 0.0}, output_r[2] = {1.0, 1.0};
  // Per mode, the lag-1 correlation of the whitened innovations nu / sqrt(s):
  // the likelihood of z is that of nu given the mode's last innovation, g
  // steps back, N(nu; sqrt(s) a e_last, s (1 - a^2)) with a = rho^g.
  double rho[2] = {0.0, 0.0};
  double last_whitened[2] = {0.0, 0.0};
  int steps_since[2] = {0, 0};
  bool remembers[2] = {false, false};
  bool first = true;
  double last_t = 0.0, held_u = 0.0;

  void step(double t, double u, double z, double y = std::numeric_limits<double>::quiet_NaN()) {
    double c[2], x0[2], p0[2];
    if (first) {
      c[0] = mu[0];
      c[1] = mu[1];
      for (int j = 0; j < 2; ++j) x0[j] = x[j], p0[j] = var[j];
    } else {
      for (int j = 0; j < 2; ++j) {
        c[j] = p[0][j] * mu[0] + p[1][j] * mu[1];
        const double w0 = p[0][j] * mu[0] / c[j], w1 = p[1][j] * mu[1] / c[j];
        x0[j] = w0 * x[0] + w1 * x[1];
        p0[j] = w0 * (var[0] + (x[0] - x0[j]) * (x[0] - x0[j])) + w1 * (var[1] + (x[1] - x0[j]) * (x[1] - x0[j]));
      }
    }
    const double dt = t - last_t;
    double likelihood[2];
    for (int j = 0; j < 2; ++j) {
      double xm = x0[j], pm = p0[j];
      if (!first) {
        const double f = 1.0 + a[j] * dt;
        xm = x0[j] + (a[j] * x0[j] + b[j] * held_u) * dt;
        pm = f * p0[j] * f + q[j] * dt;
      }
      likelihood[j] = 1.0;
      x[j] = xm;
      var[j] = pm;
      if (!first) ++steps_since[j];
      if (!std::isnan(z)) {  // a step without z: prediction only
        double s = pm + r[j], nu = z - xm;
        const double k = pm / s;
        if (rho[j] != 0.0) {
          const double whitened = nu / std::sqrt(s);
          if (remembers[j]) {
            const double lag = std::pow(rho[j], steps_since[j]);
            nu -= std::sqrt(s) * lag * last_whitened[j];
            s *= 1.0 - lag * lag;
          }
          last_whitened[j] = whitened;
          steps_since[j] = 0;
          remembers[j] = true;
        }
        if (likelihood_dof > 0.0) {
          const double v = likelihood_dof;
          likelihood[j] = std::tgamma(0.5 * (v + 1.0)) / (std::tgamma(0.5 * v) * std::sqrt(v * M_PI * s)) *
                          std::pow(1.0 + nu * nu / (v * s), -0.5 * (v + 1.0));
        } else {
          likelihood[j] = std::exp(-0.5 * nu * nu / s) / std::sqrt(2.0 * M_PI * s);
        }
        x[j] = xm + k * (z - xm);
        var[j] = pm - k * pm;  // standard form: equal to Joseph's for the optimal gain
      }
      if (!std::isnan(y)) {
        const double e = y - output_gain[j] * u;
        likelihood[j] *= std::exp(-0.5 * e * e / output_r[j]) / std::sqrt(2.0 * M_PI * output_r[j]);
      }
    }
    for (int j = 0; j < 2; ++j) likelihood[j] = std::pow(likelihood[j], likelihood_weight);
    const double total = likelihood[0] * c[0] + likelihood[1] * c[1];
    for (int j = 0; j < 2; ++j) mu[j] = likelihood[j] * c[j] / total;
    x_combined = mu[0] * x[0] + mu[1] * x[1];
    var_combined =
        mu[0] * (var[0] + std::pow(x[0] - x_combined, 2)) + mu[1] * (var[1] + std::pow(x[1] - x_combined, 2));
    first = false;
    last_t = t;
    held_u = u;
  }
};

TEST(Imm, OneStepMatchesHandComputation) {
  Imm imm(two_mode_scalar_bank().build());
  // Step 0: the prior holds at t = 0, no prediction; both modes see the same
  // prior so their likelihoods are equal and mu stays mu0.
  const ImmEstimate& e0 = imm.step(0.0, vec({1.0}), vec({0.6}));
  EXPECT_NEAR(e0.mode_probabilities[0], 0.6, 1e-15);
  EXPECT_NEAR(e0.state[0], 0.58, 1e-15);         // 0.5 + 0.8 * 0.1, K = 1 / 1.25
  EXPECT_NEAR(e0.covariance(0, 0), 0.2, 1e-15);  // (1 - 0.8) * 1
  // Step 1, computed by hand with the formulas of eq. 4-11:
  // c = [0.62, 0.38]; mode 0: x- = 0.622, P- = 0.172, S = 0.422, nu = 0.078;
  // mode 1: x- = 0.514, P- = 0.168, S = 0.418, nu = 0.186.
  const ImmEstimate& e1 = imm.step(0.1, vec({0.0}), vec({0.7}));
  EXPECT_NEAR(e1.mode_states[0][0], 0.6537914691943127, 1e-14);
  EXPECT_NEAR(e1.mode_states[1][0], 0.588755980861244, 1e-14);
  EXPECT_NEAR(e1.mode_covariances[0](0, 0), 0.10189573459715642, 1e-14);
  EXPECT_NEAR(e1.mode_covariances[1](0, 0), 0.10047846889952153, 1e-14);
  EXPECT_NEAR(e1.log_likelihoods[0], std::log(0.6097098555942483), 1e-13);
  EXPECT_NEAR(e1.log_likelihoods[1], std::log(0.592038042551774), 1e-13);
  EXPECT_NEAR(e1.mode_probabilities[0], 0.626904671091847, 1e-14);
  EXPECT_NEAR(e1.mode_probabilities[1], 0.373095328908153, 1e-14);
  EXPECT_NEAR(e1.state[0], 0.629527032283984, 1e-14);
  EXPECT_NEAR(e1.covariance(0, 0), 0.102356245990562, 1e-14);
  // The paper's eq. 9 (mu_{k-1} in place of c_j) would give 0.6070: the
  // transition matrix must matter.
  EXPECT_GT(std::abs(e1.mode_probabilities[0] - 0.6070377458762876), 0.01);
}

// 200 irregular steps of the two-mode bank with `likelihood_weight`, against
// ReferenceImm with the same weight.
// With `rho`, each mode's innovations are correlated (residual_correlation),
// and every seventh step measures nothing.
void ExpectMatchesReferenceOverManySteps(double likelihood_weight, unsigned seed, double likelihood_dof = 0.0,
                                         std::array<double, 2> rho = {0.0, 0.0}) {
  Bank bank = two_mode_scalar_bank().build();
  bank.config.likelihood_weight = likelihood_weight;
  bank.config.likelihood_dof = likelihood_dof;
  bank.config.modes[0].residual_correlation = rho[0];
  bank.config.modes[1].residual_correlation = rho[1];
  const bool gaps = rho[0] != 0.0 || rho[1] != 0.0;
  Imm imm(std::move(bank));
  ReferenceImm reference;
  reference.likelihood_weight = likelihood_weight;
  reference.likelihood_dof = likelihood_dof;
  reference.rho[0] = rho[0];
  reference.rho[1] = rho[1];
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.5);
  double t = 0.0;
  for (int k = 0; k < 200; ++k) {
    const double u = std::sin(0.1 * k);
    const double z = gaps && k % 7 == 3 ? kNaN : 0.8 * std::sin(0.05 * k) + noise(rng);
    const ImmEstimate& e = imm.step(t, vec({u}), vec({z}));
    reference.step(t, u, z);
    ASSERT_NEAR(e.mode_probabilities[0], reference.mu[0], 1e-10) << "step " << k;
    ASSERT_NEAR(e.mode_states[0][0], reference.x[0], 1e-10) << "step " << k;
    ASSERT_NEAR(e.mode_states[1][0], reference.x[1], 1e-10) << "step " << k;
    ASSERT_NEAR(e.mode_covariances[1](0, 0), reference.var[1], 1e-10) << "step " << k;
    ASSERT_NEAR(e.state[0], reference.x_combined, 1e-10) << "step " << k;
    ASSERT_NEAR(e.covariance(0, 0), reference.var_combined, 1e-10) << "step " << k;
    t += 0.05 + 0.03 * std::cos(k);  // irregular sampling
  }
}

TEST(Imm, MatchesIndependentScalarImplementationOverManySteps) { ExpectMatchesReferenceOverManySteps(1.0, 7); }

// likelihood_weight w: mu_j is proportional to c_j * Lambda_j^w. By hand from
// the step above: c = [0.62, 0.38], Lambda = [0.6097..., 0.5920...], w = 0.5:
// 0.62 * sqrt(0.6097...) / (0.62 * sqrt(0.6097...) + 0.38 * sqrt(0.5920...)).
// At this step the mode filters and their reported likelihoods are as with
// w = 1; from the next step on, the mixing uses the tempered probabilities.
TEST(Imm, LikelihoodWeightTempersEachStepsEvidence) {
  Bank bank = two_mode_scalar_bank().build();
  bank.config.likelihood_weight = 0.5;
  Imm imm(std::move(bank));
  imm.step(0.0, vec({1.0}), vec({0.6}));
  const ImmEstimate& e1 = imm.step(0.1, vec({0.0}), vec({0.7}));
  EXPECT_NEAR(e1.mode_probabilities[0], 0.6234586034966958, 1e-14);
  EXPECT_NEAR(e1.log_likelihoods[0], std::log(0.6097098555942483), 1e-13);
  EXPECT_NEAR(e1.mode_states[0][0], 0.6537914691943127, 1e-14);

  // Over many irregular steps, against the linear-domain reference raising
  // each likelihood to the weight.
  ExpectMatchesReferenceOverManySteps(0.3, 11);
}

// likelihood_dof v: each mode's innovation is scored with the Student-t
// density of scale S. By hand at the step above with v = 1 (Cauchy,
// 1 / (pi sqrt(S) (1 + nu^2 / S))): mode 0 has S = 0.42189..., nu = 0.07794...,
// mode 1 S = 0.41880..., nu = 0.18612...; the filters update as before.
TEST(Imm, LikelihoodDofScoresInnovationsWithTheStudentTDensity) {
  Bank bank = two_mode_scalar_bank().build();
  bank.config.likelihood_dof = 1.0;
  Imm imm(std::move(bank));
  imm.step(0.0, vec({1.0}), vec({0.6}));
  const ImmEstimate& e1 = imm.step(0.1, vec({0.0}), vec({0.7}));
  // S and nu of each mode from its Gaussian likelihood and NIS: log N = -(nis + log(2 pi S)) / 2.
  for (int j = 0; j < 2; ++j) {
    const double gaussian = j == 0 ? std::log(0.6097098555942483) : std::log(0.592038042551774);
    const double s = std::exp(-2.0 * gaussian - e1.nis[j]) / (2.0 * M_PI);
    EXPECT_NEAR(e1.log_likelihoods[j], -std::log(M_PI * std::sqrt(s) * (1.0 + e1.nis[j])), 1e-13) << "mode " << j;
  }
  EXPECT_NEAR(e1.mode_states[0][0], 0.6537914691943127, 1e-14);  // the update is the Kalman one
  ExpectMatchesReferenceOverManySteps(1.0, 13, 3.0);
  ExpectMatchesReferenceOverManySteps(0.4, 17, 7.5);
}

// extrapolation_scale s: at a step whose input lies d range widths outside
// the inputs a class was fitted on, its modes' log-likelihoods count
// t = exp(-d / s) of themselves and 1 - t of the trusted mixture's,
// log((c_0 t Lambda_0 + c_1 Lambda_1) / (c_0 t + c_1)). By hand at the step
// above (u = 0, c and Lambda as there): mode 0 fitted on u in [0.5, 1]
// (d = 1), s = 0.5, so t = exp(-2); mode 1 has no ranges and is used as it
// is. The reported log-likelihoods and the filters are untouched: only the
// probabilities move.
TEST(Imm, ExtrapolationScaleFadesTheEvidenceOfAClassOutsideItsFittedInputs) {
  const auto probability_of_mode_0 = [](double lowest, double highest, double scale) {
    Bank bank = two_mode_scalar_bank().build();
    bank.config.modes[0].fitted_inputs["u"] = InputRange{lowest, highest};
    bank.config.extrapolation_scale = scale;
    Imm imm(std::move(bank));
    imm.step(0.0, vec({1.0}), vec({0.6}));
    const ImmEstimate& e1 = imm.step(0.1, vec({0.0}), vec({0.7}));
    EXPECT_NEAR(e1.log_likelihoods[0], std::log(0.6097098555942483), 1e-13);
    EXPECT_NEAR(e1.mode_states[0][0], 0.6537914691943127, 1e-14);
    return e1.mode_probabilities[0];
  };
  EXPECT_NEAR(probability_of_mode_0(0.5, 1.0, 0.5), 0.6220325635889563, 1e-13);
  // Fitted at one value of u: any other is infinitely far out, t = 0, mode 0
  // is scored as mode 1 is, and keeps its prior c_0 = 0.62.
  EXPECT_NEAR(probability_of_mode_0(0.5, 0.5, 0.5), 0.62, 1e-13);
  // Inside its range, the plain IMM's probability (0.62 Lambda_0 / (0.62
  // Lambda_0 + 0.38 Lambda_1)), bit for bit that of a bank without the key.
  Bank plain_bank = two_mode_scalar_bank().build();
  Imm plain(std::move(plain_bank));
  plain.step(0.0, vec({1.0}), vec({0.6}));
  const double expected = plain.step(0.1, vec({0.0}), vec({0.7})).mode_probabilities[0];
  EXPECT_NEAR(expected, 0.626904671091847, 1e-13);
  EXPECT_EQ(probability_of_mode_0(-1.0, 1.0, 0.5), expected);
}

// A class driven far outside its fitted inputs, whose model misses every step,
// is not driven to its floor: it keeps the share the transitions give it (here
// its prior 0.4, with sticky transitions), where the plain IMM all but rules
// it out.
TEST(Imm, AClassFarOutsideItsFittedInputsIsNotRuledOutByItsMisses) {
  const auto smallest_probability_of_mode_1 = [](double scale) {
    BankBuilder b = two_mode_scalar_bank();
    b.transition << 0.999, 0.001, 0.001, 0.999;
    Bank bank = b.build();
    bank.config.modes[1].fitted_inputs["u"] = InputRange{0.0, 0.1};
    if (scale > 0.0) bank.config.extrapolation_scale = scale;
    Imm imm(std::move(bank));
    double smallest = 1.0;
    // u = 2: mode 0 (x' = -x + u) settles at 2, mode 1 (x' = -2x + u/2) at 0.5; z follows mode 0.
    for (int k = 0; k < 60; ++k) {
      smallest = std::min(smallest, imm.step(0.1 * k, vec({2.0}), vec({2.0})).mode_probabilities[1]);
    }
    return smallest;
  };
  EXPECT_LT(smallest_probability_of_mode_1(0.0), 0.01);
  // 19 range widths out: t = exp(-380), mode 1 scored as mode 0 at every step.
  EXPECT_GT(smallest_probability_of_mode_1(0.05), 0.35);
}

// A measurement far from every mode: the Gaussian density makes the mode whose
// prediction is least wrong almost certain at once; the Student-t one leaves
// the modes near their prior, as neither explains the step.
// residual_correlation rho_j: mode j's likelihood is that of its whitened
// innovation e = nu / sqrt(S) given its last one, N(e; rho e_last, 1 - rho^2)
// / sqrt(S). By hand (an independent numpy computation of the same two-mode
// IMM) with rho = 0.6 and 0.3: step 0 has no memory and is the Gaussian
// density; steps 1 and 2 are conditioned. The filters update as without it.
TEST(Imm, ResidualCorrelationConditionsEachModesLikelihoodOnItsLastInnovation) {
  Bank bank = two_mode_scalar_bank().build();
  bank.config.modes[0].residual_correlation = 0.6;
  bank.config.modes[1].residual_correlation = 0.3;
  Imm imm(std::move(bank));
  const ImmEstimate& e0 = imm.step(0.0, vec({1.0}), vec({0.6}));
  EXPECT_NEAR(e0.log_likelihoods[0], -1.0345103088617775, 1e-14);
  const ImmEstimate& e1 = imm.step(0.1, vec({0.0}), vec({0.7}));
  EXPECT_NEAR(e1.log_likelihoods[0], -0.2678650635855219, 1e-13);
  EXPECT_NEAR(e1.log_likelihoods[1], -0.4730344479358252, 1e-13);
  EXPECT_NEAR(e1.mode_probabilities[0], 0.6670155595228378, 1e-13);
  EXPECT_NEAR(e1.mode_states[0][0], 0.6537914691943127, 1e-14);  // the Kalman update
  const ImmEstimate& e2 = imm.step(0.2, vec({0.5}), vec({0.9}));
  EXPECT_NEAR(e2.log_likelihoods[0], -0.3330961657468772, 1e-13);
  EXPECT_NEAR(e2.log_likelihoods[1], -0.5625450186308533, 1e-13);
  EXPECT_NEAR(e2.mode_probabilities[0], 0.7157944391422081, 1e-13);
  EXPECT_NEAR(e2.mode_states[1][0], 0.6051625494287534, 1e-13);

  // Over many irregular steps, some measuring nothing (the memory then is
  // rho^2 of the innovation two steps back), against the linear-domain
  // reference; with the weight and the Student-t density too.
  ExpectMatchesReferenceOverManySteps(1.0, 19, 0.0, {0.6, 0.3});
  ExpectMatchesReferenceOverManySteps(0.3, 23, 5.0, {0.9, -0.4});
}

// A mode whose rho is 0 is scored exactly as without the option, bit for bit,
// next to a mode whose rho is not; and a later reset forgets every memory.
TEST(Imm, ZeroResidualCorrelationIsTheIndependentLikelihoodBitForBit) {
  Bank correlated = two_mode_scalar_bank().build();
  correlated.config.modes[1].residual_correlation = 0.5;
  Imm plain(two_mode_scalar_bank().build()), with(std::move(correlated));
  for (int pass = 0; pass < 2; ++pass) {
    for (const double t : {0.0, 0.1}) {
      const ImmEstimate& p = plain.step(t, vec({1.0 - t}), vec({0.6 + t}));
      const ImmEstimate& w = with.step(t, vec({1.0 - t}), vec({0.6 + t}));
      EXPECT_EQ(p.log_likelihoods[0], w.log_likelihoods[0]);
      EXPECT_EQ(p.mode_states[0][0], w.mode_states[0][0]);
      EXPECT_EQ(p.mode_states[1][0], w.mode_states[1][0]);
      if (t == 0.0) {
        EXPECT_EQ(p.log_likelihoods[1], w.log_likelihoods[1]);  // no memory yet
      } else {
        EXPECT_NE(p.log_likelihoods[1], w.log_likelihoods[1]);
      }
    }
    plain.reset();
    with.reset();
  }
}

TEST(Imm, AStudentTLikelihoodIsNotSureOfTheLeastWrongModeAfterOneWildStep) {
  for (const double dof : {0.0, 4.0}) {
    Bank bank = two_mode_scalar_bank().build();
    bank.config.likelihood_dof = dof;
    Imm imm(std::move(bank));
    imm.step(0.0, vec({1.0}), vec({0.6}));
    const ImmEstimate& e = imm.step(0.1, vec({0.0}), vec({25.0}));
    if (dof == 0.0) {
      EXPECT_GT(e.mode_probabilities[0], 0.99999);
    } else {
      EXPECT_GT(e.mode_probabilities[0], 0.6);
      EXPECT_LT(e.mode_probabilities[0], 0.7);
    }
  }
}

// The unknown hypothesis by hand on two_mode_scalar_bank (inflation 100, enter
// 0.05, leave 0.2). Step 0 has no transition and mu_U starts at 0, so it
// stays 0. Step 1 measures z = 3, far from both modes: with the modes'
// predictions of OneStepMatchesHandComputation (c' = [0.62, 0.38];
// x- = 0.622, 0.514; S = 0.422, 0.418), the chain gives
// c = [0.95 * 0.62, 0.95 * 0.38, 0.05]; log N(nu; 0, S) = -7.18766, -7.87538;
// the unknown's, log N(nu_0; 0, 100 S_0) = -2.85715 (mode 0 fits better);
// mu = c Lambda / sum = [0.128894, 0.0397148, 0.831391]. The combined state
// weighs the modes' updated states 1.59123 and 1.51316 by their conditional
// probabilities: 1.57284. Both kernels.
TEST(Imm, UnknownHypothesisTakesTheMassWhenEveryModeMissesByFar) {
  for (const ImmKernelChoice choice : {ImmKernelChoice::kFastest, ImmKernelChoice::kDynamic}) {
    Bank bank = two_mode_scalar_bank().build();
    bank.config.unknown.inflation = 100.0;
    bank.config.unknown.enter = 0.05;
    bank.config.unknown.leave = 0.2;
    Imm imm(std::move(bank), choice);
    const ImmEstimate& e0 = imm.step(0.0, vec({1.0}), vec({0.6}));
    EXPECT_EQ(e0.unknown_probability, 0.0);
    EXPECT_NEAR(e0.mode_probabilities[0], 0.6, 1e-15);
    const ImmEstimate& e1 = imm.step(0.1, vec({0.0}), vec({3.0}));
    EXPECT_NEAR(e1.log_likelihoods[0], -7.187663076797962, 1e-12);
    EXPECT_NEAR(e1.log_likelihoods[1], -7.875380557344402, 1e-12);
    EXPECT_NEAR(e1.mode_probabilities[0], 0.12889397707459344, 1e-13);
    EXPECT_NEAR(e1.mode_probabilities[1], 0.03971482236861092, 1e-13);
    EXPECT_NEAR(e1.unknown_probability, 0.8313912005567956, 1e-13);
    EXPECT_NEAR(e1.mode_probabilities.sum() + e1.unknown_probability, 1.0, 1e-15);
    EXPECT_EQ(e1.most_likely_mode, 0);
    EXPECT_TRUE(e1.unknown_is_most_likely());
    EXPECT_NEAR(e1.state[0], 1.5728422723552906, 1e-12);
    // Step 2, back near the modes: the chain gives back leave = 0.2 of U's
    // mass and takes enter = 0.05 of the modes'; the unknown's likelihood is
    // the better mode's innovation under 100 S, from the NIS and the
    // Gaussian log-likelihood.
    const double mu_u = e1.unknown_probability;
    const Eigen::Vector2d conditional = e1.mode_probabilities / e1.mode_probabilities.sum();
    const Eigen::Vector2d chain = Eigen::Matrix2d((Eigen::Matrix2d() << 0.9, 0.1, 0.2, 0.8).finished()).transpose() *
                                  conditional;
    const ImmEstimate& e2 = imm.step(0.2, vec({0.0}), vec({1.4}));
    double unknown_log_likelihood = -std::numeric_limits<double>::infinity();
    for (int j = 0; j < 2; ++j) {
      unknown_log_likelihood = std::max(unknown_log_likelihood, e2.log_likelihoods[j] + 0.5 * e2.nis[j] * (1 - 0.01) -
                                                                    0.5 * std::log(100.0));
    }
    Eigen::Vector3d w;
    for (int j = 0; j < 2; ++j) {
      w[j] = ((1 - mu_u) * 0.95 * chain[j] + mu_u * 0.2 / 2) * std::exp(e2.log_likelihoods[j]);
    }
    w[2] = ((1 - mu_u) * 0.05 + mu_u * 0.8) * std::exp(unknown_log_likelihood);
    w /= w.sum();
    EXPECT_NEAR(e2.mode_probabilities[0], w[0], 1e-13);
    EXPECT_NEAR(e2.mode_probabilities[1], w[1], 1e-13);
    EXPECT_NEAR(e2.unknown_probability, w[2], 1e-13);
    EXPECT_LT(e2.unknown_probability, 0.5 * mu_u);
    EXPECT_FALSE(e2.unknown_is_most_likely());
  }
}

// Under a Student-t likelihood the unknown hypothesis is scored in the same
// family: the best mode's innovation under the Student-t density of scale
// inflation x S, here written out from its definition for one row,
//   log t(nu; dof, s S) = lgamma((dof + 1)/2) - lgamma(dof/2) - log(dof pi s S)/2
//                         - (dof + 1)/2 log(1 + nu^2 / (dof s S)),
// with each mode's S recovered from its own Student-t log-likelihood and NIS.
TEST(Imm, UnknownHypothesisUnderAStudentTLikelihoodIsAStudentTToo) {
  const double dof = 4.0, inflation = 100.0;
  for (const ImmKernelChoice choice : {ImmKernelChoice::kFastest, ImmKernelChoice::kDynamic}) {
    Bank bank = two_mode_scalar_bank().build();
    bank.config.likelihood_dof = dof;
    bank.config.unknown.inflation = inflation;
    bank.config.unknown.enter = 0.05;
    bank.config.unknown.leave = 0.2;
    Imm imm(std::move(bank), choice);
    const ImmEstimate& e0 = imm.step(0.0, vec({1.0}), vec({0.6}));
    const Eigen::Vector2d chain =
        Eigen::Matrix2d((Eigen::Matrix2d() << 0.9, 0.1, 0.2, 0.8).finished()).transpose() * e0.mode_probabilities;
    const ImmEstimate& e1 = imm.step(0.1, vec({0.0}), vec({3.0}));
    const double constant = std::lgamma(0.5 * (dof + 1)) - std::lgamma(0.5 * dof) - 0.5 * std::log(dof * M_PI);
    double unknown_log_likelihood = -std::numeric_limits<double>::infinity();
    for (int j = 0; j < 2; ++j) {
      const double d2 = e1.nis[j];
      const double log_s = 2.0 * (constant - 0.5 * (dof + 1) * std::log1p(d2 / dof) - e1.log_likelihoods[j]);
      const double broad = constant - 0.5 * (std::log(inflation) + log_s) -
                           0.5 * (dof + 1) * std::log1p(d2 / (dof * inflation));
      unknown_log_likelihood = std::max(unknown_log_likelihood, broad);
    }
    Eigen::Vector3d w;
    for (int j = 0; j < 2; ++j) w[j] = 0.95 * chain[j] * std::exp(e1.log_likelihoods[j]);
    w[2] = 0.05 * std::exp(unknown_log_likelihood);
    w /= w.sum();
    EXPECT_NEAR(e1.mode_probabilities[0], w[0], 1e-13);
    EXPECT_NEAR(e1.mode_probabilities[1], w[1], 1e-13);
    EXPECT_NEAR(e1.unknown_probability, w[2], 1e-13);
  }
  // A miss of a hundred standard deviations: the modes' density falls only
  // with log d2, and so does the unknown's, which wins the far tail by
  // dof log(inflation) / 2 = 9.2 nats, against the chain's odds of 1 to 19.
  // A broad Gaussian would have lost it by about a thousand nats.
  Bank bank = two_mode_scalar_bank().build();
  bank.config.likelihood_dof = dof;
  bank.config.unknown.inflation = inflation;
  bank.config.unknown.enter = 0.05;
  bank.config.unknown.leave = 0.2;
  Imm imm(std::move(bank));
  imm.step(0.0, vec({1.0}), vec({0.6}));
  const ImmEstimate& far = imm.step(0.1, vec({0.0}), vec({300.0}));
  EXPECT_GT(far.unknown_probability, 0.99);
}

// Without a miss the unknown hypothesis only costs its share of the chain:
// along a run the modes explain, it stays near enter / (enter + leave) times
// the evidence ratio, far from being the most likely.
TEST(Imm, UnknownHypothesisStaysSmallWhileAModeFits) {
  Bank bank = two_mode_scalar_bank().build();
  bank.config.unknown.inflation = 100.0;
  bank.config.unknown.enter = 0.05;
  bank.config.unknown.leave = 0.2;
  Imm imm(std::move(bank));
  double largest = 0.0;
  double x = 0.5;
  for (int k = 0; k < 50; ++k) {
    x += (-x + 1.0) * 0.1;  // mode 0 with u = 1
    const ImmEstimate& e = imm.step(0.1 * k, vec({1.0}), vec({x}));
    largest = std::max(largest, e.unknown_probability);
    ASSERT_NEAR(e.mode_probabilities.sum() + e.unknown_probability, 1.0, 1e-12) << "step " << k;
  }
  EXPECT_GT(largest, 0.0);
  EXPECT_LT(largest, 0.05);
}

// ScalarLinearModel that also predicts outputs from the input: "y" = gain u
// (listed second, so the bank must find it by name), and fails on u > 100.
class ScalarModelWithOutput : public ScalarLinearModel {
 public:
  ScalarModelWithOutput(double a, double b, double gain) : ScalarLinearModel(a, b), gain_(gain) {}
  const std::vector<std::string>& output_names() const noexcept override { return names_; }
  bool outputs(const Eigen::Ref<const Eigen::VectorXd>& u, Eigen::Ref<Eigen::VectorXd> y) const noexcept override {
    if (u[0] > 100.0) {
      sdk::report_failure("u above 100");
      return false;
    }
    y << -7.0, gain_ * u[0];
    return true;
  }

 private:
  double gain_;
  const std::vector<std::string> names_{"unused", "y"};
};

// two_mode_scalar_bank measuring x and the output y = gain_j u (gains 0.5
// and 1, R_y = 0.04).
Bank scalar_bank_with_output() {
  BankBuilder b = two_mode_scalar_bank();
  b.models = {std::make_shared<ScalarModelWithOutput>(-1.0, 1.0, 0.5),
              std::make_shared<ScalarModelWithOutput>(-2.0, 0.5, 1.0)};
  b.h = Eigen::MatrixXd::Zero(2, 1);
  b.h(0, 0) = 1.0;
  b.r = Eigen::Vector2d(0.25, 0.04).asDiagonal();
  Bank bank = b.build();
  bank.config.measurement.names = {"x", "y"};
  bank.config.measurement.outputs = {"y"};
  return bank;
}

// A measured output leaves every state as without it and multiplies each
// mode's likelihood by N(y - gain_j u; 0, R_y), u this step's input: by hand
// at step 1 (u = 0.5, y = 0.3), for the fixed-size and the dynamic kernels.
TEST(Imm, MeasuredOutputsScoreEachModesPrediction) {
  for (const ImmKernelChoice choice : {ImmKernelChoice::kFastest, ImmKernelChoice::kDynamic}) {
    Imm plain(two_mode_scalar_bank().build(), choice);
    Imm with(scalar_bank_with_output(), choice);
    plain.step(0.0, vec({1.0}), vec({0.6}));
    with.step(0.0, vec({1.0}), vec({0.6, kNaN}));
    const ImmEstimate& p = plain.step(0.1, vec({0.5}), vec({0.7}));
    const ImmEstimate& e = with.step(0.1, vec({0.5}), vec({0.7, 0.3}));
    // log N(0.3 - 0.25; 0, 0.04) and log N(0.3 - 0.5; 0, 0.04).
    const double log_n[2] = {-0.5 * 0.0025 / 0.04 - 0.5 * std::log(2.0 * M_PI * 0.04),
                             -0.5 * 0.04 / 0.04 - 0.5 * std::log(2.0 * M_PI * 0.04)};
    const double weight[2] = {p.mode_probabilities[0] * std::exp(log_n[0]),
                              p.mode_probabilities[1] * std::exp(log_n[1])};
    for (int j = 0; j < 2; ++j) {
      EXPECT_NEAR(e.log_likelihoods[j], p.log_likelihoods[j] + log_n[j], 1e-12);
      EXPECT_NEAR(e.mode_states[j][0], p.mode_states[j][0], 1e-15);
      EXPECT_NEAR(e.mode_covariances[j](0, 0), p.mode_covariances[j](0, 0), 1e-15);
      EXPECT_NEAR(e.mode_probabilities[j], weight[j] / (weight[0] + weight[1]), 1e-12);
    }
    EXPECT_EQ(e.num_measured, 2);

    // A model whose outputs() fails is rejected for the step, with its reason.
    const ImmEstimate& failed = with.step(0.2, vec({200.0}), vec({0.7, 0.3}));
    EXPECT_EQ(failed.status, StepStatus::kAllModesRejected);
    EXPECT_EQ(failed.mode_failures[0], ModeFailure::kModel);
    EXPECT_EQ(failed.failure_reasons[0], "u above 100");
  }
}

// Over many irregular steps, a third of them without the output, against
// the independent scalar IMM.
TEST(Imm, MeasuredOutputsMatchTheReferenceOverManySteps) {
  for (const ImmKernelChoice choice : {ImmKernelChoice::kFastest, ImmKernelChoice::kDynamic}) {
    Imm imm(scalar_bank_with_output(), choice);
    ReferenceImm reference;
    reference.output_gain[0] = 0.5;
    reference.output_gain[1] = 1.0;
    reference.output_r[0] = reference.output_r[1] = 0.04;
    std::mt19937 rng(5);
    std::normal_distribution<double> noise(0.0, 0.2);
    double t = 0.0;
    for (int k = 0; k < 200; ++k) {
      const double u = std::sin(0.1 * k);
      const double z = 0.8 * std::sin(0.05 * k) + noise(rng);
      const double y = k % 3 == 1 ? kNaN : 0.7 * u + noise(rng);
      const ImmEstimate& e = imm.step(t, vec({u}), vec({z, y}));
      reference.step(t, u, z, y);
      ASSERT_NEAR(e.mode_probabilities[0], reference.mu[0], 1e-10) << "step " << k;
      ASSERT_NEAR(e.mode_states[1][0], reference.x[1], 1e-10) << "step " << k;
      ASSERT_NEAR(e.covariance(0, 0), reference.var_combined, 1e-10) << "step " << k;
      t += 0.05 + 0.03 * std::cos(k);
    }
  }
}

// A mode with its own R (ModeConfig::r): its filter takes that noise, for the
// state's measurement and the output alike, against the independent scalar
// IMM given the same per-mode noise; both kernels.
TEST(Imm, EachModesOwnMeasurementNoiseIsItsFiltersNoise) {
  for (const ImmKernelChoice choice : {ImmKernelChoice::kFastest, ImmKernelChoice::kDynamic}) {
    Bank bank = scalar_bank_with_output();
    bank.config.modes[1].r = Eigen::Vector2d(0.6, 0.01).asDiagonal();
    Imm imm(std::move(bank), choice);
    ReferenceImm reference;
    reference.output_gain[0] = 0.5;
    reference.output_gain[1] = 1.0;
    reference.r[1] = 0.6;
    reference.output_r[0] = 0.04;
    reference.output_r[1] = 0.01;
    std::mt19937 rng(8);
    std::normal_distribution<double> noise(0.0, 0.2);
    double t = 0.0;
    for (int k = 0; k < 200; ++k) {
      const double u = std::sin(0.1 * k);
      const double z = k % 4 == 2 ? kNaN : 0.8 * std::sin(0.05 * k) + noise(rng);
      const double y = k % 3 == 1 ? kNaN : 0.7 * u + noise(rng);
      const ImmEstimate& e = imm.step(t, vec({u}), vec({z, y}));
      reference.step(t, u, z, y);
      ASSERT_NEAR(e.mode_probabilities[0], reference.mu[0], 1e-10) << "step " << k;
      ASSERT_NEAR(e.mode_states[1][0], reference.x[1], 1e-10) << "step " << k;
      ASSERT_NEAR(e.mode_covariances[1](0, 0), reference.var[1], 1e-10) << "step " << k;
      t += 0.05 + 0.03 * std::cos(k);
    }
  }
  // The same bank with every mode's R equal to the bank's runs as the bank.
  Bank same = scalar_bank_with_output();
  for (ModeConfig& m : same.config.modes) m.r = same.config.measurement.r;
  Imm a(std::move(same)), b(scalar_bank_with_output());
  for (int k = 0; k < 50; ++k) {
    const ImmEstimate& ea = a.step(0.1 * k, vec({std::cos(0.2 * k)}), vec({0.3 * k, 0.1}));
    const ImmEstimate& eb = b.step(0.1 * k, vec({std::cos(0.2 * k)}), vec({0.3 * k, 0.1}));
    ASSERT_EQ(ea.mode_probabilities, eb.mode_probabilities) << "step " << k;
  }
}

// Three LTC modes with random inputs: the invariants hold at every step.
TEST(Imm, InvariantsHoldAtEveryStep) {
  BankBuilder b;
  b.states = {"V", "omega"};
  b.angles = {false, false};
  b.inputs = {"phi_dot_L", "phi_dot_R"};
  Eigen::Matrix2d a1, a2, a3, b1;
  a1 << -5, 0, 0, -4;
  a2 << -3, 0.1, 0, -2.5;
  a3 << -2, 0, -0.2, -2;
  b1 << 0.4, 0.4, -0.8, 0.8;
  b.models = {skidimm_test::make_ltc(a1, b1), skidimm_test::make_ltc(a2, 0.6 * b1),
              skidimm_test::make_ltc(a3, 0.4 * b1)};
  b.q = {Eigen::Matrix2d::Identity() * 0.01, Eigen::Matrix2d::Identity() * 0.02, Eigen::Matrix2d::Identity() * 0.05};
  b.r = Eigen::Vector2d(0.0025, 0.001).asDiagonal();
  Imm imm(b.build());
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 1.0);
  for (int k = 0; k < 500; ++k) {
    // One draw per statement: the order of draws within one argument list is
    // the compiler's, and clang's and gcc's differ.
    const double u0 = noise(rng), u1 = noise(rng), z0 = noise(rng), z1 = noise(rng);
    const Eigen::Vector2d u(3.0 + u0, 4.0 + u1);
    const Eigen::Vector2d z(0.5 + 0.3 * z0, 0.2 + 0.3 * z1);
    const ImmEstimate& e = imm.step(0.02 * k, u, k % 7 == 3 ? Eigen::Vector2d(kNaN, z[1]) : z);
    ASSERT_NEAR(e.mode_probabilities.sum(), 1.0, 1e-12);
    ASSERT_TRUE((e.mode_probabilities.array() >= 0.0).all());
    Eigen::MatrixXd weighted = Eigen::MatrixXd::Zero(2, 2);
    for (int j = 0; j < 3; ++j) {
      const Eigen::MatrixXd& p = e.mode_covariances[j];
      ASSERT_EQ(p, p.transpose());
      ASSERT_GT(min_eigenvalue(p), 0.0);
      weighted += e.mode_probabilities[j] * p;
    }
    ASSERT_EQ(e.covariance, e.covariance.transpose());
    // P = sum mu_j P_j + spread of the means: never smaller than the weighted covariances.
    ASSERT_GE(min_eigenvalue(e.covariance - weighted), -1e-12) << "step " << k;
  }
}

// Data generated from one of two clearly different modes: the IMM settles on
// it, and follows a switch within a bounded number of steps.
TEST(Imm, IdentifiesTheTrueModeAndFollowsASwitch) {
  Eigen::Matrix2d a_fast, a_slow, b_grip;
  a_fast << -5, 0, 0, -4;
  a_slow << -2, 0, 0, -1.5;
  b_grip << 0.4, 0.4, -0.8, 0.8;
  auto fast = skidimm_test::make_ltc(a_fast, b_grip);
  auto slow = skidimm_test::make_ltc(a_slow, 0.25 * b_grip);  // 60% lower steady-state gains
  BankBuilder b;
  b.states = {"V", "omega"};
  b.angles = {false, false};
  b.inputs = {"phi_dot_L", "phi_dot_R"};
  b.models = {fast, slow};
  b.q = {Eigen::Matrix2d::Identity() * 0.01};
  b.r = Eigen::Vector2d(0.05 * 0.05, 0.03 * 0.03).asDiagonal();
  b.transition.resize(2, 2);
  b.transition << 0.999, 0.001, 0.001, 0.999;  // 20 s mean dwell at 50 Hz
  Imm imm(b.build());

  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, 1.0);
  const double dt = 0.02;
  Eigen::VectorXd x = Eigen::Vector2d::Zero(), next(2);
  int steps_to_follow = -1;
  const int switch_step = 500;
  int settled_steps = 0;  // steps 100-499 with the true mode most likely
  double last_second_sum = 0.0;
  for (int k = 0; k < 1000; ++k) {
    const double t = k * dt;
    const Eigen::Vector2d u(4.0 + 2.0 * std::sin(0.7 * t), 4.0 + 2.0 * std::cos(0.5 * t));
    // Drawn one statement each: the order of two draws in one argument list
    // is the compiler's choice, and clang's gave other data than gcc's.
    const double v_noise = noise(rng);
    const double omega_noise = noise(rng);
    const Eigen::Vector2d z(x[0] + 0.05 * v_noise, x[1] + 0.03 * omega_noise);
    const ImmEstimate& e = imm.step(t, u, z);
    const int truth = k < switch_step ? 0 : 1;
    if (k >= 100 && k < switch_step) settled_steps += e.most_likely_mode == 0 ? 1 : 0;
    if (k >= switch_step - 50 && k < switch_step) last_second_sum += e.mode_probabilities[0];
    if (k >= switch_step && steps_to_follow < 0 && e.most_likely_mode == truth) steps_to_follow = k - switch_step;
    if (k > switch_step + 100) {
      EXPECT_EQ(e.most_likely_mode, 1) << "lost the mode again at step " << k;
    }
    (truth == 0 ? *fast : *slow).predict(x, u, dt, next);
    const double w0 = noise(rng), w1 = noise(rng);
    x = next + Eigen::Vector2d(0.1 * std::sqrt(dt) * w0, 0.1 * std::sqrt(dt) * w1);
  }
  // Settled on the first mode: most likely at 95% of the steps from 2 s to
  // the switch, and a mean probability above 0.95 over the second before it.
  // (One step's value is noise: it was 0.986 or 0.996 at the last step before
  // the switch depending on the order of two draws, i.e. on the compiler.)
  EXPECT_GE(settled_steps, 380);
  EXPECT_GT(last_second_sum / 50.0, 0.95);
  EXPECT_GT(imm.estimate().mode_probabilities[1], 0.99);
  ASSERT_GE(steps_to_follow, 0) << "the switch was never followed";
  EXPECT_LE(steps_to_follow, 50) << "took more than 1 s to follow the switch";
}

// 16 modes, tight covariances, data far from most modes: log-likelihoods of
// -1e5 and below would underflow a linear-domain update to 0/0 = NaN.
TEST(Imm, SixteenTightModesRun1e5StepsWithoutNaNOrUnderflow) {
  SKIDIMM_SKIP_UNDER_SANITIZERS_STATISTICAL();
  BankBuilder b;
  b.states = {"V", "omega"};
  b.angles = {false, false};
  b.inputs = {"phi_dot_L", "phi_dot_R"};
  Eigen::Matrix2d b_grip;
  b_grip << 0.4, 0.4, -0.8, 0.8;
  for (int j = 0; j < 16; ++j) {
    Eigen::Matrix2d a = Eigen::Matrix2d::Identity() * -(1.0 + 0.3 * j);
    b.models.push_back(skidimm_test::make_ltc(a, (0.3 + 0.04 * j) * b_grip));
  }
  b.q = {Eigen::Matrix2d::Identity() * 1e-8};
  b.r = Eigen::Matrix2d::Identity() * 1e-8;
  b.floor = 1e-12;
  Imm imm(b.build());
  double min_log_likelihood = 0.0;
  for (int k = 0; k < 100000; ++k) {
    const double t = 0.01 * k;
    const Eigen::Vector2d u(5.0 + std::sin(t), 5.0 + std::cos(0.3 * t));
    const Eigen::Vector2d z(0.8 + 0.5 * std::sin(0.2 * t), 0.3 * std::cos(0.1 * t));  // no mode explains this
    const ImmEstimate& e = imm.step(t, u, z);
    ASSERT_TRUE(e.mode_probabilities.allFinite()) << "step " << k;
    ASSERT_TRUE(e.state.allFinite() && e.covariance.allFinite()) << "step " << k;
    ASSERT_NEAR(e.mode_probabilities.sum(), 1.0, 1e-9) << "step " << k;
    ASSERT_GE(e.mode_probabilities.minCoeff(), 1e-12 * 0.99) << "step " << k;
    min_log_likelihood = std::min(min_log_likelihood, e.log_likelihoods.minCoeff());
  }
  EXPECT_LT(min_log_likelihood, -1e4) << "the test must actually reach likelihoods that underflow exp()";
}

TEST(Imm, PredictOnlyStepMovesProbabilitiesOnlyThroughTheChain) {
  Imm imm(two_mode_scalar_bank().build());
  imm.step(0.0, vec({1.0}), vec({0.6}));
  imm.step(0.1, vec({1.0}), vec({0.9}));
  const Eigen::VectorXd before = imm.estimate().mode_probabilities;
  const ImmEstimate& e = imm.step(0.2, vec({1.0}), vec({kNaN}));
  EXPECT_EQ(e.status, StepStatus::kPredictOnly);
  EXPECT_EQ(e.num_measured, 0);
  EXPECT_TRUE(std::isnan(e.log_likelihoods[0]));
  // mu_k = P' mu_{k-1}: no likelihood applied.
  EXPECT_NEAR(e.mode_probabilities[0], 0.9 * before[0] + 0.2 * before[1], 1e-15);
  EXPECT_NEAR(e.mode_probabilities[1], 0.1 * before[0] + 0.8 * before[1], 1e-15);
}

TEST(Imm, PartiallyObservedRowUsesOnlyThePresentComponents) {
  // The same 2-state bank measuring [V, omega], fed (V, NaN), must equal a bank
  // that measures V alone.
  Eigen::Matrix2d a, bm;
  a << -5, 0, 0, -4;
  bm << 0.4, 0.4, -0.8, 0.8;
  BankBuilder both;
  both.states = {"V", "omega"};
  both.angles = {false, false};
  both.inputs = {"l", "r"};
  both.models = {skidimm_test::make_ltc(a, bm), skidimm_test::make_ltc(0.5 * a, bm)};
  both.q = {Eigen::Matrix2d::Identity() * 0.01};
  both.r.resize(2, 2);
  both.r << 0.01, 0.002, 0.002, 0.02;
  BankBuilder v_only = both;
  v_only.h = Eigen::RowVector2d(1.0, 0.0);
  v_only.r = Eigen::MatrixXd::Constant(1, 1, 0.01);
  Imm imm_both(both.build()), imm_v(v_only.build());
  for (int k = 0; k < 20; ++k) {
    const Eigen::Vector2d u(3.0, 5.0);
    const double v = 0.1 * k;
    const ImmEstimate& e_both = imm_both.step(0.02 * k, u, Eigen::Vector2d(v, kNaN));
    const ImmEstimate& e_v = imm_v.step(0.02 * k, u, vec({v}));
    EXPECT_EQ(e_both.num_measured, 1);
    ASSERT_TRUE(e_both.state.isApprox(e_v.state, 1e-13));
    ASSERT_TRUE(e_both.mode_probabilities.isApprox(e_v.mode_probabilities, 1e-13));
  }
}

TEST(Imm, AnglesAreMixedAndUpdatedAcrossThePiSeam) {
  // Two heading modes turning at rates 1 and 1.3 (x u) through +-pi. A naive
  // average of 3.13 and -3.13 would give ~0, a jump of pi.
  BankBuilder b;
  b.states = {"theta"};
  b.angles = {true};
  b.models = {std::make_shared<HeadingModel>(1.0), std::make_shared<HeadingModel>(1.3)};
  b.q = {Eigen::MatrixXd::Constant(1, 1, 1e-4)};
  b.r = Eigen::MatrixXd::Constant(1, 1, 1e-4);
  b.x0 = vec({3.0});
  b.p0 = Eigen::MatrixXd::Constant(1, 1, 0.01);
  Imm imm(b.build());
  double truth = 3.0;
  for (int k = 0; k < 60; ++k) {
    const double t = 0.05 * k;
    const ImmEstimate& e = imm.step(t, vec({1.0}), vec({truth}));
    const double error = sdk::wrap_angle(e.state[0] - truth);
    ASSERT_LT(std::abs(error), 0.05) << "step " << k << ": estimate " << e.state[0] << " truth " << truth;
    ASSERT_GE(e.state[0], -M_PI);
    ASSERT_LT(e.state[0], M_PI);
    ASSERT_LT(e.covariance(0, 0), 0.01) << "a seam-crossing mix would inflate the spread to ~pi^2";
    truth = sdk::wrap_angle(truth + 1.15 * 0.05);  // between the two modes' rates
  }
}

TEST(Imm, RejectsNonIncreasingTimeAndNonFiniteInputWithoutChangingState) {
  Imm imm(two_mode_scalar_bank().build());
  imm.step(0.0, vec({1.0}), vec({0.6}));
  const ImmEstimate before = imm.step(0.1, vec({1.0}), vec({0.7}));
  const ImmEstimate& same_time = imm.step(0.1, vec({1.0}), vec({5.0}));
  EXPECT_EQ(same_time.status, StepStatus::kRejectedTime);
  EXPECT_EQ(same_time.state, before.state);
  EXPECT_EQ(same_time.mode_probabilities, before.mode_probabilities);
  const ImmEstimate& nan_input = imm.step(0.2, vec({kNaN}), vec({0.7}));
  EXPECT_EQ(nan_input.status, StepStatus::kRejectedInput);
  EXPECT_EQ(nan_input.state, before.state);
  // The next valid step proceeds normally.
  EXPECT_EQ(imm.step(0.2, vec({1.0}), vec({0.7})).status, StepStatus::kUpdated);
}

TEST(Imm, ResetReturnsToThePrior) {
  Imm imm(two_mode_scalar_bank().build());
  const double first = imm.step(0.0, vec({1.0}), vec({0.6})).state[0];
  imm.step(0.1, vec({1.0}), vec({2.0}));
  imm.reset();
  EXPECT_EQ(imm.step(5.0, vec({1.0}), vec({0.6})).state[0], first);
}

// ---------------------------------------------------------------- references
//
// The engine against ReferenceImm (reference_imm.h): fixed-size, hand-written,
// mixing each target around its own heaviest component. Every transition
// form, irregular dt, partial rows, headings across +-pi; both the fixed-size
// kernels and the dynamic one.

enum class Form { kPerStep, kEqualDwell, kPerModeDwell };

void set_form(Form form, BankBuilder* b, Bank* bank) {
  const int n = static_cast<int>(b->models.size());
  TransitionConfig& t = bank->config.transition;
  switch (form) {
    case Form::kPerStep:
      t.kind = TransitionConfig::Kind::kMatrix;
      t.matrix = Eigen::MatrixXd::Constant(n, n, 0.03 / (n - 1));
      t.matrix.diagonal().setConstant(0.97);
      t.matrix(0, 1) += 0.01;  // not symmetric
      t.matrix(0, 0) -= 0.01;
      break;
    case Form::kEqualDwell:
      t.kind = TransitionConfig::Kind::kDwellTimes;
      t.dwell_seconds = Eigen::VectorXd::Constant(n, 2.0);
      break;
    case Form::kPerModeDwell:
      t.kind = TransitionConfig::Kind::kDwellTimes;
      t.dwell_seconds = Eigen::VectorXd::LinSpaced(n, 0.5, 6.0);
      break;
  }
}

// P(dt) for the reference, independently: Eigen's Pade exponential of the
// generator written out here, or the per-step matrix.
Eigen::MatrixXd reference_transition(const TransitionConfig& t, double dt) {
  if (t.kind == TransitionConfig::Kind::kMatrix) return t.matrix;
  const Eigen::Index n = t.dwell_seconds.size();
  Eigen::MatrixXd generator(n, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    generator.row(i).setConstant(1.0 / t.dwell_seconds[i] / static_cast<double>(n - 1));
    generator(i, i) = -1.0 / t.dwell_seconds[i];
  }
  return (generator * dt).exp();
}

template <typename Reference>
void expect_same(const ImmEstimate& e, const Reference& reference, int k) {
  const int modes = reference.num_modes();
  for (int j = 0; j < modes; ++j) {
    ASSERT_NEAR(e.mode_probabilities[j], reference.mode_probabilities()[j], 1e-10) << "step " << k << " mode " << j;
    ASSERT_TRUE(e.mode_states[j].isApprox(reference.mode_state(j), 1e-10) ||
                (e.mode_states[j] - reference.mode_state(j)).norm() < 1e-10)
        << "step " << k << " mode " << j << ": " << e.mode_states[j].transpose() << " vs "
        << reference.mode_state(j).transpose();
    ASSERT_LT((e.mode_covariances[j] - reference.mode_covariance(j)).cwiseAbs().maxCoeff(), 1e-10)
        << "step " << k << " mode " << j;
    if (e.status == StepStatus::kUpdated) {
      ASSERT_NEAR(e.log_likelihoods[j], reference.log_likelihood(j), 1e-9) << "step " << k << " mode " << j;
    }
  }
  Eigen::VectorXd difference = e.state - reference.state();
  for (int d = 0; d < difference.size(); ++d) difference[d] = sdk::wrap_angle(difference[d] + 0.0);
  ASSERT_LT(difference.cwiseAbs().maxCoeff(), 1e-10) << "step " << k;
  ASSERT_LT((e.covariance - reference.covariance()).cwiseAbs().maxCoeff(), 1e-10) << "step " << k;
}

// Three linear terrain modes, [V, omega] measured, V missing on some rows.
struct LtcCase {
  BankBuilder builder;
  std::vector<skidimm_test::LtcReferenceModel> models;
  LtcCase() {
    builder.states = {"V", "omega"};
    builder.angles = {false, false};
    builder.inputs = {"phi_dot_L", "phi_dot_R"};
    Eigen::Matrix2d a1, a2, a3, b1;
    a1 << -5, 0, 0, -4;
    a2 << -3, 0.1, 0, -2.5;
    a3 << -2, 0, -0.2, -2;
    b1 << 0.4, 0.4, -0.8, 0.8;
    for (const auto& [a, b] : {std::pair<Eigen::Matrix2d, Eigen::Matrix2d>{a1, b1}, {a2, 0.6 * b1}, {a3, 0.4 * b1}}) {
      builder.models.push_back(skidimm_test::make_ltc(a, b));
      models.push_back(skidimm_test::LtcReferenceModel{a, b});
    }
    builder.q = {Eigen::Matrix2d::Identity() * 0.01, Eigen::Vector2d(0.02, 0.03).asDiagonal(),
                 Eigen::Matrix2d::Identity() * 0.05};
    builder.r.resize(2, 2);
    builder.r << 0.0025, 0.0004, 0.0004, 0.001;
    builder.mu0 = vec({0.5, 0.3, 0.2});
  }
};

void run_ltc_against_reference(Form form, ImmKernelChoice choice) {
  LtcCase c;
  Bank bank = c.builder.build();
  set_form(form, &c.builder, &bank);
  const TransitionConfig transition = bank.config.transition;
  std::vector<Eigen::Matrix2d> q;
  for (const Eigen::MatrixXd& m : c.builder.q) q.push_back(m);
  skidimm_test::ReferenceImm<skidimm_test::LtcReferenceModel, 2> reference(
      c.models, q, Eigen::Matrix2d::Identity(), c.builder.r, {false, false}, Eigen::Vector2d::Zero(),
      Eigen::Matrix2d::Identity(), c.builder.mu0, 1e-9);
  Imm imm(std::move(bank), choice);
  ASSERT_EQ(imm.uses_fixed_size_kernel(), choice == ImmKernelChoice::kFastest);
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 1.0);
  double t = 0.0, last_t = 0.0;
  for (int k = 0; k < 600; ++k) {
    const double u0 = noise(rng), z0 = noise(rng), z1 = noise(rng);  // in this order, whatever the compiler
    const Eigen::Vector2d u(3.0 + u0, 4.0 + 2.0 * std::sin(0.05 * k));
    Eigen::Vector2d z(0.5 + 0.3 * std::sin(0.02 * k) + 0.05 * z0, 0.2 * std::cos(0.03 * k) + 0.03 * z1);
    if (k % 7 == 3) z[0] = kNaN;
    if (k % 11 == 5) z.setConstant(kNaN);
    const ImmEstimate& e = imm.step(t, u, z);
    reference.step(t, u, z, reference_transition(transition, t - last_t));
    expect_same(e, reference, k);
    if (::testing::Test::HasFatalFailure()) return;
    last_t = t;
    t += 0.02 * (1.0 + 0.3 * std::sin(0.37 * k));  // irregular sampling
  }
}

TEST(Imm, TwoStatesMatchAHandWrittenFixedSizeImmForEveryTransitionForm) {
  for (Form form : {Form::kPerStep, Form::kEqualDwell, Form::kPerModeDwell}) {
    SCOPED_TRACE(static_cast<int>(form));
    run_ltc_against_reference(form, ImmKernelChoice::kFastest);
    run_ltc_against_reference(form, ImmKernelChoice::kDynamic);
  }
}

// Four kinematic slip modes turning in circles: the heading crosses +-pi
// again and again; a compass every row (an angle measured alone), GPS every
// fifth.
void run_stc_against_reference(Form form, ImmKernelChoice choice) {
  BankBuilder b;
  b.states = {"X", "Y", "theta"};
  b.angles = {false, false, true};
  b.inputs = {"phi_dot_L", "phi_dot_R"};
  std::vector<skidimm_test::StcReferenceModel> models;
  const double ks[] = {1.0, 0.9, 0.8, 0.95}, ms[] = {0.55, 0.5, 0.6, 0.45};
  for (int j = 0; j < 4; ++j) {
    sdk::ParameterSet p;
    p.set_scalar("k", ks[j]);
    p.set_scalar("m", ms[j]);
    p.set_scalar("r", 0.165);
    p.set_scalar("b", 0.555);
    std::string error;
    b.models.push_back(std::shared_ptr<sdk::MotionModel>(plugins::StcKinematicModel::Create(p, &error).release()));
    models.push_back(skidimm_test::StcReferenceModel{ks[j], ms[j], 0.165, 0.555});
  }
  b.q = {Eigen::Vector3d(1e-3, 2e-3, 4e-3).asDiagonal()};
  b.r = Eigen::Vector3d(0.03 * 0.03, 0.03 * 0.03, 0.02 * 0.02).asDiagonal();
  b.x0 = vec({0.0, 0.0, 3.0});
  b.p0 = Eigen::Vector3d(0.01, 0.01, 0.01).asDiagonal();
  Bank bank = b.build();
  set_form(form, &b, &bank);
  const TransitionConfig transition = bank.config.transition;
  skidimm_test::ReferenceImm<skidimm_test::StcReferenceModel, 3> reference(
      models, {b.q[0], b.q[0], b.q[0], b.q[0]}, Eigen::Matrix3d::Identity(), b.r, {false, false, true},
      Eigen::Vector3d(0.0, 0.0, 3.0), b.p0, Eigen::Vector4d::Constant(0.25), 1e-9);
  Imm imm(std::move(bank), choice);
  std::mt19937 rng(9);
  std::normal_distribution<double> noise(0.0, 1.0);
  Eigen::Vector3d truth(0.0, 0.0, 3.0);
  double t = 0.0, last_t = 0.0;
  int crossings = 0;
  for (int k = 0; k < 1000; ++k) {
    const Eigen::Vector2d u(2.0, 12.0 + std::sin(0.01 * k));  // turning left, about 1.5 rad/s
    const double n0 = noise(rng), n1 = noise(rng), n2 = noise(rng);  // in this order, whatever the compiler
    Eigen::Vector3d z(truth[0] + 0.03 * n0, truth[1] + 0.03 * n1, sdk::wrap_angle(truth[2] + 0.02 * n2));
    if (k % 5 != 0) z[0] = z[1] = kNaN;
    const ImmEstimate& e = imm.step(t, u, z);
    reference.step(t, u, z, reference_transition(transition, t - last_t));
    expect_same(e, reference, k);
    if (::testing::Test::HasFatalFailure()) return;
    const double dt = 0.02 * (1.0 + 0.3 * std::sin(0.37 * k));
    Eigen::Vector3d next;
    Eigen::Matrix3d f;
    models[1].predict(truth, u, dt, &next, &f);
    crossings += std::abs(next[2] - truth[2]) > 3.0;
    truth = next;
    last_t = t;
    t += dt;
  }
  EXPECT_GE(crossings, 4) << "the heading must cross the seam";
}

TEST(Imm, ThreeStatesWithAnAngleMatchAHandWrittenFixedSizeImmForEveryTransitionForm) {
  for (Form form : {Form::kPerStep, Form::kEqualDwell, Form::kPerModeDwell}) {
    SCOPED_TRACE(static_cast<int>(form));
    run_stc_against_reference(form, ImmKernelChoice::kFastest);
    run_stc_against_reference(form, ImmKernelChoice::kDynamic);
  }
}

// Every fixed size the kernels cover (states and measurements 1 to 4; up to
// 12 states with any measurement, more rows than states included; 13 states
// is dynamic either way): the fixed-size kernel and the dynamic one agree, as
// the references above.
// Runs a bank of n states and m measurement rows on the fixed-size and the
// dynamic kernel for `steps` steps and checks they agree within `tolerance`
// (scaled as below).
// unknown_inflation > 0: with an unknown hypothesis (enter 0.05, leave 0.2).
void ExpectKernelsAgree(double likelihood_dof, int steps, double tolerance, double rho = 0.0,
                        double unknown_inflation = 0.0) {
  for (int n : {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13}) {
    for (int m = 1; m <= n + 2; m += (n <= 5 || m >= n - 1 ? 1 : n - 2)) {
      // A build with the bundled shapes only has nothing to compare for the
      // others (both would run the dynamic kernel); 13 states still checks
      // that a bank past every fixed shape runs the dynamic one.
      if (n <= kMaxFixedStates && !internal::has_fixed_size_kernel(n, m)) continue;
      SCOPED_TRACE("states " + std::to_string(n) + ", measurements " + std::to_string(m));
      BankBuilder b;
      b.states.clear();
      b.angles.assign(static_cast<std::size_t>(n), false);
      for (int i = 0; i < n; ++i) b.states.push_back("x" + std::to_string(i));
      b.angles[static_cast<std::size_t>(n - 1)] = true;  // the last state is a heading
      b.inputs = {"u"};
      // n-state linear model: x' = A x + B u with a coupled A, per mode.
      class Linear : public sdk::MotionModel {
       public:
        Linear(int n, double scale) : a_(Eigen::MatrixXd::Identity(n, n) * -scale), names_(n, "x") {
          for (int i = 0; i + 1 < n; ++i) a_(i, i + 1) = 0.1 * scale;
        }
        int state_dim() const noexcept override { return static_cast<int>(a_.rows()); }
        int input_dim() const noexcept override { return 1; }
        const std::vector<std::string>& state_names() const noexcept override { return names_; }
        const std::vector<std::string>& input_names() const noexcept override { return inputs_; }
        bool is_angle(int i) const noexcept override { return i == a_.rows() - 1; }
        const std::vector<sdk::ParameterInfo>& parameter_info() const noexcept override { return info_; }
        void get_parameters(Eigen::Ref<Eigen::VectorXd>) const noexcept override {}
        bool set_parameters(const Eigen::Ref<const Eigen::VectorXd>&, std::string*) noexcept override { return true; }
        bool predict(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
                     Eigen::Ref<Eigen::VectorXd> next) const noexcept override {
          next = x + (a_ * x + Eigen::VectorXd::Constant(x.size(), u[0])) * dt;
          next[next.size() - 1] = sdk::wrap_angle(next[next.size() - 1]);
          return true;
        }
        bool jacobian(const Eigen::Ref<const Eigen::VectorXd>&, const Eigen::Ref<const Eigen::VectorXd>&, double dt,
                      Eigen::Ref<Eigen::MatrixXd> f) const noexcept override {
          f = Eigen::MatrixXd::Identity(a_.rows(), a_.rows()) + a_ * dt;
          return true;
        }
        bool has_analytic_jacobian() const noexcept override { return true; }

       private:
        Eigen::MatrixXd a_;
        std::vector<std::string> names_, inputs_{"u"};
        std::vector<sdk::ParameterInfo> info_;
      };
      for (int j = 0; j < 3; ++j) b.models.push_back(std::make_shared<Linear>(n, 1.0 + j));
      b.q = {Eigen::MatrixXd::Identity(n, n) * 0.01};
      // Row a measures state a % n; rows past n a combination of two. The row
      // measuring the heading alone is an angle.
      b.h = Eigen::MatrixXd::Zero(m, n);
      for (int a = 0; a < m; ++a) b.h(a, a % n) = 1.0;
      for (int a = n; a < m; ++a) b.h(a, (a + 1) % n) += 0.5;
      b.r = Eigen::MatrixXd::Identity(m, m) * 0.01;
      b.r(0, m - 1) = b.r(m - 1, 0) = m > 1 ? 0.002 : 0.01;
      b.x0 = Eigen::VectorXd::Constant(n, 3.0);
      Bank bank = b.build();
      bank.config.likelihood_dof = likelihood_dof;
      bank.config.unknown = UnknownHypothesisConfig{unknown_inflation, unknown_inflation > 0.0 ? 0.05 : 0.0, 0.2};
      for (int j = 0; j < 3; ++j)
        bank.config.modes[static_cast<std::size_t>(j)].residual_correlation = rho / (1 - 2 * j);
      bank.config.measurement.is_angle.assign(static_cast<std::size_t>(m), false);
      if (n - 1 < m) bank.config.measurement.is_angle[static_cast<std::size_t>(n - 1)] = true;
      bank.config.transition.kind = TransitionConfig::Kind::kDwellTimes;
      bank.config.transition.dwell_seconds = vec({1.0, 2.0, 4.0});
      Imm fixed(bank, ImmKernelChoice::kFastest), dynamic(bank, ImmKernelChoice::kDynamic);
      EXPECT_EQ(fixed.uses_fixed_size_kernel(), n <= kMaxFixedStates);
      std::mt19937 rng(1);
      std::normal_distribution<double> noise(0.0, 1.0);
      double largest_log_likelihood = 0.0;
      for (int k = 0; k < steps; ++k) {
        const double t = 0.05 * k + 0.01 * std::sin(k);
        Eigen::VectorXd z(m);
        for (int a = 0; a < m; ++a) z[a] = sdk::wrap_angle(3.0 + 0.5 * std::sin(0.1 * k + a) + 0.1 * noise(rng));
        if (k % 4 == 1) z[0] = kNaN;
        if (k % 9 == 2) z.setConstant(kNaN);
        const Eigen::VectorXd u = vec({std::sin(0.2 * k)});
        const ImmEstimate& a = fixed.step(t, u, z);
        const ImmEstimate& d = dynamic.step(t, u, z);
        ASSERT_EQ(a.status, d.status) << "step " << k;
        // The probabilities carry the likelihoods' round-off, relative to their
        // size (thousands when many rows miss the model by far), and the
        // mixed states and covariances carry the probabilities'. Rows that
        // measure sums of states, one with noise correlated to a state's row,
        // make S ill-conditioned (a condition number near 1e5 at 12 states):
        // the two kernels' round-off then differs by that times eps.
        for (int j = 0; j < 3; ++j) {
          if (std::isfinite(d.log_likelihoods[j])) {
            largest_log_likelihood = std::max(largest_log_likelihood, std::abs(d.log_likelihoods[j]));
          }
        }
        // From 5 states or rows the fixed kernel updates P as P- - W W', the
        // dynamic one in Joseph form: their round-off differs by more than two
        // orderings of one form's (about twice as much at 8 states and rows,
        // where a mode misses by far and the mixing amplifies it most).
        const bool difference_form = n <= kMaxFixedStates && (n > 4 || m > 4);
        const double conditioning = (m > n ? 100.0 : 1.0) * (difference_form ? 4.0 : 1.0);
        const double bound = conditioning * tolerance * (1.0 + 0.01 * largest_log_likelihood);
        ASSERT_LT((a.mode_probabilities - d.mode_probabilities).cwiseAbs().maxCoeff(), bound) << "step " << k;
        ASSERT_NEAR(a.unknown_probability, d.unknown_probability, bound) << "step " << k;
        for (int j = 0; j < 3; ++j) {
          const double scale = std::max(1.0, d.mode_states[j].cwiseAbs().maxCoeff());
          ASSERT_LT((a.mode_states[j] - d.mode_states[j]).cwiseAbs().maxCoeff(), bound * scale) << "step " << k;
          ASSERT_LT((a.mode_covariances[j] - d.mode_covariances[j]).cwiseAbs().maxCoeff(), bound * scale * scale)
              << "step " << k;
          if (a.status == StepStatus::kUpdated) {
            ASSERT_NEAR(a.log_likelihoods[j], d.log_likelihoods[j],
                        conditioning * tolerance * std::max(1.0, std::abs(d.log_likelihoods[j])))
                << "step " << k;
          }
        }
        const double scale = std::max(1.0, d.state.cwiseAbs().maxCoeff());
        ASSERT_LT((a.covariance - d.covariance).cwiseAbs().maxCoeff(), bound * scale * scale) << "step " << k;
      }
    }
  }
}

// Under the sanitizers a fifth of the steps: every kernel's code runs in the
// first of them, and the Release suite runs them all.
TEST(Imm, FixedSizeKernelsAgreeWithTheDynamicOneAtEverySize) {
  ExpectKernelsAgree(0.0, SKIDIMM_SANITIZED ? 60 : 300, 1e-10);
}

// The Student-t score's constant depends on how many rows a step measures
// (steps with a row missing, steps with none). Its probabilities stay away
// from 0 and 1, so the mixing carries the kernels' different round-off
// further from step to step: fewer steps, for the same bound.
TEST(Imm, FixedSizeKernelsAgreeWithTheDynamicOneWithAStudentTLikelihood) { ExpectKernelsAgree(3.0, 30, 1e-8); }

// Correlated innovations (rho 0.7, 0.7 and -0.7): each kernel whitens the same
// rows in the same order, across steps with a row missing (the memory
// restarts) and steps with none (the memory ages a step).
TEST(Imm, FixedSizeKernelsAgreeWithTheDynamicOneWithCorrelatedInnovations) {
  ExpectKernelsAgree(0.0, SKIDIMM_SANITIZED ? 20 : 60, 1e-8, 0.7);
}

// The unknown hypothesis scores each mode's innovation under an inflated
// covariance: the same in every kernel.
TEST(Imm, FixedSizeKernelsAgreeWithTheDynamicOneWithAnUnknownHypothesis) {
  ExpectKernelsAgree(0.0, SKIDIMM_SANITIZED ? 20 : 60, 1e-8, 0.0, 4.0);
}

// Before the first measurement every mode has its prior probability, and the
// most likely mode is decided by how the chain's round-off falls (docs/results.md
// counts those changes). For per-step matrices and equal dwell times, the IMM
// still computes c = P' mu with the same dense product, bit for bit, so the
// published results do not move.
TEST(Imm, PredictedProbabilitiesAreTheDenseProductBitForBit) {
  for (bool dwell : {false, true}) {
    BankBuilder b;
    b.states = {"V", "omega"};
    b.angles = {false, false};
    b.inputs = {"phi_dot_L", "phi_dot_R"};
    Eigen::Matrix2d input;
    input << 0.4, 0.4, -0.8, 0.8;
    for (int j = 0; j < 16; ++j) b.models.push_back(skidimm_test::make_ltc(-Eigen::Matrix2d::Identity(), input));
    b.q = {Eigen::Matrix2d::Identity() * 0.01};
    b.r = Eigen::Matrix2d::Identity() * 0.01;
    Bank bank = b.build();
    if (dwell) {
      bank.config.transition.kind = TransitionConfig::Kind::kDwellTimes;
      bank.config.transition.dwell_seconds = Eigen::VectorXd::Constant(16, 20.0);
    }
    ModeTransition chain = ModeTransition::from_config(bank.config.transition, 16);
    Imm imm(std::move(bank));
    Eigen::VectorXd mu = Eigen::VectorXd::Constant(16, 1.0 / 16.0);
    double t = 0.0;
    for (int k = 0; k < 20; ++k) {
      const double dt = 0.0185 + 0.004 * std::sin(k);
      t += k == 0 ? 0.0 : dt;
      const ImmEstimate& e = imm.step(t, Eigen::Vector2d(1.0, 2.0), Eigen::Vector2d(kNaN, kNaN));
      if (k == 0) continue;
      // What the IMM did before its fixed-size kernels, written out.
      const Eigen::VectorXd c = chain.matrix(dt).transpose() * mu;
      Eigen::VectorXd expected(16);
      const double largest = c.array().log().maxCoeff();
      for (int j = 0; j < 16; ++j) expected[j] = std::exp(std::log(c[j]) - largest);
      expected /= expected.sum();
      expected = expected.cwiseMax(1e-9);
      expected /= expected.sum();
      ASSERT_EQ(e.mode_probabilities, expected) << "step " << k;
      Eigen::Index first = 0;
      expected.maxCoeff(&first);
      ASSERT_EQ(e.most_likely_mode, first);
      mu = expected;
    }
  }
}

TEST(ImmDeathTest, WrongInputSizeIsAProgrammerError) {
  Imm imm(two_mode_scalar_bank().build());
  EXPECT_DEATH(imm.step(0.0, vec({1.0, 2.0}), vec({0.6})), "input vector size differs");
}

// What correlated innovations do to evidence, on the measured output y alone
// (its innovation y - gain_j u does not depend on the state, so each mode's
// whitened innovation is exactly (y - gain_j u) / 0.2): u = 1, the modes
// predict 0.5 and 1, d = 2.5 standard deviations apart, rho = 0.8 for both.
// Mode 0 is right for ten steps, with a bump of b = 1.5 common to both modes
// at step 5, then mode 1 is right. Per step, log Lambda_0 - log Lambda_1
// (docs/engine.md, "Correlated innovations"):
//   no memory (step 0):         d^2 / 2
//   a persistent offset:        d^2 / 2 (1 - rho) / (1 + rho), the likelihood weight w = 1/9's share
//   the bump, over two steps:   -b d (1 - rho) / (1 + rho), also the weight's share of the Gaussian's -b d
//   the change (step 10):       -d^2 / 2, the whole Gaussian evidence at once
TEST(Imm, CorrelatedInnovationsCountAnOffsetLikeTheWeightAndAChangeAtOnce) {
  const double rho = 0.8, d = 2.5, b = 1.5, w = (1.0 - rho) / (1.0 + rho);
  Bank bank = scalar_bank_with_output();
  for (ModeConfig& mode : bank.config.modes) mode.residual_correlation = rho;
  Bank weighted = scalar_bank_with_output();
  weighted.config.likelihood_weight = w;
  Imm imm(std::move(bank)), tempered(std::move(weighted));
  double bump = 0.0, gaussian_before_bump = 0.0, gaussian_bump = 0.0;
  for (int k = 0; k < 14; ++k) {
    const double y = (k < 10 ? 0.5 : 1.0) + (k == 5 ? 0.2 * b : 0.0);
    const ImmEstimate& e = imm.step(0.1 * k, vec({1.0}), vec({kNaN, y}));
    const ImmEstimate& g = tempered.step(0.1 * k, vec({1.0}), vec({kNaN, y}));
    const double steady = 0.5 * d * d * w;
    const double expected = k == 0    ? 0.5 * d * d
                            : k == 5  ? steady - b * d / (1.0 + rho)
                            : k == 6  ? steady + rho * b * d / (1.0 + rho)
                            : k == 10 ? -0.5 * d * d
                            : k < 10  ? steady
                                      : -steady;
    EXPECT_NEAR(e.log_likelihoods[0] - e.log_likelihoods[1], expected, 1e-12) << "step " << k;
    if (k == 10) {
      // The tempered IMM moves by w of the Gaussian's evidence; this one by all of it.
      EXPECT_NEAR(w * (g.log_likelihoods[0] - g.log_likelihoods[1]), -0.5 * d * d * w, 1e-12);
      EXPECT_GT(e.mode_probabilities[1], 0.5);
      EXPECT_LT(g.mode_probabilities[1], 0.5);
    }
    // The bump's effect: over steps 5 and 6 here, at step 5 in the Gaussian.
    if (k == 5 || k == 6) bump += e.log_likelihoods[0] - e.log_likelihoods[1] - steady;
    if (k == 4) gaussian_before_bump = g.log_likelihoods[0] - g.log_likelihoods[1];
    if (k == 5) gaussian_bump = g.log_likelihoods[0] - g.log_likelihoods[1] - gaussian_before_bump;
  }
  EXPECT_NEAR(gaussian_bump, -b * d, 1e-12);
  EXPECT_NEAR(bump, w * gaussian_bump, 1e-12);  // as the weight tempers it
}

// Multi-rate steps: the memory holds one set of measured rows. A step that
// measures another set is scored by the marginal (Gaussian) density and
// starts a new memory; a step that measures nothing ages it, so the next is
// conditioned with rho^2. rho = 0.8, u = 1, each mode's y innovation whitened
// by sqrt(R_y) = 0.2.
TEST(Imm, CorrelatedInnovationsAcrossStepsMeasuringOtherRowsOrNothing) {
  const double rho = 0.8, log_2pi_r = std::log(2.0 * M_PI * 0.04);
  for (const ImmKernelChoice choice : {ImmKernelChoice::kFastest, ImmKernelChoice::kDynamic}) {
    Bank bank = scalar_bank_with_output();
    for (ModeConfig& mode : bank.config.modes) mode.residual_correlation = rho;
    Imm imm(std::move(bank), choice);
    const double gain[2] = {0.5, 1.0};
    auto whitened = [&](double y, int j) { return (y - gain[j]) / 0.2; };
    imm.step(0.0, vec({1.0}), vec({0.6, 0.55}));                          // x and y
    const ImmEstimate& e1 = imm.step(0.1, vec({1.0}), vec({kNaN, 0.6}));  // y alone: another set
    for (int j = 0; j < 2; ++j) {
      EXPECT_NEAR(e1.log_likelihoods[j], -0.5 * (std::pow(whitened(0.6, j), 2) + log_2pi_r), 1e-12) << j;
    }
    const ImmEstimate& e2 = imm.step(0.2, vec({1.0}), vec({kNaN, 0.45}));  // conditioned on step 1
    for (int j = 0; j < 2; ++j) {
      const double v = whitened(0.45, j) - rho * whitened(0.6, j), spread = 1.0 - rho * rho;
      EXPECT_NEAR(e2.log_likelihoods[j], -0.5 * (v * v / spread + std::log(spread) + log_2pi_r), 1e-12) << j;
    }
    EXPECT_EQ(imm.step(0.3, vec({1.0}), vec({kNaN, kNaN})).status, StepStatus::kPredictOnly);
    const ImmEstimate& e4 = imm.step(0.4, vec({1.0}), vec({kNaN, 0.7}));  // two steps after step 2
    for (int j = 0; j < 2; ++j) {
      const double lag = rho * rho, v = whitened(0.7, j) - lag * whitened(0.45, j), spread = 1.0 - lag * lag;
      EXPECT_NEAR(e4.log_likelihoods[j], -0.5 * (v * v / spread + std::log(spread) + log_2pi_r), 1e-12) << j;
    }
  }
}

}  // namespace
}  // namespace skidimm
