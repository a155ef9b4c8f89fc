// How far the accuracy of the next logs may fall from the accuracy of these.
//
// A mean over classes of each class's log accuracies (log_scores.h,
// summarize()) is an estimate from a few logs per class, and logs of one
// class differ: on real runs most of a terrain's logs are read right nearly
// throughout and one in a few is read wrong nearly throughout. Another set
// of logs, however honestly held out, then scores a mean of its own, and with
// two or four logs of a class it can lie well away from this one. This says
// how far: the range that set's mean falls in, given how many logs of each
// class it holds.
//
// The range is the normal-theory prediction interval of the other set's
// mean over classes, from the spread of logs about their class's mean
// pooled over the classes (s^2, with sum_c (n_c - 1) degrees of freedom):
// the other set's mean minus this one's has variance
// s^2 sum_c (1 / n_c + 1 / m_c) / C^2, and the interval takes Student's t
// quantile for s^2's degrees of freedom, clamped to [0, 1]. Pooled, a class
// of one log, or of two logs alike by chance, has the others' spread rather
// than none. What it cannot see are failures no scored log shows: with few
// logs per class, and logs read right or wrong nearly throughout, another
// set falls outside it more often than the level says (docs/cli.md).
#ifndef SKIDIMM_EVALUATION_ACCURACY_RANGE_H_
#define SKIDIMM_EVALUATION_ACCURACY_RANGE_H_

#include <cmath>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "skidimm/evaluation/log_scores.h"

namespace skidimm {
namespace evaluation {

struct AccuracyRange {
  // The share of other sets the range is meant to hold the mean over
  // classes of, were logs' accuracies normal about their class's mean.
  double level = 0.0;
  double low = std::numeric_limits<double>::quiet_NaN();
  double high = std::numeric_limits<double>::quiet_NaN();
  double half_width = std::numeric_limits<double>::quiet_NaN();  // t s_pred, before [low, high] is clamped to [0, 1]
  // This set's mean over classes, and its standard error from the pooled
  // spread, s sqrt(sum_c 1 / n_c) / C (NaN where the range is not known).
  double mean = std::numeric_limits<double>::quiet_NaN();
  double standard_error = std::numeric_limits<double>::quiet_NaN();
  int degrees_of_freedom = 0;                 // sum over classes of n_c - 1
  std::map<std::string, int> logs_per_class;  // of the other set

  // False with fewer than kLeastDegreesOfFreedom: too few logs beyond each
  // class's first to say how much logs of a class differ.
  bool known() const { return !std::isnan(low); }
  // The other set: how many logs, and "ASPHALT 2, ICE 4" (logs_per_class).
  int other_logs() const;
  std::string other_counts() const;
  // One sentence: the range, the set it is for, and how it was made.
  std::string describe() const;
};

// The degrees of freedom below which accuracy_range() gives no range nor
// standard error (two logs of one class, alike by chance, would give every
// class no spread).
inline constexpr int kLeastDegreesOfFreedom = 3;

// The range of the mean over classes of the accuracies of another set of
// logs holding `another[c]` logs of each class c (empty: as many of each as
// `scores` holds), drawn as `scores`' logs were; `level` in (0, 1). Throws
// std::invalid_argument when `another` names a class `scores` has not, or
// leaves out one it has, or asks for fewer than one log of a class or more
// than kMostLogsPerClass, or when an accuracy is not in [0, 1].
AccuracyRange accuracy_range(const std::vector<LogScore>& scores, const std::map<std::string, int>& another = {},
                             double level = 0.9);

// The most logs of a class another set may be asked to hold.
inline constexpr int kMostLogsPerClass = 1000000;

// Throws std::invalid_argument, as accuracy_range() does, unless `another`
// gives one log or more (at most kMostLogsPerClass) for each class of
// `scores` and names no other.
void check_logs_per_class(const std::vector<LogScore>& scores, const std::map<std::string, int>& another);

// "ASPHALT=2,ICE=4" as logs per class, for accuracy_range(); throws
// std::invalid_argument naming the item that is not CLASS=COUNT (a name
// without spaces, a whole number from 1 to kMostLogsPerClass).
std::map<std::string, int> parse_logs_per_class(const std::string& text);

}  // namespace evaluation
}  // namespace skidimm

#endif  // SKIDIMM_EVALUATION_ACCURACY_RANGE_H_
