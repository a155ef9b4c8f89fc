#include "skidimm/evaluation/extrapolation_counts.h"

namespace skidimm {
namespace evaluation {

void ExtrapolationCounts::merge(const ExtrapolationCounts& other) {
  steps += other.steps;
  outside_estimate += other.outside_estimate;
  labelled += other.labelled;
  outside_truth += other.outside_truth;
  outside_truth_right += other.outside_truth_right;
  inside_truth_right += other.inside_truth_right;
  if (other.farthest_beyond > farthest_beyond) {
    farthest_beyond = other.farthest_beyond;
    farthest = other.farthest;
  }
}

}  // namespace evaluation
}  // namespace skidimm
