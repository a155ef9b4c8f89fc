#include "process_noise_search.h"

#include <algorithm>
#include <boost/math/tools/toms748_solve.hpp>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>

#include "skidimm/engine/ekf.h"
#include "skidimm/engine/measurement_model.h"
#include "skidimm/sdk/angles.h"

namespace skidimm {
namespace fitting {
namespace internal {

namespace {

constexpr double kLowest = 1e-10, kHighest = 1e3;
constexpr double kStart = 1e-3;  // every Q_ss before its first search

// Mean normalized innovation squared of the measurement of state s (the row
// of H that picks it alone: layout_of) of the mode's EKF with process-noise
// intensity `q`, over the logs. That row picks s, so its innovation variance
// is P(s, s) + R(c, c), read off without forming H P H'.
double mean_state_nis(const Bank& bank, const sdk::MotionModel& model, const MeasurementLayout& m, const ModeLogs& data,
                      const Eigen::MatrixXd& q, int s) {
  const BankConfig& config = bank.config;
  // The mode's own R where it has one: the noise its filter will assume.
  const Eigen::MatrixXd& r = config.measurement_noise(data.mode);
  const MeasurementModel measurement(config.measurement.h, r, config.measurement.is_angle);
  SelectedMeasurement selected = measurement.make_selection();
  const Eigen::Index rows = measurement.measurement_dim();
  const int c = m.state_row[static_cast<std::size_t>(s)];
  const double r_c = r(c, c);
  // Outputs depend on no state: the state's filter leaves them out.
  Eigen::VectorXd z(rows);
  const Eigen::VectorXd no_outputs = Eigen::VectorXd::Zero(rows);
  double sum = 0.0, count = 0.0;
  for (const Trajectory& t : data.logs) {
    ExtendedKalmanFilter filter(model, q, static_cast<int>(rows));
    int k = 0;
    while (k < t.size() && !fully_measured(m, t, k)) ++k;
    if (k >= t.size()) continue;
    filter.state() = measured_state(m, t, k);
    filter.covariance() = m.r_state;
    for (++k; k < t.size(); ++k) {
      if (!filter.predict(t.u.col(k - 1), t.t[k] - t.t[k - 1])) break;
      z = t.z.col(k);
      z.tail(static_cast<Eigen::Index>(m.outputs.size())).setConstant(std::numeric_limits<double>::quiet_NaN());
      measurement.select(z, &selected);
      if (selected.size == 0) continue;
      // The component's innovation and its variance before the update.
      for_each_error(m, t, k, filter.state(), no_outputs, [&](Eigen::Index component, double e) {
        if (component != c) return;
        sum += e * e / (filter.covariance()(s, s) + r_c);
        count += 1.0;
      });
      if (!filter.update(selected).ok) break;
    }
  }
  return sum / std::max(count, 1.0);
}

// The root-finder's function: log of a mean NIS. A filter that failed at its
// first step scores 0: below any target.
double log_of_mean_nis(double nis) { return std::log(std::isfinite(nis) ? std::max(nis, 1e-300) : 1e-300); }

// One state's search, given its log NIS as a function of log Q_ss: Q_ss, and
// whether it is at the floor or at the ceiling (still overconfident there).
template <typename LogNis>
double solve_state(const LogNis& log_nis, bool* at_floor, bool* at_ceiling) {
  const double low = std::log(kLowest), high = std::log(kHighest);
  const double at_low = log_nis(low);
  *at_floor = at_low <= 0.0;
  *at_ceiling = false;
  if (*at_floor) return kLowest;
  const double at_high = log_nis(high);
  *at_ceiling = at_high >= 0.0;
  if (*at_ceiling) return kHighest;
  // To within 2e-8 in log q, as fine as the 30 halvings of the bracket it replaced.
  const auto close_enough = [](double a, double b) { return std::abs(a - b) <= 2e-8; };
  std::uintmax_t iterations = 60;
  const auto root = boost::math::tools::toms748_solve(log_nis, low, high, at_low, at_high, close_enough, iterations);
  return std::exp(0.5 * (root.first + root.second));
}

// The two rounds over the states, each search running the mode's filter.
ConsistentProcessNoise two_rounds(const Bank& bank, const ModeLogs& data, const MeasurementLayout& m) {
  const sdk::MotionModel& model = *bank.models[static_cast<std::size_t>(data.mode)];
  const int n = bank.config.state_dim();
  Eigen::MatrixXd q = Eigen::MatrixXd::Identity(n, n) * kStart;
  ConsistentProcessNoise out;
  out.at_floor.assign(static_cast<std::size_t>(n), false);
  out.at_ceiling.assign(static_cast<std::size_t>(n), false);
  for (int round = 0; round < 2; ++round) {
    for (int s = 0; s < n; ++s) {
      const auto log_nis = [&](double log_q) {
        q(s, s) = std::exp(log_q);
        return log_of_mean_nis(mean_state_nis(bank, model, m, data, q, s));
      };
      bool at_floor = false, at_ceiling = false;
      q(s, s) = solve_state(log_nis, &at_floor, &at_ceiling);
      out.at_floor[static_cast<std::size_t>(s)] = at_floor;
      out.at_ceiling[static_cast<std::size_t>(s)] = at_ceiling;
    }
  }
  out.intensity = q.diagonal();
  return out;
}

// Every state's filter of a decoupled mode run on its own: each state's mean
// NIS at a diagonal intensity in one pass over the logs. The arithmetic is
// ExtendedKalmanFilter's on a diagonal P, to the bit: each of its products
// (ekf.cc) then adds exact zeros to the one term the diagonal leaves, and
// its Cholesky factor and solves reduce to a square root, two divisions of
// the innovation and two multiplications by the factor's reciprocal.
class DecoupledPass {
 public:
  DecoupledPass(const Bank& bank, const ModeLogs& data, const MeasurementLayout& m)
      : model_(*bank.models[static_cast<std::size_t>(data.mode)]),
        data_(data),
        m_(m),
        r_(bank.config.measurement_noise(data.mode)),
        n_(bank.config.state_dim()),
        row_state_(static_cast<std::size_t>(m.first_output_row), -1) {
    const MeasurementConfig& mc = bank.config.measurement;
    const MeasurementModel measurement(mc.h, r_, mc.is_angle);
    // The rows the filter updates with (outputs are left out): each must pick
    // a state of its own, with noise independent of the others'.
    std::vector<bool> picked(static_cast<std::size_t>(n_), false);
    possible_ = true;
    for (int row = 0; row < m.first_output_row; ++row) {
      const int s = measurement.picked_state(row);
      if (s < 0 || picked[static_cast<std::size_t>(s)]) possible_ = false;
      if (s >= 0) picked[static_cast<std::size_t>(s)] = true;
      row_state_[static_cast<std::size_t>(row)] = s;
      for (int other = 0; other < m.first_output_row; ++other) {
        if (other != row && r_(row, other) != 0.0) possible_ = false;
      }
    }
    for (int s = 0; s < n_; ++s) state_is_angle_.push_back(model_.is_angle(s));
    q_ = Eigen::MatrixXd::Zero(n_, n_);
    f_.resize(n_, n_);
    qd_.resize(n_, n_);
    next_.resize(n_);
    p_.resize(n_);
    sum_.resize(n_);
    count_.resize(n_);
  }

  bool possible() const { return possible_; }

  // Each state's mean NIS with Q = diag(q). False if some step is not
  // decoupled (a Jacobian or process noise with an entry off the diagonal)
  // or a filter fails, which the full filter handles (two_rounds()).
  bool run(const Eigen::VectorXd& q, Eigen::VectorXd* mean_nis) {
    q_.diagonal() = q;
    sum_.setZero();
    count_.setZero();
    for (const Trajectory& t : data_.logs) {
      if (!run_log(t)) return false;
    }
    *mean_nis = sum_.array() / count_.array().max(1.0);
    return true;
  }

 private:
  bool run_log(const Trajectory& t) {
    int k = 0;
    while (k < t.size() && !fully_measured(m_, t, k)) ++k;
    if (k >= t.size()) return true;
    x_ = measured_state(m_, t, k);
    p_ = m_.r_state.diagonal();
    for (++k; k < t.size(); ++k) {
      if (!predict(t.u.col(k - 1), t.t[k] - t.t[k - 1])) return false;
      bool measured = false;
      for (int row = 0; row < m_.first_output_row; ++row) measured = measured || std::isfinite(t.z(row, k));
      if (!measured) continue;
      // Each state's innovation and its variance before the update.
      for (int s = 0; s < n_; ++s) {
        const int c = m_.state_row[static_cast<std::size_t>(s)];
        const double z = t.z(c, k);
        if (!std::isfinite(z)) continue;
        double e = z - x_[s];
        if (m_.row_is_angle[static_cast<std::size_t>(c)]) e = sdk::wrap_angle(e);
        sum_[s] += e * e / (p_[s] + r_(c, c));
        count_[s] += 1.0;
      }
      if (!update(t, k)) return false;
    }
    return true;
  }

  bool predict(const Eigen::Ref<const Eigen::VectorXd>& u, double dt) {
    if (!model_.jacobian(x_, u, dt, f_) || !model_.process_noise(q_, x_, u, dt, qd_) ||
        !model_.predict(x_, u, dt, next_)) {
      return false;
    }
    for (int j = 0; j < n_; ++j) {
      for (int i = 0; i < n_; ++i) {
        if (i != j && (f_(i, j) != 0.0 || qd_(i, j) != 0.0)) return false;
      }
    }
    x_ = next_;
    wrap_angles();
    for (int s = 0; s < n_; ++s) {
      // A non-finite F(i, i) would make P(i, j) = F(i, i) 0 F(j, j) NaN.
      if (!std::isfinite(f_(s, s))) return false;
      p_[s] = (f_(s, s) * p_[s]) * f_(s, s);
      p_[s] += qd_(s, s);
    }
    return x_.allFinite() && p_.allFinite();
  }

  bool update(const Trajectory& t, int k) {
    // The innovation's log-likelihood must be finite, as the filter requires
    // (its NIS sums the rows in another order: a sum this close to overflow
    // goes to the full filter).
    double nis = 0.0;
    for (int row = 0; row < m_.first_output_row; ++row) {
      const double z = t.z(row, k);
      if (!std::isfinite(z)) continue;
      const int s = row_state_[static_cast<std::size_t>(row)];
      double nu = z - x_[s];
      if (m_.row_is_angle[static_cast<std::size_t>(row)]) nu = sdk::wrap_angle(nu);
      const double variance = p_[s] + r_(row, row);
      if (!(variance > 0.0)) return false;
      const double l = std::sqrt(variance);
      nis += nu * ((nu / l) / l);
      const double inverse = 1.0 / l;
      const double gain = (p_[s] * inverse) * inverse;
      x_[s] = x_[s] + gain * nu;
      const double keep = 1.0 - gain;
      p_[s] = (keep * p_[s]) * keep + (gain * r_(row, row)) * gain;
    }
    wrap_angles();
    return nis < 1e300 && x_.allFinite() && p_.allFinite();
  }

  void wrap_angles() {
    for (int s = 0; s < n_; ++s) {
      if (state_is_angle_[static_cast<std::size_t>(s)]) x_[s] = sdk::wrap_angle(x_[s]);
    }
  }

  const sdk::MotionModel& model_;
  const ModeLogs& data_;
  const MeasurementLayout& m_;
  const Eigen::MatrixXd& r_;
  const int n_;
  std::vector<int> row_state_;  // per measurement row before the outputs, the state it picks
  std::vector<bool> state_is_angle_;
  bool possible_ = false;
  // Workspace.
  Eigen::MatrixXd q_;
  Eigen::MatrixXd f_;
  Eigen::MatrixXd qd_;
  Eigen::VectorXd x_;
  Eigen::VectorXd next_;
  Eigen::VectorXd p_;  // the diagonal of P
  Eigen::VectorXd sum_;
  Eigen::VectorXd count_;
};

// Thrown by a replayed search when it asks for a value no pass has computed.
struct NotYetComputed {};

// The searches of a decoupled mode, all at once: each state's search is run
// from its start with the values computed so far, up to the first it lacks;
// one pass computes those of every state; repeat. TOMS 748 is deterministic,
// so each replay retraces the last and asks for exactly the next value the
// two rounds would. False (the two rounds must run) if the mode turns out
// not to be decoupled or a filter fails.
bool decoupled_searches(const Bank& bank, const ModeLogs& data, const MeasurementLayout& m,
                        ConsistentProcessNoise* out) {
  DecoupledPass pass(bank, data, m);
  if (!pass.possible()) return false;
  const int n = bank.config.state_dim();
  std::vector<std::map<double, double>> known(static_cast<std::size_t>(n));  // log Q_ss -> log NIS
  std::vector<bool> done(static_cast<std::size_t>(n), false);
  Eigen::VectorXd result(n), asked(n), mean_nis(n);
  out->at_floor.assign(static_cast<std::size_t>(n), false);
  out->at_ceiling.assign(static_cast<std::size_t>(n), false);
  while (true) {
    bool waiting = false;
    for (int s = 0; s < n; ++s) {
      const std::size_t si = static_cast<std::size_t>(s);
      if (done[si]) continue;
      const auto log_nis = [&](double log_q) {
        const auto found = known[si].find(log_q);
        if (found != known[si].end()) return found->second;
        asked[s] = log_q;
        throw NotYetComputed{};
      };
      try {
        bool at_floor = false, at_ceiling = false;
        result[s] = solve_state(log_nis, &at_floor, &at_ceiling);
        out->at_floor[si] = at_floor;
        out->at_ceiling[si] = at_ceiling;
        done[si] = true;
      } catch (const NotYetComputed&) {
        waiting = true;
      }
    }
    if (!waiting) break;
    // The states whose searches are done sit at their result (any value would do).
    Eigen::VectorXd q(n);
    for (int s = 0; s < n; ++s) q[s] = done[static_cast<std::size_t>(s)] ? result[s] : std::exp(asked[s]);
    if (!pass.run(q, &mean_nis)) return false;
    for (int s = 0; s < n; ++s) {
      const std::size_t si = static_cast<std::size_t>(s);
      if (!done[si]) known[si][asked[s]] = log_of_mean_nis(mean_nis[s]);
    }
  }
  // Independence, checked on the values the two rounds give the other states
  // while one is searched: their start and their result. For each bit of the
  // state index, the states with that bit set (then those without) are moved
  // to the start; every other state's NIS at its result must not change. Any
  // two states differ in some bit, so each is moved while the other is
  // watched. These passes also run every state's filter at both values, so
  // no filter of the two rounds can fail where these did not.
  Eigen::VectorXd at_results(n);
  if (!pass.run(result, &at_results)) return false;
  for (int bit = 1; bit < n; bit <<= 1) {
    for (const bool moved_has_bit : {true, false}) {
      Eigen::VectorXd q = result;
      for (int s = 0; s < n; ++s) {
        if (((s & bit) != 0) == moved_has_bit) q[s] = kStart;
      }
      if (!pass.run(q, &mean_nis)) return false;
      for (int s = 0; s < n; ++s) {
        if (((s & bit) != 0) != moved_has_bit && !(mean_nis[s] == at_results[s])) return false;
      }
    }
  }
  out->intensity = result;
  return true;
}

}  // namespace

ConsistentProcessNoise consistent_process_noise(const Bank& bank, const ModeLogs& data, const MeasurementLayout& m) {
  ConsistentProcessNoise out;
  if (decoupled_searches(bank, data, m, &out)) return out;
  return two_rounds(bank, data, m);
}

}  // namespace internal
}  // namespace fitting
}  // namespace skidimm
