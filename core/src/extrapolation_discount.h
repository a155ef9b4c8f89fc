// The evidence of a class whose models extrapolate, faded towards what the
// step says of no mode in particular (`extrapolation_scale` in a bank,
// docs/engine.md "Extrapolation discount").
//
// A mode's model was fitted where its runs were driven (ModeConfig::
// fitted_inputs). Outside that, its prediction is a straight line's guess
// (widened by its parameter uncertainty, where the bank has it, but centred
// where the line goes), and the IMM takes its miss, or its match, as
// evidence as sure as any other. A run driven faster than any fitting run of
// its terrain then reads, for the whole run and with full confidence, as the
// terrain whose models happen to extrapolate closest.
//
// Here a class (a terrain: the union of its modes' ranges, so that its
// turning mode is not called extrapolating because its straight mode was
// fitted straight) is d of its range widths outside its ranges, in the input
// farthest out. Each of its modes' log-likelihoods then becomes
//
//   l_j' = t_j l_j + (1 - t_j) l_trusted,    t_j = exp(-d / scale),
//   l_trusted = log (sum_k c_k t_k exp(l_k) / sum_k c_k t_k),
//
// l_trusted being the step's log-likelihood under the predicted mixture of
// the modes, each weighed by how far its class is trusted at this step (c_k:
// the predicted mode probabilities, over the modes scored at this step).
// Why that mixture: the posterior of a set E of modes scored at it is
// c_E L / (c_E L + sum_{k not in E} c_k L_k), which is c_E, its prior,
// exactly when L is the mixture of the others. So a class at t = 0 keeps
// the probability the transitions give it, neither confirmed nor refuted,
// while the others share the rest by their own evidence; the estimate is
// less sure exactly where the models cannot tell. (The mixture of all the
// modes would be below the leader's likelihood, and would still wear the
// class down step by step.) When every class is at t = 0 the step moves no
// probability. Where all are equally trusted, the differences between
// log-likelihoods are scaled by t: the step counts t of a step. Inside every
// class's ranges (t = 1 for all) the log-likelihoods are used as they are,
// bit for bit. Private to the engine.
#ifndef SKIDIMM_CORE_SRC_EXTRAPOLATION_DISCOUNT_H_
#define SKIDIMM_CORE_SRC_EXTRAPOLATION_DISCOUNT_H_

#include <Eigen/Core>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include "skidimm/config/bank.h"
#include "skidimm/engine/input_envelope.h"

namespace skidimm {
namespace internal {

class ExtrapolationDiscount {
 public:
  // Without a scale nothing is built: tune constructs an engine per log and
  // candidate, and most banks go without the discount.
  explicit ExtrapolationDiscount(const BankConfig& bank) : scale_(bank.extrapolation_scale) {
    if (!(scale_ > 0.0)) return;
    envelope_.emplace(bank);
    class_of_mode_ = bank.class_of_modes();
    trust_.assign(static_cast<std::size_t>(envelope_->num_classes()), 1.0);
    evidence_.resize(bank.num_modes());
  }

  // A bank with a scale and some mode's ranges.
  bool active() const { return envelope_.has_value() && !envelope_->empty(); }

  // The log-likelihoods the mode probabilities are to use at a step with
  // inputs `u`: `log_likelihoods` itself where no class extrapolates, else
  // the discounted values (held here until the next call). `predicted`: the
  // predicted mode probabilities c. A mode whose log-likelihood is not finite
  // (failed, or not scored) keeps it.
  const Eigen::VectorXd& evidence(const Eigen::Ref<const Eigen::VectorXd>& u, const Eigen::VectorXd& predicted,
                                  const Eigen::VectorXd& log_likelihoods) {
    if (!update_trust(u)) return log_likelihoods;
    // l_trusted over the modes scored, from the largest term.
    double largest = -std::numeric_limits<double>::infinity();
    for (Eigen::Index k = 0; k < log_likelihoods.size(); ++k) {
      if (std::isfinite(log_likelihoods[k]) && predicted[k] * trust_of(k) > 0.0) {
        largest = std::max(largest, log_likelihoods[k]);
      }
    }
    double weighted = 0.0, total = 0.0;
    for (Eigen::Index k = 0; std::isfinite(largest) && k < log_likelihoods.size(); ++k) {
      const double weight = predicted[k] * trust_of(k);
      if (!std::isfinite(log_likelihoods[k]) || !(weight > 0.0)) continue;
      weighted += weight * std::exp(log_likelihoods[k] - largest);
      total += weight;
    }
    // No trusted mode scored the step: it says nothing of any mode.
    const bool none_trusted = !(total > 0.0);
    const double trusted = none_trusted ? 0.0 : largest + std::log(weighted / total);
    for (Eigen::Index j = 0; j < log_likelihoods.size(); ++j) {
      const double t = trust_of(j);
      const double l = log_likelihoods[j];
      if (!std::isfinite(l)) {
        evidence_[j] = l;
      } else if (none_trusted) {
        evidence_[j] = 0.0;
      } else {
        evidence_[j] = t == 1.0 ? l : t * l + (1.0 - t) * trusted;
      }
    }
    return evidence_;
  }

 private:
  double trust_of(Eigen::Index mode) const {
    return trust_[static_cast<std::size_t>(class_of_mode_[static_cast<std::size_t>(mode)])];
  }

  // Sets each class's t for `u`; false when every class is inside its ranges.
  bool update_trust(const Eigen::Ref<const Eigen::VectorXd>& u) {
    bool outside = false;
    for (int c = 0; c < envelope_->num_classes(); ++c) {
      const Excursion farthest = envelope_->outside(c, u);
      const double t = farthest.input < 0 ? 1.0 : std::exp(-farthest.beyond / scale_);
      trust_[static_cast<std::size_t>(c)] = t;
      outside = outside || t < 1.0;
    }
    return outside;
  }

  double scale_;
  std::optional<InputEnvelope> envelope_;  // the classes' fitted input ranges; none without a scale
  std::vector<int> class_of_mode_;  // per mode, its class
  std::vector<double> trust_;       // per class, the weight t of its own evidence at the last step
  Eigen::VectorXd evidence_;        // the discounted log-likelihoods
};

}  // namespace internal
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_EXTRAPOLATION_DISCOUNT_H_
