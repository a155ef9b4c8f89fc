// Where a bank's classes were fitted, and which steps ask them to
// extrapolate: a mode's fit records each input's range over the steps it was
// fitted on (ModeConfig::fitted_inputs); a class's range is the span of its
// modes'. A robot driven faster or turning harder than a terrain's runs were
// is outside that terrain's ranges, and its probability there is a straight
// line followed past its data, however confident it looks.
#ifndef SKIDIMM_EVALUATION_INPUT_ENVELOPE_H_
#define SKIDIMM_EVALUATION_INPUT_ENVELOPE_H_

#include <Eigen/Core>
#include <string>
#include <vector>

#include "skidimm/config/bank.h"

namespace skidimm {
namespace evaluation {

// An input of a step beyond a class's range.
struct Excursion {
  int input = -1;          // the bank's input index; -1: inside every range
  double value = 0.0;      // the step's value
  double lowest = 0.0;     // the class's range
  double highest = 0.0;
  double beyond = 0.0;     // how far outside, in widths of the range (a range of no width: of 1)
};

class InputEnvelope {
 public:
  // The ranges of each class of `bank` (BankConfig::class_names()). An input
  // is unbounded for a class where one of its modes has no range for it.
  explicit InputEnvelope(const BankConfig& bank);

  // True when no mode of the bank records its ranges: nothing is outside.
  bool empty() const { return empty_; }
  // The input of `u` farthest outside class c's ranges (Excursion::input -1
  // when `u` is inside them all or is not finite).
  Excursion outside(int c, const Eigen::VectorXd& u) const;
  // "speed 0.78 (ICE fitted on 0.04 to 0.31)".
  std::string describe(int c, const Excursion& e) const;

 private:
  bool empty_ = true;
  std::vector<std::string> inputs_;
  std::vector<std::string> classes_;
  std::vector<Eigen::VectorXd> lowest_, highest_;  // per class, per input; +-inf where unbounded
};

// How many of a log's steps were outside the ranges of the class estimated
// there, and, where the truth is known, of the true class, and how often the
// estimate was right inside and outside them.
struct ExtrapolationCounts {
  long steps = 0;                // steps counted (the bank records ranges)
  long outside_estimate = 0;     // outside the most likely class's ranges
  long labelled = 0;             // steps whose truth is a class of the bank
  long outside_truth = 0;        // ... outside the true class's ranges
  long outside_truth_right = 0;  // ... of which the most likely class was right
  long inside_truth_right = 0;   // right where inside the true class's ranges
  // The step farthest outside the true class's ranges (or, without truth,
  // the estimated class's), as InputEnvelope::describe() says it.
  std::string farthest;
  double farthest_beyond = 0.0;

  void merge(const ExtrapolationCounts& other);
};

}  // namespace evaluation
}  // namespace skidimm

#endif  // SKIDIMM_EVALUATION_INPUT_ENVELOPE_H_
