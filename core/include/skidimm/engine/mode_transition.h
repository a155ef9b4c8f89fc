// ModeTransition: the Markov chain that switches modes between steps.
//
// p_ij = P(mode j at step k | mode i at step k-1): row = from, column = to,
// rows sum to 1 (Bar-Shalom et al. 2001, section 11.6; paper eq. 4-5).
//
// Two kinds:
//  * per step: a fixed matrix used at every step, whatever dt is. Simple, and
//    right for uniformly sampled logs.
//  * continuous: a generator Pi_c built from mean dwell times tau_i (mode i is
//    left at rate r_i = 1/tau_i, to every other mode with equal probability),
//    and P(dt) = expm(Pi_c dt) per step, so that irregular sampling keeps the
//    same switching statistics in seconds.
//
// Cost per step, N modes (the IMM needs P(dt)' applied to its N x C moments,
// propagate(), never P itself):
//  * per step: one N x N by N x C product, O(N^2 C).
//  * equal dwell times: P = e I + (1 - e)/N 1 1' in closed form, O(N C).
//  * per-mode dwell times: Pi_c = a r 1' - D (a = 1/(N-1), D = diag(N r/(N-1)))
//    is diagonal plus rank one, so a product with it costs O(N C), not O(N^2 C).
//    From 8 modes on, a short step (||Pi_c dt|| = 2 max r dt <= 0.01: 10 ms
//    against dwell times of 2 s or more) applies the Taylor series of expm(Pi_c dt)' itself, a few
//    O(N C) products with Pi_c', one column at a time: O(N C) per step like
//    equal dwell times. A longer step uses an anchor: P(dt_a) computed once
//    for a step dt_a (uniformisation, every term a product with the
//    structured J = I + Pi_c / max r, O(N^2) each), reused for every later dt
//    near it: P(dt) = P(dt_a) expm(Pi_c (dt - dt_a)), the second factor the
//    same short Taylor series; one N x N by N x C product per step, like a
//    per-step matrix. A step far from every anchor makes a new one (four are
//    kept); a step long enough that uniformisation would need many terms (max r dt >
//    50, a gap of 50 dwell times of the fastest mode) uses the eigenvectors of
//    the symmetric matrix R^1/2 K R^1/2 similar to Pi_c (computed once, at
//    construction): P(dt)' x = R^-1/2 U exp(L dt) U' R^1/2 x, two products.
//  Results agree with the direct uniformisation of expm(Pi_c dt) to about
//  1e-15 (tests/core/mode_transition_test.cc pins 1e-12).
//
// matrix(dt) forms P(dt) itself (the smoother uses it): O(N^2) per new dt for
// every form, O(N^3) only past the eigenvector threshold above. Nothing here
// allocates after construction.
#ifndef SKIDIMM_ENGINE_MODE_TRANSITION_H_
#define SKIDIMM_ENGINE_MODE_TRANSITION_H_

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

namespace skidimm {

// The `transition:` of a bank (docs/bank-format.md).
struct TransitionConfig {
  enum class Kind { kMatrix, kStay, kDwellTimes };
  Kind kind = Kind::kStay;
  Eigen::MatrixXd matrix;         // kMatrix: per-step p_ij, row = from
  double stay = 0.95;             // kStay: per-step probability of staying
  Eigen::VectorXd dwell_seconds;  // kDwellTimes: mean time in each mode
};

class ModeTransition {
 public:
  // The chain a bank's `transition:` describes, for `num_modes` modes.
  static ModeTransition from_config(const TransitionConfig& config, int num_modes);
  // A per-step matrix. Checked by the bank loader; here only asserted square.
  static ModeTransition per_step(const Eigen::MatrixXd& matrix);
  // Equal stay probability on the diagonal, the rest spread evenly.
  static ModeTransition per_step_stay(int num_modes, double stay_probability);
  // Continuous-time chain from mean dwell times in seconds (all > 0).
  static ModeTransition from_dwell_times(const Eigen::VectorXd& mean_dwell_seconds);

  int num_modes() const { return static_cast<int>(matrix_.rows()); }
  bool is_continuous() const { return form_ != Form::kPerStep; }
  // The generator Pi_c (zero for per-step transitions).
  const Eigen::MatrixXd& generator() const { return generator_; }

  // Transition matrix for a step of dt > 0 seconds.
  const Eigen::MatrixXd& matrix(double dt);
  // True when matrix(dt) is given or in closed form (per step, equal dwell
  // times): O(N^2) at most, and the same numbers, bit for bit, as before the
  // structured forms existed. The IMM then computes c = P' mu with it exactly
  // as it always has, so that modes whose probabilities tie exactly (equal
  // priors before the first measurement) keep their order.
  bool matrix_in_closed_form() const { return form_ != Form::kDwellTimes; }

  // Sizes the workspace of propagate() for inputs of up to `columns` columns.
  void reserve_columns(int columns);
  // out = P(dt)' in (N x C, C <= the reserved columns): row j of out is
  // sum_i p_ij in.row(i), i.e. what flows into mode j. Allocates nothing.
  void propagate(double dt, const Eigen::Ref<const Eigen::MatrixXd>& in, Eigen::Ref<Eigen::MatrixXd> out);

  // Which steps' P(dt) the chain keeps as anchors (per-mode dwell times),
  // and in what order it used them: which anchor a later step starts from
  // depends on them, and its last bits on the anchor. A chain restored with
  // the memory of another (same dwell times) propagates every later step
  // exactly as that one would (Imm::restore). Empty for the other forms.
  struct AnchorMemory {
    std::vector<double> dt;  // per slot; < 0: unused
    std::vector<long> used;  // per slot, when it was last used
    long uses = 0;
  };
  AnchorMemory anchor_memory() const;
  // Recomputes each kept anchor's P(dt) (the same numbers). A memory that
  // is empty, or a chain of another form, restores nothing; a memory of
  // another number of slots is an Error.
  void restore_anchors(const AnchorMemory& memory);
  // Why `memory` cannot be this chain's ("" when it can): slots of another
  // number, or a kept step no anchor is made for (a gap of more than 50
  // dwell times of the fastest mode, whose P(dt) a long series would take).
  std::string anchor_memory_problem(const AnchorMemory& memory) const;

 private:
  enum class Form { kPerStep, kEqualRates, kDwellTimes };
  static constexpr int kAnchors = 4;
  struct Anchor {
    double dt = -1.0;  // < 0: unused
    long used = 0;
    Eigen::MatrixXd p;  // P(dt)
  };

  ModeTransition() = default;
  double equal_rates_decay(double dt) const;
  // The anchor to use for dt (made if none is close enough); -1: use the eigenvectors.
  int anchor_for(double dt);
  void uniformise(double dt, Eigen::MatrixXd* p);
  // out = x Pi_c, in O(N^2): x (N x N) times the diagonal-plus-rank-one generator.
  void times_generator(const Eigen::MatrixXd& x, Eigen::MatrixXd* out) const;
  // Terms of the Taylor series of expm(Pi_c h) past the identity that reach 1e-18.
  int taylor_terms(double h) const;
  // matrix_ <- matrix_ expm(Pi_c h) by its Taylor series, O(N^2) per term.
  void taylor_multiply(double h);
  // x <- expm(Pi_c h)' x by its Taylor series, O(N C) per term.
  void taylor_propagate(double h, Eigen::Ref<Eigen::MatrixXd> x);
  void eigen_propagate(double dt, const Eigen::Ref<const Eigen::MatrixXd>& in, Eigen::Ref<Eigen::MatrixXd> out);

  Form form_ = Form::kPerStep;
  double cached_dt_ = -1.0;
  mutable double decay_dt_ = -1.0;  // equal rates: the last dt's decay, for matrix() and propagate()
  mutable double decay_value_ = 1.0;
  double max_rate_ = 0.0;
  Eigen::MatrixXd matrix_;
  Eigen::MatrixXd generator_;
  // Per-mode dwell times: Pi_c = a r 1' - diag(d).
  Eigen::VectorXd rates_;  // r
  Eigen::VectorXd decay_;  // d = N r / (N - 1)
  double spread_ = 0.0;    // a = 1 / (N - 1)
  std::array<Anchor, kAnchors> anchors_;
  long uses_ = 0;
  // Eigenvectors of R^1/2 K R^1/2 (Pi_c = R K), for long steps.
  Eigen::MatrixXd eigenvectors_;             // U
  Eigen::MatrixXd eigenvectors_transposed_;  // U', for contiguous rows of U
  Eigen::VectorXd eigenvalues_;              // L
  Eigen::VectorXd sqrt_rates_;               // R^1/2
  // Workspace.
  Eigen::MatrixXd power_;
  Eigen::MatrixXd scratch_;
  Eigen::MatrixXd term_;   // N x C
  Eigen::MatrixXd term2_;  // N x C
  Eigen::VectorXd row_;    // C
};

}  // namespace skidimm

#endif  // SKIDIMM_ENGINE_MODE_TRANSITION_H_
