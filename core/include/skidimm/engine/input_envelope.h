// Where a bank's classes were fitted, and which steps ask them to
// extrapolate: a mode's fit records each input's range over the steps it was
// fitted on (ModeConfig::fitted_inputs); a class's range is the span of its
// modes'. A robot driven faster or turning harder than a terrain's runs were
// is outside that terrain's ranges, and its probability there is a straight
// line followed past its data, however confident it looks. The engine fades
// such a class's evidence (`extrapolation_scale`), `eval` counts such steps.
#ifndef SKIDIMM_ENGINE_INPUT_ENVELOPE_H_
#define SKIDIMM_ENGINE_INPUT_ENVELOPE_H_

#include <Eigen/Core>
#include <string>
#include <vector>

#include "skidimm/config/bank.h"

namespace skidimm {

// An input of a step beyond a class's range.
struct Excursion {
  int input = -1;       // the bank's input index; -1: inside every range
  double value = 0.0;   // the step's value
  double lowest = 0.0;  // the class's range
  double highest = 0.0;
  // How far outside, in widths of the range; a range of one value: infinitely far.
  double beyond = 0.0;
};

class InputEnvelope {
 public:
  // The ranges of each class of `bank` (BankConfig::class_names()). An input
  // is unbounded for a class where one of its modes has no range for it.
  explicit InputEnvelope(const BankConfig& bank);

  // True when no mode of the bank records its ranges: nothing is outside.
  bool empty() const { return empty_; }
  int num_classes() const { return static_cast<int>(classes_.size()); }
  // The input of `u` farthest outside class c's ranges (Excursion::input -1
  // when `u` is inside them all or is not finite). A value beyond a range's
  // end by less than 1e-7 of that end is inside: the round-off of inputs
  // computed from other rows, and the 7 digits a written bank keeps.
  Excursion outside(int c, const Eigen::Ref<const Eigen::VectorXd>& u) const;
  // "speed 0.78 (ICE fitted on 0.04 to 0.31)".
  std::string describe(int c, const Excursion& e) const;

 private:
  bool empty_ = true;
  std::vector<std::string> inputs_;
  std::vector<std::string> classes_;
  std::vector<Eigen::VectorXd> lowest_, highest_;  // per class, per input; +-inf where unbounded
  std::vector<Eigen::VectorXd> inside_from_, inside_to_;  // the same widened by the round-off slack
};

}  // namespace skidimm

#endif  // SKIDIMM_ENGINE_INPUT_ENVELOPE_H_
