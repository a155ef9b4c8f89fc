#include "skidimm/evaluation/accuracy_range.h"

#include <algorithm>
#include <boost/math/distributions/students_t.hpp>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

namespace skidimm {
namespace evaluation {

namespace {

std::string three_decimals(double v) {
  char b[32];
  std::snprintf(b, sizeof(b), "%.3f", v);
  return b;
}

std::string scored_classes(const std::map<std::string, int>& scored) {
  std::string names;
  for (const auto& [name, count] : scored) names += (names.empty() ? "" : ", ") + name;
  return names;
}

}  // namespace

void check_logs_per_class(const std::vector<LogScore>& scores, const std::map<std::string, int>& another) {
  std::map<std::string, int> scored;
  for (const LogScore& s : scores) ++scored[s.truth];
  for (const auto& [name, count] : another) {
    if (scored.count(name) == 0) {
      throw std::invalid_argument("class '" + name +
                                  "' of the other set has no scored log here (scored: " + scored_classes(scored) + ")");
    }
    if (count < 1 || count > kMostLogsPerClass) {
      throw std::invalid_argument("class '" + name + "' of the other set needs from 1 to " +
                                  std::to_string(kMostLogsPerClass) + " logs");
    }
  }
  for (const auto& [name, count] : scored) {
    if (another.count(name) == 0) {
      throw std::invalid_argument(
          "the other set leaves out class '" + name +
          "', which these logs score: give each class's count (scored: " + scored_classes(scored) + ")");
    }
  }
}

AccuracyRange accuracy_range(const std::vector<LogScore>& scores, const std::map<std::string, int>& another,
                             double level) {
  if (!(level > 0.0 && level < 1.0)) throw std::invalid_argument("a range's level must be in (0, 1)");
  if (!another.empty()) check_logs_per_class(scores, another);
  std::map<std::string, std::vector<double>> by_class;
  for (const LogScore& s : scores) {
    if (!(s.accuracy >= 0.0 && s.accuracy <= 1.0)) {
      throw std::invalid_argument("log '" + s.log + "' has accuracy " + std::to_string(s.accuracy) +
                                  ", not a share in [0, 1]");
    }
    by_class[s.truth].push_back(s.accuracy);
  }
  // Summed in sorted order, the range does not depend on the logs' order.
  for (auto& [name, values] : by_class) std::sort(values.begin(), values.end());
  AccuracyRange range;
  range.level = level;
  if (by_class.empty()) return range;
  // Each class's mean, summed as summarize() sums them; the squares of its
  // logs' deviations from it, pooled.
  double sum_of_means = 0.0, squares = 0.0, inverse_counts = 0.0, predicted_inverse_counts = 0.0;
  for (const auto& [name, values] : by_class) {
    const int wanted = another.empty() ? static_cast<int>(values.size()) : another.at(name);
    range.logs_per_class[name] = wanted;
    double sum = 0.0;
    for (double v : values) sum += v;
    const double n = static_cast<double>(values.size());
    const double mean = sum / n;
    sum_of_means += mean;
    for (double v : values) squares += (v - mean) * (v - mean);
    range.degrees_of_freedom += static_cast<int>(values.size()) - 1;
    inverse_counts += 1.0 / n;
    predicted_inverse_counts += 1.0 / n + 1.0 / static_cast<double>(wanted);
  }
  const double classes = static_cast<double>(by_class.size());
  range.mean = sum_of_means / classes;
  if (range.degrees_of_freedom < kLeastDegreesOfFreedom) return range;
  const double pooled_variance = squares / range.degrees_of_freedom;
  range.standard_error = std::sqrt(pooled_variance * inverse_counts) / classes;
  const double spread = std::sqrt(pooled_variance * predicted_inverse_counts) / classes;
  const boost::math::students_t t(static_cast<double>(range.degrees_of_freedom));
  range.half_width = boost::math::quantile(t, 0.5 * (1.0 + level)) * spread;
  range.low = std::max(0.0, range.mean - range.half_width);
  range.high = std::min(1.0, range.mean + range.half_width);
  return range;
}

int AccuracyRange::other_logs() const {
  int total = 0;
  for (const auto& [name, count] : logs_per_class) total += count;
  return total;
}

std::string AccuracyRange::other_counts() const {
  std::string set;
  for (const auto& [name, count] : logs_per_class)
    set += (set.empty() ? "" : ", ") + name + " " + std::to_string(count);
  return set;
}

std::string AccuracyRange::describe() const {
  const std::string set = other_counts();
  const int total = other_logs();
  if (!known()) {
    return "too few logs to say how far another set of logs would score from these (the range needs " +
           std::to_string(kLeastDegreesOfFreedom) +
           " logs or more beyond each class's first, counted over all "
           "classes; these have " +
           std::to_string(degrees_of_freedom) + ")";
  }
  char share[32];
  std::snprintf(share, sizeof(share), "%.0f%%", 100.0 * level);
  return "another " + std::to_string(total) + " logs drawn like these (" + set +
         ") would score a mean over classes between " + three_decimals(low) + " and " + three_decimals(high) + " (a " +
         share +
         " range from the spread of logs within a class, pooled over classes: " + std::to_string(degrees_of_freedom) +
         " degrees of freedom; this mean's standard error " + three_decimals(standard_error) +
         "; narrow where few logs show how often a class's logs fail whole)";
}

std::map<std::string, int> parse_logs_per_class(const std::string& text) {
  std::map<std::string, int> out;
  std::stringstream in(text);
  std::string item;
  const auto is_space = [](char c) { return std::isspace(static_cast<unsigned char>(c)) != 0; };
  const auto bad = [](const std::string& what) {
    return std::invalid_argument("'" + what + "' is not CLASS=COUNT (a class's name, '=', a whole number of logs " +
                                 "from 1 to " + std::to_string(kMostLogsPerClass) + ")");
  };
  while (std::getline(in, item, ',')) {
    const std::size_t equals = item.find('=');
    if (equals == std::string::npos || equals == 0 || equals + 1 == item.size()) throw bad(item);
    const std::string name = item.substr(0, equals);
    const std::string count = item.substr(equals + 1);
    if (std::any_of(name.begin(), name.end(), is_space) || count.size() > 7 ||
        !std::all_of(count.begin(), count.end(), [](char c) { return c >= '0' && c <= '9'; })) {
      throw bad(item);
    }
    const int value = std::stoi(count);
    if (value < 1 || value > kMostLogsPerClass) throw bad(item);
    if (out.count(name) != 0) throw std::invalid_argument("class '" + name + "' is given twice");
    out[name] = value;
  }
  // getline drops a trailing empty item: "ICE=4," would pass as "ICE=4".
  if (out.empty() || text.back() == ',') throw bad(text);
  return out;
}

}  // namespace evaluation
}  // namespace skidimm
