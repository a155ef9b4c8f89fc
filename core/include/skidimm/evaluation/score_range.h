// How far the accuracy of the next logs may fall from the accuracy of these.
//
// A mean over classes of each class's log accuracies (log_scores.h,
// summarize()) is an estimate from a few logs per class, and logs of one
// class differ: on real runs most of a terrain's logs are read right nearly
// throughout and one in a few is read wrong nearly throughout. Another set
// of logs, however honestly held out, then scores a mean of its own, and with
// two or four logs of a class it can lie well away from this one. This says
// how far: the range that set's mean falls in, given how many logs of each
// class it holds, so that a published figure comes with what a user may
// measure on their next logs.
//
// The range is a predictive bootstrap over each class's logs, at two
// levels: the class's logs resampled (this estimate's own uncertainty),
// then the other set's logs of the class drawn from that resample (their
// spread). A class with a single log has no spread of its own; it borrows
// the deviations of the other classes' logs from their classes' means,
// pooled, around its one value (said in describe()).
#ifndef SKIDIMM_EVALUATION_SCORE_RANGE_H_
#define SKIDIMM_EVALUATION_SCORE_RANGE_H_

#include <limits>
#include <map>
#include <string>
#include <vector>

#include "skidimm/evaluation/log_scores.h"

namespace skidimm {
namespace evaluation {

struct AccuracyRange {
  // The share of other sets whose mean over classes falls in [low, high].
  double level = 0.0;
  double low = std::numeric_limits<double>::quiet_NaN();
  double high = std::numeric_limits<double>::quiet_NaN();
  // This set's mean over classes, and its standard error from the spread of
  // each class's logs: sqrt(sum_c s_c^2 / n_c) / C.
  double mean = std::numeric_limits<double>::quiet_NaN();
  double standard_error = std::numeric_limits<double>::quiet_NaN();
  std::map<std::string, int> logs_per_class;  // of the other set
  std::vector<std::string> borrowed_spread;   // classes of one log here (their spread is the others')

  // False where the logs say too little about how much a class's logs
  // differ: fewer than three logs beyond each class's first, summed over
  // the classes.
  bool known() const { return low == low; }
  // One sentence: the range, the set it is for, and how it was made.
  std::string describe() const;
};

// The range of the mean over classes of the accuracies of another set of
// logs holding `another[c]` logs of each class c (empty: as many of each as
// `scores` holds), drawn as `scores`' logs were; `level` in (0, 1).
// Deterministic: the same scores, in any order, give the same range. Throws
// std::invalid_argument when `another` names a class `scores` has not, or
// leaves out one it has, or asks for fewer than one log of a class.
AccuracyRange accuracy_range(const std::vector<LogScore>& scores, const std::map<std::string, int>& another = {},
                             double level = 0.9);

// Throws std::invalid_argument, as accuracy_range() does, unless `another`
// gives one log or more for each class of `scores` and names no other.
void check_logs_per_class(const std::vector<LogScore>& scores, const std::map<std::string, int>& another);

// "ASPHALT=2,ICE=4" as logs per class, for accuracy_range(); throws
// std::invalid_argument naming the item that is not CLASS=COUNT (COUNT >= 1).
std::map<std::string, int> parse_logs_per_class(const std::string& text);

}  // namespace evaluation
}  // namespace skidimm

#endif  // SKIDIMM_EVALUATION_SCORE_RANGE_H_
