// Banks, references and data for the benchmarks (docs/performance.md).
//
// Every timed filter sees a precomputed sequence of steps, so that what is
// timed is the filter and not the data, and the engine and the hand-written
// reference (tests/core/reference_imm.h) see exactly the same steps.
#ifndef SKIDIMM_TESTS_BENCHMARKS_BENCHMARK_DATA_H_
#define SKIDIMM_TESTS_BENCHMARKS_BENCHMARK_DATA_H_

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "core/reference_imm.h"
#include "core/test_banks.h"
#include "skidimm/config/bank.h"
#include "skidimm/engine/mode_transition.h"
#include "skidimm/sdk/angles.h"
#include "stc_kinematic/stc_kinematic_model.h"

namespace skidimm_bench {

// A sequence of filter steps; the benchmarks cycle through it (resetting the
// filter at the end, once in `size()` steps).
struct Steps {
  std::vector<double> t;
  std::vector<Eigen::VectorXd> u;
  std::vector<Eigen::VectorXd> z;
  int size() const { return static_cast<int>(t.size()); }
};

// Drives the bank's own models (the true mode changes every 500 steps) with
// smooth wheel speeds, and measures with the bank's R. dt is `dt` times
// (1 + jitter sin(0.37 k)): real logs are irregular. `measured_every`: rows
// between complete measurements (the rest have none).
inline Steps simulate_steps(const skidimm::Bank& bank, int count, double dt, double jitter, int measured_every = 1,
                            unsigned seed = 7) {
  const skidimm::BankConfig& c = bank.config;
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  const Eigen::VectorXd noise = c.measurement.r.diagonal().cwiseSqrt();
  Eigen::VectorXd x = c.initial_state, next(c.state_dim());
  Steps s;
  double t = 0.0;
  for (int k = 0; k < count; ++k) {
    Eigen::VectorXd u(c.input_dim());
    for (int i = 0; i < u.size(); ++i) u[i] = 4.0 + 2.0 * std::sin((0.7 - 0.2 * i) * t + 1.3 * i);
    Eigen::VectorXd z = c.measurement.h * x;
    for (int i = 0; i < z.size(); ++i) {
      z[i] += noise[i] * normal(rng);
      if (c.measurement.is_angle[static_cast<std::size_t>(i)]) z[i] = skidimm::sdk::wrap_angle(z[i]);
    }
    if (k % measured_every != 0) z.setConstant(std::numeric_limits<double>::quiet_NaN());
    s.t.push_back(t);
    s.u.push_back(u);
    s.z.push_back(z);
    const double step = dt * (1.0 + jitter * std::sin(0.37 * k));
    const int mode = (k / 500) % c.num_modes();
    bank.models[static_cast<std::size_t>(mode)]->predict(x, u, step, next);
    x = next;
    t += step;
  }
  return s;
}

inline std::filesystem::path source_dir() { return SKIDIMM_SOURCE_DIR; }

inline skidimm::Bank bundled_bank(const std::string& name) {
  return skidimm::Bank::load(source_dir() / "configs" / (name + ".yaml"), {SKIDIMM_PLUGIN_DIR});
}

// The transition matrix of a bank for a step of dt, for the reference.
inline Eigen::MatrixXd transition_matrix(const skidimm::BankConfig& c, double dt) {
  return skidimm::ModeTransition::from_config(c.transition, c.num_modes()).matrix(dt);
}

template <int M>
std::array<bool, M> measures_angle(const skidimm::BankConfig& c) {
  std::array<bool, M> a{};
  for (int i = 0; i < M; ++i) a[static_cast<std::size_t>(i)] = c.measurement.is_angle[static_cast<std::size_t>(i)];
  return a;
}

// The hand-written filter of an LTC bank (2 states, 2 measurements).
using LtcReference = skidimm_test::ReferenceImm<skidimm_test::LtcReferenceModel, 2>;
inline LtcReference ltc_reference(const skidimm::Bank& bank) {
  const skidimm::BankConfig& c = bank.config;
  std::vector<skidimm_test::LtcReferenceModel> models;
  std::vector<Eigen::Matrix2d> q;
  for (int j = 0; j < c.num_modes(); ++j) {
    Eigen::VectorXd p(8);
    bank.models[static_cast<std::size_t>(j)]->get_parameters(p);
    skidimm_test::LtcReferenceModel m;
    m.a << p[0], p[1], p[2], p[3];
    m.b << p[4], p[5], p[6], p[7];
    models.push_back(m);
    q.push_back(c.modes[static_cast<std::size_t>(j)].q_intensity);
  }
  return LtcReference(models, q, c.measurement.h, c.measurement.r, measures_angle<2>(c), c.initial_state,
                      c.initial_covariance, c.initial_mode_probabilities, c.mode_probability_floor);
}

// The hand-written filter of an STC bank (3 states, 3 measurements).
using StcReference = skidimm_test::ReferenceImm<skidimm_test::StcReferenceModel, 3>;
inline StcReference stc_reference(const skidimm::Bank& bank) {
  const skidimm::BankConfig& c = bank.config;
  std::vector<skidimm_test::StcReferenceModel> models;
  std::vector<Eigen::Matrix3d> q;
  for (int j = 0; j < c.num_modes(); ++j) {
    Eigen::VectorXd p(4);
    bank.models[static_cast<std::size_t>(j)]->get_parameters(p);
    skidimm_test::StcReferenceModel m;
    m.k = p[0];
    m.m = p[1];
    m.r = p[2];
    m.b = p[3];
    models.push_back(m);
    q.push_back(c.modes[static_cast<std::size_t>(j)].q_intensity);
  }
  return StcReference(models, q, c.measurement.h, c.measurement.r, measures_angle<3>(c), c.initial_state,
                      c.initial_covariance, c.initial_mode_probabilities, c.mode_probability_floor);
}

enum class TransitionForm { kPerStep, kUniformDwell, kPerModeDwell };

inline const char* form_name(TransitionForm f) {
  switch (f) {
    case TransitionForm::kPerStep:
      return "per_step";
    case TransitionForm::kUniformDwell:
      return "uniform_dwell";
    case TransitionForm::kPerModeDwell:
      return "per_mode_dwell";
  }
  return "?";
}

inline void set_transition(skidimm::BankConfig* c, TransitionForm form) {
  const int n = c->num_modes();
  switch (form) {
    case TransitionForm::kPerStep:
      c->transition.kind = skidimm::TransitionConfig::Kind::kStay;
      c->transition.stay = n > 1 ? 0.99 : 1.0;
      break;
    case TransitionForm::kUniformDwell:
      c->transition.kind = skidimm::TransitionConfig::Kind::kDwellTimes;
      c->transition.dwell_seconds = Eigen::VectorXd::Constant(n, 10.0);
      break;
    case TransitionForm::kPerModeDwell:
      c->transition.kind = skidimm::TransitionConfig::Kind::kDwellTimes;
      c->transition.dwell_seconds = Eigen::VectorXd::LinSpaced(n, 5.0, 20.0);
      break;
  }
}

// N linear terrain modes over [V, omega] (as the first benchmarks had).
inline skidimm::Bank ltc_bank(int num_modes, TransitionForm form) {
  skidimm_test::BankBuilder b;
  b.states = {"V", "omega"};
  b.angles = {false, false};
  b.inputs = {"phi_dot_L", "phi_dot_R"};
  Eigen::Matrix2d input;
  input << 0.4, 0.4, -0.8, 0.8;
  for (int j = 0; j < num_modes; ++j) {
    b.models.push_back(
        skidimm_test::make_ltc(Eigen::Matrix2d::Identity() * -(1.0 + 0.1 * j), (0.3 + 0.01 * j) * input));
  }
  b.q = {Eigen::Matrix2d::Identity() * 0.01};
  b.r = Eigen::Vector2d(0.05 * 0.05, 0.02 * 0.02).asDiagonal();
  skidimm::Bank bank = b.build();
  set_transition(&bank.config, form);
  return bank;
}

// N kinematic slip modes over [X, Y, theta], the heading an angle.
inline skidimm::Bank stc_bank(int num_modes, TransitionForm form) {
  skidimm_test::BankBuilder b;
  b.states = {"X", "Y", "theta"};
  b.angles = {false, false, true};
  b.inputs = {"phi_dot_L", "phi_dot_R"};
  for (int j = 0; j < num_modes; ++j) {
    skidimm::sdk::ParameterSet p;
    p.set_scalar("k", 0.6 + 0.4 * j / std::max(1, num_modes - 1));
    p.set_scalar("m", 0.5 + 0.45 * ((j * 7) % num_modes) / std::max(1, num_modes - 1));
    p.set_scalar("r", 0.165);
    p.set_scalar("b", 0.555);
    std::string error;
    b.models.push_back(
        std::shared_ptr<skidimm::sdk::MotionModel>(skidimm::plugins::StcKinematicModel::Create(p, &error).release()));
  }
  b.q = {Eigen::Vector3d(1e-3, 1e-3, 2e-3).asDiagonal()};
  b.r = Eigen::Matrix3d::Identity() * 0.03 * 0.03;
  skidimm::Bank bank = b.build();
  set_transition(&bank.config, form);
  return bank;
}

}  // namespace skidimm_bench

#endif  // SKIDIMM_TESTS_BENCHMARKS_BENCHMARK_DATA_H_
