#include "skidimm/engine/input_envelope.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace skidimm {

namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();
constexpr double kRelativeSlack = 1e-7;

std::string number(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.3g", v);
  return buffer;
}

}  // namespace

InputEnvelope::InputEnvelope(const BankConfig& bank) : inputs_(bank.input_names), classes_(bank.class_names()) {
  const Eigen::Index inputs = static_cast<Eigen::Index>(inputs_.size());
  lowest_.assign(classes_.size(), Eigen::VectorXd::Constant(inputs, kInfinity));
  highest_.assign(classes_.size(), Eigen::VectorXd::Constant(inputs, -kInfinity));
  const std::vector<int> class_of_mode = bank.class_of_modes();
  for (std::size_t j = 0; j < bank.modes.size(); ++j) {
    const ModeConfig& mode = bank.modes[j];
    if (!mode.fitted_inputs.empty()) empty_ = false;
    const std::size_t c = static_cast<std::size_t>(class_of_mode[j]);
    for (Eigen::Index i = 0; i < inputs; ++i) {
      const auto range = mode.fitted_inputs.find(inputs_[static_cast<std::size_t>(i)]);
      const double low = range == mode.fitted_inputs.end() ? -kInfinity : range->second.lowest;
      const double high = range == mode.fitted_inputs.end() ? kInfinity : range->second.highest;
      lowest_[c][i] = std::min(lowest_[c][i], low);
      highest_[c][i] = std::max(highest_[c][i], high);
    }
  }
  // The same wheel speeds computed another way (velR - velL from other rows)
  // can differ from a range's end in the last bit; within the 7 digits a
  // written bank keeps of a range (rounded outward), a value is inside, in
  // memory as from a file.
  inside_from_ = lowest_;
  inside_to_ = highest_;
  for (std::size_t c = 0; c < classes_.size(); ++c) {
    for (Eigen::Index i = 0; i < inputs; ++i) {
      const double slack = kRelativeSlack * std::max(std::abs(lowest_[c][i]), std::abs(highest_[c][i]));
      inside_from_[c][i] -= slack;
      inside_to_[c][i] += slack;
    }
  }
}

Excursion InputEnvelope::outside(int c, const Eigen::Ref<const Eigen::VectorXd>& u) const {
  Excursion farthest;
  if (empty_ || c < 0 || static_cast<std::size_t>(c) >= classes_.size()) return farthest;
  const Eigen::VectorXd& low = lowest_[static_cast<std::size_t>(c)];
  const Eigen::VectorXd& high = highest_[static_cast<std::size_t>(c)];
  const Eigen::VectorXd& from = inside_from_[static_cast<std::size_t>(c)];
  const Eigen::VectorXd& to = inside_to_[static_cast<std::size_t>(c)];
  for (Eigen::Index i = 0; i < u.size() && i < low.size(); ++i) {
    const double value = u[i];
    if (!std::isfinite(value) || (value >= from[i] && value <= to[i])) continue;
    const double width = high[i] - low[i];
    const double distance = value < low[i] ? low[i] - value : value - high[i];
    // A range of one value: any other is infinitely far out.
    const double beyond = width > 0.0 ? distance / width : kInfinity;
    if (farthest.input < 0 || beyond > farthest.beyond) {
      farthest = Excursion{static_cast<int>(i), value, low[i], high[i], beyond};
    }
  }
  return farthest;
}

std::string InputEnvelope::describe(int c, const Excursion& e) const {
  if (e.input < 0) return "";
  return inputs_[static_cast<std::size_t>(e.input)] + " " + number(e.value) + " (" +
         classes_[static_cast<std::size_t>(c)] + " fitted on " + number(e.lowest) + " to " + number(e.highest) + ")";
}

}  // namespace skidimm
