// Logs simulated from a model itself and the six-state linear_features
// banks, shared by the likelihood fitter's tests
// (tests/fitting/likelihood_fitter_test.cc) and its benchmark
// (tests/benchmarks/likelihood_benchmark.cc), so both run on the same data.
#ifndef SKIDIMM_TESTS_FITTING_SIMULATED_LOGS_H_
#define SKIDIMM_TESTS_FITTING_SIMULATED_LOGS_H_

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>
#include <string>

#include "skidimm/config/bank.h"
#include "skidimm/fitting/trajectory.h"
#include "skidimm/sdk/angles.h"
#include "skidimm/sdk/motion_model.h"

namespace skidimm_test {

// A log generated from `model` itself: x_{k+1} = predict(x_k, u_k, dt) + w,
// w ~ N(0, Q dt) (the default process_noise()), z_k = H x_k + v, v ~ N(0, R),
// with component c of row k kept only where measured(k, c). Angles wrapped.
inline skidimm::fitting::Trajectory simulate(const skidimm::sdk::MotionModel& model, const Eigen::MatrixXd& q,
                                             const Eigen::MatrixXd& h, const Eigen::MatrixXd& r, int rows, double dt,
                                             const std::function<Eigen::VectorXd(double)>& input, unsigned seed,
                                             const std::function<bool(int, int)>& measured = {}) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  const int n = model.state_dim();
  const Eigen::Index m = h.rows();
  const Eigen::MatrixXd process = Eigen::LLT<Eigen::MatrixXd>(q * dt).matrixL();
  const Eigen::MatrixXd sensor = Eigen::LLT<Eigen::MatrixXd>(r).matrixL();
  skidimm::fitting::Trajectory t;
  t.source = "simulated";
  t.u.resize(model.input_dim(), rows);
  t.z.resize(m, rows);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(n), next(n), w(n), v(m);
  for (int k = 0; k < rows; ++k) {
    const double time = k * dt;
    t.t.push_back(time);
    t.u.col(k) = input(time);
    for (Eigen::Index c = 0; c < m; ++c) v[c] = normal(rng);
    t.z.col(k) = h * x + sensor * v;
    for (Eigen::Index c = 0; c < m; ++c) {
      bool angle = false;
      for (int i = 0; i < n; ++i) angle = angle || (h(c, i) != 0.0 && model.is_angle(i));
      if (angle) t.z(c, k) = skidimm::sdk::wrap_angle(t.z(c, k));
      if (measured && !measured(k, static_cast<int>(c))) t.z(c, k) = std::nan("");
    }
    model.predict(x, t.u.col(k), dt, next);
    for (int i = 0; i < n; ++i) w[i] = normal(rng);
    x = next + process * w;
    for (int i = 0; i < n; ++i) {
      if (model.is_angle(i)) x[i] = skidimm::sdk::wrap_angle(x[i]);
    }
  }
  return t;
}

inline Eigen::VectorXd rich_wheel_speeds(double t) {
  return Eigen::Vector2d(4.0 + 3.0 * std::sin(0.9 * t) + std::sin(3.1 * t), 4.0 + 3.0 * std::cos(0.6 * t));
}

// A bank of one linear_features mode over six measured states, A and B as
// YAML; its file is written into `directory`.
inline skidimm::Bank six_state_bank(const std::string& a, const std::string& b, int inputs,
                                    const std::filesystem::path& directory) {
  std::string input_names;
  for (int j = 0; j < inputs; ++j) input_names += (j ? ", u" : "u") + std::to_string(j);
  const std::string yaml = "name: six\nstates: [s0, s1, s2, s3, s4, s5]\ninputs: [" + input_names +
                           "]\nmeasurement: {observe: [s0, s1, s2, s3, s4, s5], R: {std: [0.02, 0.02, 0.02, 0.02, "
                           "0.02, 0.02]}}\ntransition: {stay: 0.99}\ninitial: {covariance: {std: [1, 1, 1, 1, 1, "
                           "1]}}\nmodes:\n  - name: six\n    model: linear_features\n    params: {A: " +
                           a + ", B: " + b + (inputs > 1 ? ", c: [0.1, 0, -0.1, 0.2, 0, 0]" : "") +
                           "}\n    Q: {diagonal: [0.01, 0.01, 0.01, 0.01, 0.01, 0.01]}\n";
  std::ofstream(directory / "six.yaml", std::ios::binary) << yaml;
  return skidimm::Bank::load(directory / "six.yaml", {SKIDIMM_PLUGIN_DIR});
}

// 42 parameters: A diagonal (6), B 6 x 5 (30), c (6).
inline skidimm::Bank six_states_diagonal_a(const std::filesystem::path& directory) {
  std::string b = "[";
  for (int i = 0; i < 6; ++i)
    b += std::string(i ? ", " : "") + "[0.5, -0.2, 0.3, 0.1, " + std::to_string(0.1 * i) + "]";
  return six_state_bank("[-1, -2, -3, -1.5, -0.5, -4]", b + "]", 5, directory);
}

// 42 parameters: A full (36), B 6 x 1 (6).
inline skidimm::Bank six_states_full_a(const std::filesystem::path& directory) {
  return six_state_bank(
      "[[-1, 0.1, 0, 0, 0, 0], [0, -2, 0.2, 0, 0, 0], [0, 0, -3, 0.1, 0, 0], [0, 0, 0, -1.5, 0.3, 0], "
      "[0, 0, 0, 0, -0.5, 0.1], [0.1, 0, 0, 0, 0, -4]]",
      "[[0.5], [-0.2], [0.3], [0.1], [0.2], [0.4]]", 1, directory);
}

// `rows` rows at 50 Hz of smooth inputs, every state measured.
inline skidimm::fitting::Trajectory six_state_log(const skidimm::sdk::MotionModel& model, unsigned seed,
                                                  int rows = 10000) {
  auto inputs = [&model](double t) {
    Eigen::VectorXd u(model.input_dim());
    for (int j = 0; j < model.input_dim(); ++j)
      u[j] = std::sin((0.3 + 0.4 * j) * t) + 0.5 * std::cos((1.1 + 0.7 * j) * t);
    return u;
  };
  return simulate(model, Eigen::MatrixXd::Identity(6, 6) * 0.01, Eigen::MatrixXd::Identity(6, 6),
                  Eigen::MatrixXd::Identity(6, 6) * 4e-4, rows, 0.02, inputs, seed);
}

}  // namespace skidimm_test

#endif  // SKIDIMM_TESTS_FITTING_SIMULATED_LOGS_H_
