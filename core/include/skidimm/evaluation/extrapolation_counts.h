// How many of a log's steps asked the classes to extrapolate (outside the
// input ranges they were fitted on, skidimm/engine/input_envelope.h), and how
// often the estimate was right there: what `eval` reports of it.
#ifndef SKIDIMM_EVALUATION_EXTRAPOLATION_COUNTS_H_
#define SKIDIMM_EVALUATION_EXTRAPOLATION_COUNTS_H_

#include <string>

namespace skidimm {
namespace evaluation {

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

  // The most likely class's accuracy on the labelled steps outside the true
  // class's ranges and on the others, naming only the sides that have steps:
  // "40.0% of those and 90.0% of the others", or "90.0% of the steps" when
  // none was outside; "" without labelled steps.
  std::string accuracy_by_truth_side() const;
};

}  // namespace evaluation
}  // namespace skidimm

#endif  // SKIDIMM_EVALUATION_EXTRAPOLATION_COUNTS_H_
