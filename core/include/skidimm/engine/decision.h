// ModeDecision: a mode a controller can act on, from the IMM's probabilities.
//
// The most likely mode (argmax) changes whenever two modes are close, which
// on a real robot can be several times a second. A controller that switches
// policy by terrain needs a decision that changes when the evidence does:
//
//   * hysteresis: a mode (or class, when the bank has classes) is taken when
//     its probability reaches `enter`, and the decision moves to another only
//     when that one reaches `enter` in turn;
//   * a minimum hold: a decision is kept at least `min_hold` seconds, so one
//     spike cannot flip it back and forth;
//   * an explicit unknown: before any mode is confident enough, and when the
//     decided one's probability has stayed below `leave` for `min_hold`
//     seconds (and its own hold is over) with no other confident, the
//     decision is unknown rather than a guess. The wait is the hold's
//     debouncing the other way: one dip cannot drop the decision, and after
//     a real switch, where the old mode's probability collapses before the
//     new one's has risen past `enter`, the decision usually moves straight
//     to the new mode, one change where unknown in between would make two.
//     leave = 0 never gives up a decision once taken.
//
// update() allocates nothing: it runs in the robot's loop next to Imm::step,
// from one thread at a time.
#ifndef SKIDIMM_ENGINE_DECISION_H_
#define SKIDIMM_ENGINE_DECISION_H_

#include <Eigen/Core>
#include <string>
#include <vector>

#include "skidimm/config/bank.h"

namespace skidimm {

class ModeDecision {
 public:
  static constexpr int kUnknown = -1;

  // Decides over the bank's classes (its modes when it has none), with the
  // bank's `decision:` settings.
  explicit ModeDecision(const BankConfig& config);
  ModeDecision(const BankConfig& config, const DecisionConfig& settings);

  // One step at time t (s, increasing) with the modes' probabilities, and
  // whether any measurement corrected the filter in it (the estimate's
  // num_measured > 0; smoothed probabilities carry later measurements, and
  // pass true). Returns the decided class's index in names(), or kUnknown.
  int update(double t, const Eigen::Ref<const Eigen::VectorXd>& mode_probabilities, bool measured = true);
  // Seconds without a measurement after which a decision is given up (0: never).
  double stale_after() const { return stale_after_; }
  int decision() const { return decision_; }
  // The decided class's probability at the last update (0 when unknown).
  double probability() const { return decision_ == kUnknown ? 0.0 : class_probabilities_[decision_]; }

  // Class names in decision order; "unknown" is not among them.
  const std::vector<std::string>& names() const { return names_; }
  const std::string& name(int decision) const;  // "unknown" for kUnknown
  const DecisionConfig& settings() const { return settings_; }

  void reset();

  // What update() carries from one step to the next (ImmCheckpoint): a
  // decision restored with it decides every later step as this one would.
  struct Memory {
    std::string decision;  // a class name, or "unknown"
    double decided_at = 0.0;
    bool below_leave = false;
    double below_leave_since = 0.0;
    bool measured_once = false;
    double last_measured_t = 0.0;
    Eigen::VectorXd class_probabilities;  // at the last update, in names() order
  };
  Memory memory() const;
  // Throws an Error naming what does not fit these classes.
  void restore(const Memory& memory);

 private:
  DecisionConfig settings_;
  std::vector<std::string> names_;
  std::vector<int> class_of_mode_;
  Eigen::VectorXd class_probabilities_;
  int decision_ = kUnknown;
  double decided_at_ = 0.0;
  bool below_leave_ = false;  // the decided class's probability is below `leave`
  double below_leave_since_ = 0.0;
  double stale_after_ = 0.0;
  bool measured_once_ = false;
  double last_measured_t_ = 0.0;
};

}  // namespace skidimm

#endif  // SKIDIMM_ENGINE_DECISION_H_
