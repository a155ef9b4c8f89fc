#include "skidimm/engine/mode_transition.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <string>

#include "check.h"
#include "skidimm/errors.h"

namespace skidimm {

namespace {

// Past this many expected jumps of the fastest mode in one step (max r dt),
// uniformisation needs too many terms: the eigenvectors take over.
constexpr double kMaxUniformisedRate = 50.0;
// A Taylor series of expm(Pi_c h) serves steps with ||Pi_c h|| up to this
// (h = dt from the identity, or dt - dt_a from an anchor): it then reaches
// 1e-18 in at most 13 terms.
constexpr double kMaxTaylorNorm = 0.1;
// Up to this ||Pi_c dt|| (dt = 10 ms against dwell times of 2 s or more),
// the series starts from the identity, at most 8 terms: no anchor, no N x N
// product. Past it, the anchor's product and a series in dt - dt_a, which
// carries less round-off than a long series from the identity.
constexpr double kMaxDirectTaylorNorm = 0.01;
// The series from the identity takes a few more terms than the one from an
// anchor, each O(N); it saves the anchor's N^2 product only from about this
// many modes on (at 4 modes it is the slower of the two).
constexpr Eigen::Index kMinDirectTaylorModes = 8;

using Packet = Eigen::internal::packet_traits<double>::type;
constexpr Eigen::Index kLanes = Eigen::internal::packet_traits<double>::size;

// a . b_w for W columns b_w of length n >= 2 kLanes at once, each summed
// exactly as Eigen sums one dot product of dynamic size (Redux.h, the
// linear vectorized traversal: two packets of running sums, their sum, one
// more packet if it fits, the packet's lanes, then the last elements one by
// one), so that the result is a.dot(b_w) bit for bit. What differs is that
// each packet of a is loaded once for the W columns.
template <int W>
void dot_products(const double* a, const double* const* b, Eigen::Index n, double* out) {
  using Eigen::internal::padd;
  using Eigen::internal::ploadu;
  using Eigen::internal::pmul;
  const Eigen::Index end2 = n / (2 * kLanes) * (2 * kLanes);
  const Eigen::Index end1 = n / kLanes * kLanes;
  Packet sum0[W], sum1[W];
  Packet a0 = ploadu<Packet>(a), a1 = ploadu<Packet>(a + kLanes);
  for (int w = 0; w < W; ++w) {
    sum0[w] = pmul(a0, ploadu<Packet>(b[w]));
    sum1[w] = pmul(a1, ploadu<Packet>(b[w] + kLanes));
  }
  for (Eigen::Index i = 2 * kLanes; i < end2; i += 2 * kLanes) {
    a0 = ploadu<Packet>(a + i);
    a1 = ploadu<Packet>(a + i + kLanes);
    for (int w = 0; w < W; ++w) {
      sum0[w] = padd(sum0[w], pmul(a0, ploadu<Packet>(b[w] + i)));
      sum1[w] = padd(sum1[w], pmul(a1, ploadu<Packet>(b[w] + i + kLanes)));
    }
  }
  for (int w = 0; w < W; ++w) sum0[w] = padd(sum0[w], sum1[w]);
  if (end1 > end2) {
    a0 = ploadu<Packet>(a + end2);
    for (int w = 0; w < W; ++w) sum0[w] = padd(sum0[w], pmul(a0, ploadu<Packet>(b[w] + end2)));
  }
  for (int w = 0; w < W; ++w) {
    double result = Eigen::internal::predux(sum0[w]);
    for (Eigen::Index i = end1; i < n; ++i) result = result + a[i] * b[w][i];
    out[w] = result;
  }
}

// The sum of x[0..n) exactly as Eigen's sum() of a dynamic-size column sums
// it (Redux.h, the linear vectorized traversal: from the first element
// aligned to a packet, two packets of running sums, their sum, one more
// packet if it fits, the packet's lanes; then the elements before the
// aligned start and after the last packet, one by one), without its
// dispatch, which at 3 or 4 modes costs more than the additions.
double eigen_sum(const double* x, Eigen::Index n) {
  using Eigen::internal::padd;
  using Eigen::internal::ploadu;
  if (n == 0) return 0.0;
  const Eigen::Index start = Eigen::internal::first_default_aligned(x, n);
  const Eigen::Index size2 = (n - start) / (2 * kLanes) * (2 * kLanes);
  const Eigen::Index size1 = (n - start) / kLanes * kLanes;
  if (size1 == 0) {
    double result = x[0];
    for (Eigen::Index i = 1; i < n; ++i) result = result + x[i];
    return result;
  }
  Packet sum0 = ploadu<Packet>(x + start);
  if (size1 > kLanes) {
    Packet sum1 = ploadu<Packet>(x + start + kLanes);
    for (Eigen::Index i = start + 2 * kLanes; i < start + size2; i += 2 * kLanes) {
      sum0 = padd(sum0, ploadu<Packet>(x + i));
      sum1 = padd(sum1, ploadu<Packet>(x + i + kLanes));
    }
    sum0 = padd(sum0, sum1);
    if (size1 > size2) sum0 = padd(sum0, ploadu<Packet>(x + start + size2));
  }
  double result = Eigen::internal::predux(sum0);
  for (Eigen::Index i = 0; i < start; ++i) result = result + x[i];
  for (Eigen::Index i = start + size1; i < n; ++i) result = result + x[i];
  return result;
}

// out = a' b for column-major a (N x N) and b (N x C), without Eigen's GEMM
// (which may take its blocking space from the heap for large N). From 16
// modes on, each entry is a.col(j).dot(b.col(c)) bit for bit, four columns
// of b at a time (dot_products).
void transpose_times(const Eigen::MatrixXd& a, const Eigen::Ref<const Eigen::MatrixXd>& b,
                     Eigen::Ref<Eigen::MatrixXd> out) {
  const Eigen::Index n = a.rows(), columns = b.cols();
  if (n < 16 || n < 2 * kLanes) {
    for (Eigen::Index c = 0; c < columns; ++c) {
      for (Eigen::Index j = 0; j < n; ++j) {
        double sum = 0.0;
        for (Eigen::Index i = 0; i < n; ++i) sum += a(i, j) * b(i, c);
        out(j, c) = sum;
      }
    }
    return;
  }
  for (Eigen::Index j = 0; j < n; ++j) {
    const double* column = a.col(j).data();
    Eigen::Index c = 0;
    for (; c + 4 <= columns; c += 4) {
      const double* bs[4] = {b.col(c).data(), b.col(c + 1).data(), b.col(c + 2).data(), b.col(c + 3).data()};
      double dots[4];
      dot_products<4>(column, bs, n, dots);
      for (int w = 0; w < 4; ++w) out(j, c + w) = dots[w];
    }
    for (; c < columns; ++c) {
      const double* bs[1] = {b.col(c).data()};
      dot_products<1>(column, bs, n, &out(j, c));
    }
  }
}

}  // namespace

ModeTransition ModeTransition::from_config(const TransitionConfig& config, int num_modes) {
  switch (config.kind) {
    case TransitionConfig::Kind::kMatrix:
      return per_step(config.matrix);
    case TransitionConfig::Kind::kStay:
      return per_step_stay(num_modes, config.stay);
    case TransitionConfig::Kind::kDwellTimes:
      return from_dwell_times(config.dwell_seconds);
  }
  return per_step_stay(num_modes, config.stay);
}

ModeTransition ModeTransition::per_step(const Eigen::MatrixXd& matrix) {
  SKIDIMM_CHECK(matrix.rows() == matrix.cols() && matrix.rows() > 0, "transition matrix must be square");
  ModeTransition t;
  t.matrix_ = matrix;
  t.generator_ = Eigen::MatrixXd::Zero(matrix.rows(), matrix.cols());
  return t;
}

ModeTransition ModeTransition::per_step_stay(int num_modes, double stay_probability) {
  SKIDIMM_CHECK(num_modes > 0, "a bank needs at least one mode");
  if (num_modes == 1) return per_step(Eigen::MatrixXd::Ones(1, 1));
  const double move = (1.0 - stay_probability) / (num_modes - 1);
  Eigen::MatrixXd m = Eigen::MatrixXd::Constant(num_modes, num_modes, move);
  m.diagonal().setConstant(stay_probability);
  return per_step(m);
}

ModeTransition ModeTransition::from_dwell_times(const Eigen::VectorXd& mean_dwell_seconds) {
  const Eigen::Index n = mean_dwell_seconds.size();
  SKIDIMM_CHECK(n > 0 && (mean_dwell_seconds.array() > 0.0).all(), "dwell times must be positive");
  ModeTransition t;
  t.generator_ = Eigen::MatrixXd::Zero(n, n);
  if (n > 1) {
    for (Eigen::Index i = 0; i < n; ++i) {
      const double rate = 1.0 / mean_dwell_seconds[i];
      t.generator_.row(i).setConstant(rate / static_cast<double>(n - 1));
      t.generator_(i, i) = -rate;
    }
  }
  t.max_rate_ = (-t.generator_.diagonal()).maxCoeff();
  t.matrix_ = Eigen::MatrixXd::Identity(n, n);
  const bool equal = (mean_dwell_seconds.array() == mean_dwell_seconds[0]).all();
  t.form_ = n == 1 || equal ? Form::kEqualRates : Form::kDwellTimes;
  if (t.form_ == Form::kEqualRates) return t;

  const double nn = static_cast<double>(n);
  t.rates_ = -t.generator_.diagonal();
  t.decay_ = t.rates_ * (nn / (nn - 1.0));
  t.spread_ = 1.0 / (nn - 1.0);
  for (Anchor& a : t.anchors_) a.p.resize(n, n);
  t.power_.resize(n, n);
  t.scratch_.resize(n, n);
  // Pi_c = R K with K = (1 1' - N I) / (N - 1) symmetric, so Pi_c is similar
  // to the symmetric R^1/2 K R^1/2 = (s s' - N R) / (N - 1), s = sqrt(r).
  t.sqrt_rates_ = t.rates_.cwiseSqrt();
  Eigen::MatrixXd symmetric = t.sqrt_rates_ * t.sqrt_rates_.transpose();
  symmetric.diagonal() -= nn * t.rates_;
  symmetric *= t.spread_;
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> solver(symmetric);
  SKIDIMM_CHECK(solver.info() == Eigen::Success, "eigendecomposition of the dwell-time generator failed");
  t.eigenvalues_ = solver.eigenvalues().cwiseMin(0.0);  // the chain's rates are <= 0; round-off may not be
  t.eigenvectors_ = solver.eigenvectors();
  // The stationary direction exactly: eigenvalue 0 (the largest; round-off
  // would make exp(L dt) drift from 1 over long gaps) with eigenvector
  // R^-1/2 1, normalised, so that P(dt) tends to 1 pi', pi_i = tau_i / sum tau.
  const Eigen::Index last = n - 1;
  t.eigenvalues_[last] = 0.0;
  t.eigenvectors_.col(last) = t.sqrt_rates_.cwiseInverse().normalized();
  t.eigenvectors_transposed_ = t.eigenvectors_.transpose();
  t.reserve_columns(1);
  return t;
}

void ModeTransition::reserve_columns(int columns) {
  const Eigen::Index n = matrix_.rows();
  if (term_.cols() >= columns && term_.rows() == n) return;
  term_.resize(n, columns);
  term2_.resize(n, columns);
  row_.resize(columns);
}

double ModeTransition::equal_rates_decay(double dt) const {
  // Equal rates r: the chain forgets its state at rate r n/(n-1), so
  // P = 1/n + (delta_ij - 1/n) exp(-r n dt / (n-1)).
  if (dt == decay_dt_) return decay_value_;
  const double nn = static_cast<double>(matrix_.rows());
  decay_value_ = std::exp(-max_rate_ * nn / (nn - 1.0) * dt);
  decay_dt_ = dt;
  return decay_value_;
}

const Eigen::MatrixXd& ModeTransition::matrix(double dt) {
  if (form_ == Form::kPerStep || dt == cached_dt_) return matrix_;
  cached_dt_ = dt;
  const Eigen::Index n = matrix_.rows();
  if (n == 1 || max_rate_ == 0.0 || dt <= 0.0) {
    matrix_.setIdentity();
    return matrix_;
  }
  if (form_ == Form::kEqualRates) {
    const double decay = equal_rates_decay(dt);
    matrix_.setConstant((1.0 - decay) / static_cast<double>(n));
    matrix_.diagonal().array() += decay;
    return matrix_;
  }
  if (n >= kMinDirectTaylorModes && 2.0 * max_rate_ * dt <= kMaxDirectTaylorNorm) {
    // P(dt) = expm(Pi_c dt), its series from the identity.
    matrix_.setIdentity();
    taylor_multiply(dt);
    return matrix_;
  }
  const int a = anchor_for(dt);
  if (a < 0) {
    // P = R^1/2 U exp(L dt) U' R^-1/2, formed in O(N^3): only past the
    // uniformisation threshold (a gap of many dwell times).
    power_ = eigenvectors_ * (eigenvalues_ * dt).array().exp().matrix().asDiagonal();
    for (Eigen::Index j = 0; j < n; ++j) {
      for (Eigen::Index i = 0; i < n; ++i) {
        matrix_(i, j) = sqrt_rates_[i] * power_.row(i).dot(eigenvectors_transposed_.col(j)) / sqrt_rates_[j];
      }
    }
    return matrix_;
  }
  // P(dt) = P(dt_a) expm(Pi_c delta).
  const double delta = dt - anchors_[static_cast<std::size_t>(a)].dt;
  matrix_ = anchors_[static_cast<std::size_t>(a)].p;
  if (delta != 0.0) taylor_multiply(delta);
  return matrix_;
}

void ModeTransition::taylor_multiply(double h) {
  // matrix_ expm(Pi_c h) = sum_k matrix_ (Pi_c h)^k / k!, each term from the
  // last by one structured product with Pi_c, O(N^2).
  power_ = matrix_;
  const int terms = taylor_terms(h);
  for (int k = 1; k <= terms; ++k) {
    times_generator(power_, &scratch_);
    power_ = scratch_ * (h / k);
    matrix_ += power_;
  }
}

int ModeTransition::taylor_terms(double h) const {
  // ||Pi_c h||^k / k! bounds the k-th term (the norm: the largest row sum of
  // |Pi_c|, 2 max r), for both x Pi_c and Pi_c' x.
  const double bound = 2.0 * max_rate_ * std::abs(h);
  double size = 1.0;
  int terms = 0;
  for (int k = 1; k < 30 && size > 1e-18; ++k) {
    terms = k;
    size *= bound / k;
  }
  return terms;
}

void ModeTransition::taylor_propagate(double h, Eigen::Ref<Eigen::MatrixXd> x) {
  // x <- expm(Pi_c h)' x = sum_k (Pi_c' h)^k x / k!, one column at a time,
  // each term from the last in O(N): Pi_c' t = a 1 (r' t) - diag(d) t, an
  // element of the new term needing only the same element of the old, so the
  // term is updated in place.
  const Eigen::Index n = x.rows(), columns = x.cols();
  const int terms = taylor_terms(h);
  auto term = term_.col(0);
  for (Eigen::Index c = 0; c < columns; ++c) {
    term = x.col(c);
    double* out = &x(0, c);
    for (int k = 1; k <= terms; ++k) {
      const double flow = spread_ * rates_.dot(term);
      const double scale = h / k;
      for (Eigen::Index i = 0; i < n; ++i) {
        const double next = (flow - decay_[i] * term[i]) * scale;
        term[i] = next;
        out[i] += next;
      }
    }
  }
}

void ModeTransition::times_generator(const Eigen::MatrixXd& x, Eigen::MatrixXd* out) const {
  // x Pi_c = a (x r) 1' - x diag(d).
  const Eigen::Index n = x.rows();
  for (Eigen::Index i = 0; i < n; ++i) {
    double flow = 0.0;
    for (Eigen::Index k = 0; k < n; ++k) flow += x(i, k) * rates_[k];
    flow *= spread_;
    for (Eigen::Index j = 0; j < n; ++j) (*out)(i, j) = flow - x(i, j) * decay_[j];
  }
}

void ModeTransition::uniformise(double dt, Eigen::MatrixXd* p) {
  // Uniformisation: expm(Pi h) = sum_k Poisson(k; r h) J^k, with J = I + Pi/r
  // stochastic, so every term is non-negative and nothing cancels. Each
  // power is the last times J, O(N^2) with the structured generator. Up to
  // r h = 1/2, the same terms as the original scaling-and-squaring
  // implementation; beyond, more terms instead of squarings (each O(N^3)).
  const Eigen::Index n = matrix_.rows();
  const double lambda = max_rate_ * dt;
  double weight = std::exp(-lambda);
  double accumulated = weight;
  p->setIdentity();
  *p *= weight;
  power_.setIdentity();
  const int most = lambda <= 0.5 ? 64 : static_cast<int>(lambda + 30.0 * std::sqrt(lambda) + 100.0);
  for (int k = 1; k < most; ++k) {
    const bool more = lambda <= 0.5 ? 1.0 - accumulated > 1e-17 : (k <= lambda || weight > 1e-18);
    if (!more) break;
    times_generator(power_, &scratch_);
    power_ += scratch_ / max_rate_;
    weight *= lambda / k;
    accumulated += weight;
    *p += weight * power_;
  }
  // Remove the truncated tail so rows sum to one to machine precision.
  for (Eigen::Index i = 0; i < n; ++i) p->row(i) /= p->row(i).sum();
}

ModeTransition::AnchorMemory ModeTransition::anchor_memory() const {
  AnchorMemory memory;
  if (form_ != Form::kDwellTimes) return memory;
  for (const Anchor& anchor : anchors_) {
    memory.dt.push_back(anchor.dt);
    memory.used.push_back(anchor.used);
  }
  memory.uses = uses_;
  return memory;
}

std::string ModeTransition::anchor_memory_problem(const AnchorMemory& memory) const {
  if (memory.used.size() != memory.dt.size()) return "its transition anchors are malformed";
  if (form_ != Form::kDwellTimes || memory.dt.empty()) return "";
  if (memory.dt.size() != anchors_.size()) {
    return "it keeps " + std::to_string(memory.dt.size()) + " transition anchors, this chain " +
           std::to_string(anchors_.size());
  }
  for (std::size_t a = 0; a < memory.dt.size(); ++a) {
    const double dt = memory.dt[a];
    if (std::isnan(dt) || (dt >= 0.0 && !(max_rate_ * dt <= kMaxUniformisedRate)) || memory.used[a] < 0 ||
        memory.used[a] > memory.uses) {
      return "a transition anchor is not one this chain makes";
    }
  }
  return "";
}

void ModeTransition::restore_anchors(const AnchorMemory& memory) {
  // Another form's memory (the bank's transition retuned) has nothing to
  // restore; none leaves the anchors to be made anew.
  if (form_ != Form::kDwellTimes || memory.dt.empty()) return;
  if (memory.dt.size() != anchors_.size() || memory.used.size() != anchors_.size()) {
    throw Error("expected " + std::to_string(anchors_.size()) + " transition anchors, got " +
                std::to_string(memory.dt.size()));
  }
  for (std::size_t a = 0; a < anchors_.size(); ++a) {
    Anchor& anchor = anchors_[a];
    anchor.dt = memory.dt[a];
    anchor.used = memory.used[a];
    if (anchor.dt >= 0.0) uniformise(anchor.dt, &anchor.p);
  }
  uses_ = memory.uses;
  cached_dt_ = -1.0;
}

int ModeTransition::anchor_for(double dt) {
  if (max_rate_ * dt > kMaxUniformisedRate) return -1;
  int best = -1, oldest = 0;
  double best_distance = 0.0;
  for (int a = 0; a < kAnchors; ++a) {
    const Anchor& anchor = anchors_[static_cast<std::size_t>(a)];
    if (anchor.used < anchors_[static_cast<std::size_t>(oldest)].used) oldest = a;
    if (anchor.dt < 0.0) continue;
    const double distance = std::abs(dt - anchor.dt);
    if (best < 0 || distance < best_distance) {
      best = a;
      best_distance = distance;
    }
  }
  if (best < 0 || 2.0 * max_rate_ * best_distance > kMaxTaylorNorm) {
    best = oldest;
    Anchor& anchor = anchors_[static_cast<std::size_t>(best)];
    uniformise(dt, &anchor.p);
    anchor.dt = dt;
  }
  anchors_[static_cast<std::size_t>(best)].used = ++uses_;
  return best;
}

void ModeTransition::eigen_propagate(double dt, const Eigen::Ref<const Eigen::MatrixXd>& in,
                                     Eigen::Ref<Eigen::MatrixXd> out) {
  // P(dt)' x = R^-1/2 U exp(L dt) U' R^1/2 x.
  const Eigen::Index n = in.rows(), columns = in.cols();
  auto scaled = term2_.leftCols(columns);
  for (Eigen::Index c = 0; c < columns; ++c) scaled.col(c) = sqrt_rates_.cwiseProduct(in.col(c));
  auto rotated = term_.leftCols(columns);
  transpose_times(eigenvectors_, scaled, rotated);  // U' R^1/2 x
  for (Eigen::Index m = 0; m < n; ++m) rotated.row(m) *= std::exp(eigenvalues_[m] * dt);
  transpose_times(eigenvectors_transposed_, rotated, out);  // U (...)
  for (Eigen::Index c = 0; c < columns; ++c) out.col(c).array() /= sqrt_rates_.array();
}

void ModeTransition::propagate(double dt, const Eigen::Ref<const Eigen::MatrixXd>& in,
                               Eigen::Ref<Eigen::MatrixXd> out) {
  const Eigen::Index n = matrix_.rows(), columns = in.cols();
  SKIDIMM_CHECK(in.rows() == n && out.rows() == n && out.cols() == columns, "propagate: shapes differ");
  switch (form_) {
    case Form::kPerStep:
      transpose_times(matrix_, in, out);
      return;
    case Form::kEqualRates: {
      if (n == 1 || max_rate_ == 0.0 || dt <= 0.0) {
        out = in;
        return;
      }
      const double decay = equal_rates_decay(dt);
      const double spread = (1.0 - decay) / static_cast<double>(n);
      for (Eigen::Index c = 0; c < columns; ++c) {
        const double* column = in.col(c).data();
        double* flowed = out.col(c).data();
        const double total = spread * eigen_sum(column, n);  // in.col(c).sum(), to the bit
        for (Eigen::Index i = 0; i < n; ++i) flowed[i] = decay * column[i] + total;
      }
      return;
    }
    case Form::kDwellTimes:
      break;
  }
  SKIDIMM_CHECK(term_.cols() >= columns, "propagate: call reserve_columns() first");
  if (dt <= 0.0) {
    out = in;
    return;
  }
  if (n >= kMinDirectTaylorModes && 2.0 * max_rate_ * dt <= kMaxDirectTaylorNorm) {
    // A short step (10 ms against dwell times of seconds: a few terms):
    // P(dt)' x = expm(Pi_c dt)' x directly, O(N C) per term, no N x N product.
    out = in;
    taylor_propagate(dt, out);
    return;
  }
  const int a = anchor_for(dt);
  if (a < 0) {
    eigen_propagate(dt, in, out);
    return;
  }
  const Anchor& anchor = anchors_[static_cast<std::size_t>(a)];
  const double delta = dt - anchor.dt;
  if (delta != 0.0 && columns > n) {
    // Fewer modes than columns (a few modes, each with a state's moments):
    // the series costs less on the N columns of P(dt)' = expm(Pi_c delta)'
    // P(dt_a)' than on the C columns of x, and then one product.
    power_ = anchor.p.transpose();
    taylor_propagate(delta, power_);
    for (Eigen::Index c = 0; c < columns; ++c) {
      for (Eigen::Index j = 0; j < n; ++j) {
        double sum = 0.0;
        for (Eigen::Index i = 0; i < n; ++i) sum += power_(j, i) * in(i, c);
        out(j, c) = sum;
      }
    }
    return;
  }
  // P(dt)' x = expm(Pi_c delta)' P(dt_a)' x: one dense product, then the
  // Taylor series.
  transpose_times(anchor.p, in, out);
  if (delta != 0.0) taylor_propagate(delta, out);
}

}  // namespace skidimm
