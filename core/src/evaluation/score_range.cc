#include "skidimm/evaluation/score_range.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <sstream>
#include <stdexcept>

namespace skidimm {
namespace evaluation {

namespace {

// Enough draws that the range's ends move by well under a thousandth
// between seeds on real scores (checked on the BorealTC runs' scores).
constexpr int kDraws = 20000;
// The spread of logs within a class is known from the logs beyond each
// class's first: at least this many of them (sum over classes of n - 1).
constexpr double kLeastDegreesOfFreedom = 3.0;
// Any fixed seed: the range is a property of the scores, so the same scores
// must give the same range on every machine. std::mt19937_64's sequence is
// fixed by the standard; `% n` (not a distribution, whose mapping is the
// library's own) keeps the draws so too. Its bias over n of a few dozen logs
// is below 1e-17.
constexpr std::mt19937_64::result_type kSeed = 20261206;

std::string three_decimals(double v) {
  char b[32];
  std::snprintf(b, sizeof(b), "%.3f", v);
  return b;
}

// The value at `share` of the sorted values, linear between neighbours.
double quantile_of_sorted(const std::vector<double>& sorted, double share) {
  const double at = share * static_cast<double>(sorted.size() - 1);
  const std::size_t below = static_cast<std::size_t>(std::floor(at));
  const std::size_t above = std::min(below + 1, sorted.size() - 1);
  return sorted[below] + (at - static_cast<double>(below)) * (sorted[above] - sorted[below]);
}

}  // namespace

void check_logs_per_class(const std::vector<LogScore>& scores, const std::map<std::string, int>& another) {
  std::map<std::string, int> scored;
  for (const LogScore& s : scores) ++scored[s.truth];
  for (const auto& [name, count] : another) {
    if (scored.count(name) == 0) {
      throw std::invalid_argument("class '" + name + "' of the other set has no scored log here");
    }
    if (count < 1) throw std::invalid_argument("class '" + name + "' of the other set needs one log or more");
  }
  for (const auto& [name, count] : scored) {
    if (another.count(name) == 0) {
      throw std::invalid_argument("the other set leaves out class '" + name +
                                  "', which these logs score: give each class's count");
    }
  }
}

AccuracyRange accuracy_range(const std::vector<LogScore>& scores, const std::map<std::string, int>& another,
                             double level) {
  if (!(level > 0.0 && level < 1.0)) throw std::invalid_argument("a range's level must be in (0, 1)");
  if (!another.empty()) check_logs_per_class(scores, another);
  std::map<std::string, std::vector<double>> by_class;
  for (const LogScore& s : scores) by_class[s.truth].push_back(s.accuracy);
  // The draws index the values: sorted, the range does not depend on the logs' order.
  for (auto& [name, values] : by_class) std::sort(values.begin(), values.end());
  AccuracyRange range;
  range.level = level;
  for (const auto& [name, values] : by_class) {
    range.logs_per_class[name] = another.empty() ? static_cast<int>(values.size()) : another.at(name);
  }
  if (by_class.empty()) return range;

  // Each class's mean, and the deviations of its logs from it, pooled over
  // the classes with two logs or more, each scaled by sqrt(n / (n - 1)) so
  // that their mean square is the classes' unbiased variance.
  std::map<std::string, double> means;
  std::vector<double> deviations;
  double squares = 0.0, degrees = 0.0;
  for (const auto& [name, values] : by_class) {
    double sum = 0.0;
    for (double v : values) sum += v;
    const double mean = sum / static_cast<double>(values.size());
    means[name] = mean;
    if (values.size() < 2) {
      range.borrowed_spread.push_back(name);
      continue;
    }
    const double n = static_cast<double>(values.size());
    for (double v : values) {
      deviations.push_back((v - mean) * std::sqrt(n / (n - 1.0)));
      squares += (v - mean) * (v - mean);
    }
    degrees += n - 1.0;
  }
  const double classes = static_cast<double>(by_class.size());
  double mean = 0.0;
  for (const auto& [name, m] : means) mean += m;
  range.mean = mean / classes;  // summarize()'s sum
  // Too few logs beyond each class's first to say how much logs of a class
  // differ (two logs of one class, alike by chance, would give every class
  // that spread, and a range of nothing).
  if (degrees < kLeastDegreesOfFreedom) return range;
  const double pooled_variance = squares / degrees;

  double variance_of_mean = 0.0;
  for (const auto& [name, values] : by_class) {
    const double n = static_cast<double>(values.size());
    double variance = pooled_variance;
    if (values.size() >= 2) {
      variance = 0.0;
      for (double v : values) variance += (v - means[name]) * (v - means[name]);
      variance /= n - 1.0;
    }
    variance_of_mean += variance / n;
  }
  range.standard_error = std::sqrt(variance_of_mean) / classes;

  std::mt19937_64 random(kSeed);
  const auto draw = [&random](std::size_t n) { return static_cast<std::size_t>(random() % n); };
  const auto clamp = [](double v) { return std::min(1.0, std::max(0.0, v)); };
  std::vector<double> outcomes;
  outcomes.reserve(kDraws);
  std::vector<double> pool;
  for (int k = 0; k < kDraws; ++k) {
    double outcome = 0.0;
    for (const auto& [name, values] : by_class) {
      const int wanted = range.logs_per_class.at(name);
      double sum = 0.0;
      if (values.size() >= 2) {
        // This estimate's uncertainty: the class's logs resampled; then the
        // other set's logs of the class drawn from that resample.
        pool.clear();
        for (std::size_t i = 0; i < values.size(); ++i) pool.push_back(values[draw(values.size())]);
        for (int i = 0; i < wanted; ++i) sum += pool[draw(pool.size())];
      } else {
        // One log: its class's mean is that log less a deviation, and each
        // log of the other set that mean plus another.
        const double centre = values.front() - deviations[draw(deviations.size())];
        for (int i = 0; i < wanted; ++i) sum += clamp(centre + deviations[draw(deviations.size())]);
      }
      outcome += sum / static_cast<double>(wanted) / classes;
    }
    outcomes.push_back(outcome);
  }
  std::sort(outcomes.begin(), outcomes.end());
  range.low = quantile_of_sorted(outcomes, 0.5 * (1.0 - level));
  range.high = quantile_of_sorted(outcomes, 0.5 * (1.0 + level));
  return range;
}

std::string AccuracyRange::describe() const {
  std::string set;
  int total = 0;
  for (const auto& [name, count] : logs_per_class) {
    set += (set.empty() ? "" : ", ") + name + " " + std::to_string(count);
    total += count;
  }
  if (!known()) {
    return "too few logs of each class to say how far another set of logs would score from these (the range needs "
           "three logs or more beyond each class's first)";
  }
  char share[32];
  std::snprintf(share, sizeof(share), "%.0f%%", 100.0 * level);
  std::string out = "another " + std::to_string(total) + " logs drawn like these (" + set +
                    ") would score a mean over classes between " + three_decimals(low) + " and " +
                    three_decimals(high) + " " + share + " of the time (this set: " + three_decimals(mean) +
                    ", standard error " + three_decimals(standard_error) + "; a bootstrap over each class's logs";
  if (!borrowed_spread.empty()) {
    std::string names;
    for (const std::string& c : borrowed_spread) names += (names.empty() ? "" : ", ") + c;
    out += "; " + names + (borrowed_spread.size() == 1 ? " has" : " have") +
           " one log, and the spread of the other classes' logs";
  }
  return out + ")";
}

std::map<std::string, int> parse_logs_per_class(const std::string& text) {
  std::map<std::string, int> out;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    const std::size_t equals = item.find('=');
    const std::string name = equals == std::string::npos ? std::string() : item.substr(0, equals);
    const std::string count = equals == std::string::npos ? std::string() : item.substr(equals + 1);
    char* end = nullptr;
    const long value = count.empty() ? 0 : std::strtol(count.c_str(), &end, 10);
    if (name.empty() || count.empty() || end == nullptr || *end != '\0' || value < 1 || value > 1000000) {
      throw std::invalid_argument("'" + item +
                                  "' is not CLASS=COUNT (a class's name, '=', a whole number of logs >= 1)");
    }
    if (out.count(name) != 0) throw std::invalid_argument("class '" + name + "' is given twice");
    out[name] = static_cast<int>(value);
  }
  if (out.empty()) throw std::invalid_argument("no CLASS=COUNT given");
  return out;
}

}  // namespace evaluation
}  // namespace skidimm
