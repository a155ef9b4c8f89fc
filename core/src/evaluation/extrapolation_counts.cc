#include "skidimm/evaluation/extrapolation_counts.h"

#include <cstdio>

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

std::string ExtrapolationCounts::accuracy_by_truth_side() const {
  const auto percent = [](long part, long whole) {
    char text[32];
    std::snprintf(text, sizeof(text), "%.1f%%", 100.0 * (static_cast<double>(part) / static_cast<double>(whole)));
    return std::string(text);
  };
  const long inside = labelled - outside_truth;
  std::string text;
  if (outside_truth > 0) text += percent(outside_truth_right, outside_truth) + " of those";
  if (outside_truth > 0 && inside > 0) text += " and ";
  if (inside > 0)
    text += percent(inside_truth_right, inside) + (outside_truth > 0 ? " of the others" : " of the steps");
  return text;
}

}  // namespace evaluation
}  // namespace skidimm
