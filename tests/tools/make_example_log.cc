// Writes the bundled example logs in configs/examples/.
//
//   skidimm_make_example_log ltc <bank.yaml> <out.csv> [seed]
//   skidimm_make_example_log stc <bank.yaml> <out.csv> [seed]
//
// Until the dynamic simulator lands (`skidimm simulate`), the example logs are
// generated from the bank's own models, integrated much finer than the filter
// steps (RK4 at 1 ms), driven through an outward spiral (the paper's
// evaluation maneuver) with a mode schedule and each mode's own process
// noise Q, and sampled at jittered,
// irregular times with noisy sensors. Because the truth uses the filter's
// model class, these logs show the engine working, not how well the models
// describe a real robot. Deterministic for a seed: mt19937_64 and our own
// Box-Muller, so the bytes do not depend on the standard library.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <iostream>
#include <random>
#include <string>
#include <vector>

#include "skidimm/bank.h"
#include "skidimm/errors.h"
#include "skidimm/log_io.h"

namespace {

using skidimm::BankConfig;
using skidimm::CsvWriter;

constexpr double kWheelRadius = 0.165;  // m
constexpr double kTrack = 0.555;        // m
constexpr double kPi = 3.14159265358979323846;

class Noise {
 public:
  explicit Noise(std::uint64_t seed) : engine_(seed) {}
  double uniform() { return (static_cast<double>(engine_() >> 11) + 0.5) * (1.0 / 9007199254740992.0); }
  double gaussian() {
    const double u1 = uniform();
    const double u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
  }

 private:
  std::mt19937_64 engine_;
};

// Outward spiral: forward speed V, turning radius growing at a constant rate.
void spiral_wheel_speeds(double t, double* left, double* right) {
  const double speed = 0.8;                // m/s
  const double radius = 0.6 + 0.12 * t;    // m, grows 0.12 m/s
  const double yaw_rate = speed / radius;  // rad/s
  *left = (speed - yaw_rate * kTrack / 2.0) / kWheelRadius;
  *right = (speed + yaw_rate * kTrack / 2.0) / kWheelRadius;
}

using Schedule = std::vector<std::pair<double, std::string>>;  // (start time, mode name)

// Index in the bank of the mode the schedule says is in effect at t.
int mode_at(const BankConfig& bank, const Schedule& schedule, double t, std::string* name) {
  std::size_t s = 0;
  while (s + 1 < schedule.size() && t >= schedule[s + 1].first) ++s;
  *name = schedule[s].second;
  const int j = bank.mode_index(*name);
  if (j < 0) throw std::runtime_error("bank has no mode '" + *name + "'");
  return j;
}

std::string fmt(double v) { return CsvWriter::format(std::round(v * 1e6) / 1e6); }

int make_ltc(const BankConfig& bank, const std::string& out_path, std::uint64_t seed) {
  // crushed concrete -> grass -> asphalt, 10 s each (the paper's fig. 4).
  const Schedule schedule = {{0.0, "crushed_concrete"}, {10.0, "grass"}, {20.0, "asphalt"}};
  const double duration = 30.0;
  Noise noise(seed);
  CsvWriter out(out_path, {"t", "phi_dot_L", "phi_dot_R", "V", "omega", "mode"});
  double v = 0.0, w = 0.0;
  double t = 0.0, next_sample = 0.0;
  const double h = 0.001;
  while (t <= duration + 1e-9) {
    std::string mode;
    const int j = mode_at(bank, schedule, t, &mode);
    const Eigen::MatrixXd& a = *bank.modes[j].params.find("A");
    const Eigen::MatrixXd& b = *bank.modes[j].params.find("B");
    double left, right;
    spiral_wheel_speeds(t, &left, &right);
    if (t >= next_sample) {
      out.write_row({fmt(t), fmt(left * (1.0 + 0.005 * noise.gaussian())),
                     fmt(right * (1.0 + 0.005 * noise.gaussian())), fmt(v + 0.05 * noise.gaussian()),
                     fmt(w + 0.03 * noise.gaussian()), mode});
      next_sample = t + 0.02 * (0.7 + 0.6 * noise.uniform());  // 50 Hz with +-30% jitter
    }
    auto f = [&](double vv, double ww, double* dv, double* dw) {
      *dv = a(0, 0) * vv + a(0, 1) * ww + b(0, 0) * left + b(0, 1) * right;
      *dw = a(1, 0) * vv + a(1, 1) * ww + b(1, 0) * left + b(1, 1) * right;
    };
    double k1v, k1w, k2v, k2w, k3v, k3w, k4v, k4w;
    f(v, w, &k1v, &k1w);
    f(v + 0.5 * h * k1v, w + 0.5 * h * k1w, &k2v, &k2w);
    f(v + 0.5 * h * k2v, w + 0.5 * h * k2w, &k3v, &k3w);
    f(v + h * k3v, w + h * k3w, &k4v, &k4w);
    // Process noise with the mode's own intensity Q, so the log is what the
    // bank's stochastic model says each terrain produces.
    const Eigen::MatrixXd& q = bank.modes[j].q_intensity;
    v += h / 6.0 * (k1v + 2 * k2v + 2 * k3v + k4v) + std::sqrt(q(0, 0) * h) * noise.gaussian();
    w += h / 6.0 * (k1w + 2 * k2w + 2 * k3w + k4w) + std::sqrt(q(1, 1) * h) * noise.gaussian();
    t += h;
  }
  out.commit();
  return 0;
}

int make_stc(const BankConfig& bank, const std::string& out_path, std::uint64_t seed) {
  // right two -> all four wheels slipping at 10 s (the paper's fig. 6).
  const Schedule schedule = {{0.0, "slip_FR_RR"}, {10.0, "slip_FL_FR_RL_RR"}};
  const double duration = 20.0;
  const double r = (*bank.shared.find("r"))(0, 0);
  const double track = (*bank.shared.find("b"))(0, 0);
  Noise noise(seed);
  CsvWriter out(out_path, {"t", "phi_dot_L", "phi_dot_R", "X", "Y", "theta", "mode"});
  double x = 0.0, y = 0.0, theta = 0.0;
  double t = 0.0, next_sample = 0.0, next_gps = 0.0;
  const double h = 0.001;
  while (t <= duration + 1e-9) {
    std::string mode;
    const int j = mode_at(bank, schedule, t, &mode);
    const double k = (*bank.modes[j].params.find("k"))(0, 0);
    const double m = (*bank.modes[j].params.find("m"))(0, 0);
    double left, right;
    spiral_wheel_speeds(t, &left, &right);
    if (t >= next_sample) {
      std::vector<std::string> row{fmt(t),
                                   fmt(left * (1.0 + 0.005 * noise.gaussian())),
                                   fmt(right * (1.0 + 0.005 * noise.gaussian())),
                                   "",
                                   "",
                                   "",
                                   mode};
      if (t >= next_gps) {  // GPS pose at 10 Hz inside the 50 Hz wheel log: other rows leave it empty
        row[3] = fmt(x + 0.03 * noise.gaussian());
        row[4] = fmt(y + 0.03 * noise.gaussian());
        double heading = theta + 0.03 * noise.gaussian();
        heading -= 2.0 * kPi * std::floor((heading + kPi) / (2.0 * kPi));
        row[5] = fmt(heading);
        next_gps = t + 0.1 - 1e-6;
      }
      out.write_row(row);
      next_sample = t + 0.02 * (0.7 + 0.6 * noise.uniform());
    }
    const double forward = r * (left + right) / 2.0;
    const double yaw_rate = r * (right - left) / track;
    // Exact integration of the unicycle over h at constant speed and yaw rate.
    const double dtheta = m * yaw_rate * h;
    const double chord = std::abs(dtheta) > 1e-12 ? 2.0 * std::sin(dtheta / 2.0) / dtheta : 1.0;
    const Eigen::MatrixXd& q = bank.modes[j].q_intensity;  // the mode's own process noise
    x += k * forward * h * chord * std::cos(theta + dtheta / 2.0) + std::sqrt(q(0, 0) * h) * noise.gaussian();
    y += k * forward * h * chord * std::sin(theta + dtheta / 2.0) + std::sqrt(q(1, 1) * h) * noise.gaussian();
    theta += dtheta + std::sqrt(q(2, 2) * h) * noise.gaussian();
    t += h;
  }
  out.commit();
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4 || (std::string(argv[1]) != "ltc" && std::string(argv[1]) != "stc")) {
    std::cerr << "usage: skidimm_make_example_log ltc|stc <bank.yaml> <out.csv> [seed]\n";
    return 2;
  }
  try {
    const BankConfig bank = skidimm::load_bank_config(argv[2]);
    const std::uint64_t seed = argc > 4 ? std::stoull(argv[4]) : 1;
    return std::string(argv[1]) == "ltc" ? make_ltc(bank, argv[3], seed) : make_stc(bank, argv[3], seed);
  } catch (const std::exception& e) {
    std::cerr << "skidimm_make_example_log: error: " << e.what() << "\n";
    return 1;
  }
}
