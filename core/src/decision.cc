#include "skidimm/engine/decision.h"

#include <cmath>
#include <string>

#include "check.h"
#include "skidimm/errors.h"

namespace skidimm {

namespace {
const std::string kUnknownName = "unknown";
}

ModeDecision::ModeDecision(const BankConfig& config) : ModeDecision(config, config.decision) {}

ModeDecision::ModeDecision(const BankConfig& config, const DecisionConfig& settings)
    : settings_(settings), names_(config.class_names()), class_of_mode_(config.class_of_modes()) {
  SKIDIMM_CHECK(settings.enter > 0.0 && settings.enter <= 1.0 && settings.leave >= 0.0 &&
                    settings.leave < settings.enter && settings.min_hold >= 0.0,
                "decision settings out of range (the bank loader checks them)");
  class_probabilities_.resize(static_cast<Eigen::Index>(names_.size()));
  stale_after_ = settings.stale_after;
  if (stale_after_ < 0.0) {
    const TransitionConfig& transition = config.transition;
    const bool dwell = transition.kind == TransitionConfig::Kind::kDwellTimes && transition.dwell_seconds.size() > 0;
    stale_after_ = dwell ? transition.dwell_seconds.minCoeff() : 0.0;
  }
}

const std::string& ModeDecision::name(int decision) const {
  return decision == kUnknown ? kUnknownName : names_[static_cast<std::size_t>(decision)];
}

void ModeDecision::reset() {
  decision_ = kUnknown;
  decided_at_ = 0.0;
  below_leave_ = false;
  below_leave_since_ = 0.0;
  measured_once_ = false;
  last_measured_t_ = 0.0;
}

ModeDecision::Memory ModeDecision::memory() const {
  Memory memory;
  memory.decision = name(decision_);
  memory.decided_at = decided_at_;
  memory.below_leave = below_leave_;
  memory.below_leave_since = below_leave_since_;
  memory.measured_once = measured_once_;
  memory.last_measured_t = last_measured_t_;
  memory.class_probabilities = class_probabilities_;
  return memory;
}

void ModeDecision::restore(const Memory& memory) {
  int decided = kUnknown;
  if (memory.decision != kUnknownName) {
    for (std::size_t c = 0; c < names_.size(); ++c) {
      if (names_[c] == memory.decision) decided = static_cast<int>(c);
    }
    if (decided == kUnknown)
      throw Error("cannot restore this checkpoint: the decision '" + memory.decision +
                  "' is none of the bank's classes");
  }
  if (memory.class_probabilities.size() != class_probabilities_.size()) {
    throw Error("cannot restore this checkpoint: the decision holds " +
                std::to_string(memory.class_probabilities.size()) + " class probabilities, the bank has " +
                std::to_string(class_probabilities_.size()) + " classes");
  }
  const bool probabilities = memory.class_probabilities.allFinite() &&
                             (memory.class_probabilities.array() >= 0.0).all() &&
                             (memory.class_probabilities.array() <= 1.0).all();
  if (!std::isfinite(memory.decided_at) || !std::isfinite(memory.below_leave_since) ||
      !std::isfinite(memory.last_measured_t) || !probabilities) {
    // A NaN time would keep a decision from ever going stale, or skip its hold.
    throw Error(
        "cannot restore this checkpoint: the decision's times and class probabilities must be finite (and "
        "the probabilities in [0, 1])");
  }
  decision_ = decided;
  decided_at_ = memory.decided_at;
  below_leave_ = memory.below_leave;
  below_leave_since_ = memory.below_leave_since;
  measured_once_ = memory.measured_once;
  last_measured_t_ = memory.last_measured_t;
  class_probabilities_ = memory.class_probabilities;
}

int ModeDecision::update(double t, const Eigen::Ref<const Eigen::VectorXd>& mode_probabilities, bool measured) {
  // A time that is not finite, or goes back, says nothing of when the
  // sensors last spoke.
  if (std::isfinite(t) && (!measured_once_ || (measured && t > last_measured_t_))) {
    measured_once_ = true;
    last_measured_t_ = t;
  }
  class_probabilities_.setZero();
  for (Eigen::Index j = 0; j < mode_probabilities.size(); ++j) {
    class_probabilities_[class_of_mode_[static_cast<std::size_t>(j)]] += mode_probabilities[j];
  }
  Eigen::Index best = 0;
  const double best_probability = class_probabilities_.maxCoeff(&best);
  // When the decided class's probability went below `leave` (and stayed),
  // counted during the hold too.
  if (decision_ != kUnknown) {
    if (class_probabilities_[decision_] >= settings_.leave) {
      below_leave_ = false;
    } else if (!below_leave_) {
      below_leave_ = true;
      below_leave_since_ = t;
    }
  }
  // No measurement for stale_after seconds: the probabilities say only what
  // the chain's prior lets them keep, nothing the sensors said.
  if (stale_after_ > 0.0 && t - last_measured_t_ >= stale_after_) {
    if (decision_ != kUnknown) {
      decision_ = kUnknown;
      decided_at_ = t;
      below_leave_ = false;
    }
    return decision_;
  }
  if (decision_ != kUnknown && t - decided_at_ < settings_.min_hold) return decision_;
  if (best != decision_ && best_probability >= settings_.enter) {
    decision_ = static_cast<int>(best);
    decided_at_ = t;
    below_leave_ = false;
  } else if (below_leave_ && t - below_leave_since_ >= settings_.min_hold) {
    // Below `leave` for a whole hold and no other class confident: after a
    // real switch the new mode is usually confident within that time, and
    // the decision moves straight to it instead of through unknown.
    decision_ = kUnknown;
    decided_at_ = t;
    below_leave_ = false;
  }
  return decision_;
}

}  // namespace skidimm
