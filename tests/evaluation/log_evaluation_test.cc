#include "skidimm/evaluation/log_evaluation.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>

#include "core/test_banks.h"
#include "skidimm/io/sample_source.h"

namespace skidimm {
namespace evaluation {
namespace {

using skidimm_test::BankBuilder;
using skidimm_test::ScalarLinearModel;
using skidimm_test::vec;

// Steps from a list, with their truth in truth_mode.
class ListSource : public SampleSource {
 public:
  explicit ListSource(std::vector<LogSample> samples) : samples_(std::move(samples)) {}
  bool next(LogSample* sample) override {
    if (next_ >= samples_.size()) return false;
    *sample = samples_[next_++];
    return true;
  }
  bool has_truth() const override { return true; }

 private:
  std::vector<LogSample> samples_;
  std::size_t next_ = 0;
};

// Two modes that hold x near 1 (mode0: x' = -x + u) and near 0.25 (mode1:
// x' = -2x + 0.5u) under u = 1. Log "a": 30 steps measuring 1 (mode0),
// log "b": 30 steps measuring 0.25 (mode1), 0.1 s apart.
std::vector<LogSample> log_of(const std::string& truth, double z, double t0) {
  std::vector<LogSample> out;
  for (int k = 0; k < 30; ++k) {
    LogSample s;
    s.t = t0 + 0.1 * k;
    s.u = vec({1.0});
    s.z = vec({z});
    s.truth_mode = truth;
    s.row = k + 1;
    out.push_back(s);
  }
  return out;
}

Bank two_modes() {
  BankBuilder b;
  b.models = {std::make_shared<ScalarLinearModel>(-1.0, 1.0), std::make_shared<ScalarLinearModel>(-2.0, 0.5)};
  b.q = {Eigen::MatrixXd::Constant(1, 1, 0.01)};
  b.r = Eigen::MatrixXd::Constant(1, 1, 0.25);  // noisy enough that a change takes a few steps to show
  b.x0 = vec({1.0});
  return b.build();
}

// One IMM over both logs: each log's result covers its own steps, the whole
// run has the one switch, and log b's first steps are scored as the run left
// the filter (sure of mode0), not from the prior as b alone is.
TEST(EvaluateSpliced, ScoresEachLogsStepsOfOneRunOverAll) {
  const Bank bank = two_modes();
  std::vector<LogSample> both = log_of("mode0", 1.0, 0.0);
  const std::vector<LogSample> b = log_of("mode1", 0.25, 3.0);
  both.insert(both.end(), b.begin(), b.end());
  ListSource spliced(both);
  LogResult whole;
  const std::vector<LogResult> logs = evaluate_spliced(bank, &spliced, {"a", "b"}, {30, 30}, &whole);
  ASSERT_EQ(logs.size(), 2u);
  EXPECT_EQ(logs[0].name, "a");
  EXPECT_EQ(logs[0].steps, 30);
  EXPECT_NEAR(logs[0].metrics.duration + logs[1].metrics.duration, whole.metrics.duration, 1e-12);
  EXPECT_NEAR(logs[0].metrics.correct + logs[1].metrics.correct, whole.metrics.correct, 1e-12);
  ASSERT_EQ(whole.metrics.switches.size(), 1u);
  EXPECT_EQ(whole.metrics.switches[0].to, "mode1");
  EXPECT_NEAR(whole.metrics.switches[0].time, 3.0, 1e-12);
  EXPECT_TRUE(logs[1].metrics.switches.empty()) << "a log's own steps hold one truth";

  EXPECT_GT(logs[0].metrics.accuracy(), 0.9);
  // Log b's first step still answers mode0: the filter carried on from log a.
  EXPECT_GT(whole.metrics.switches[0].first_latency, 0.0);
  EXPECT_GT(logs[1].metrics.confusion.at("mode1").at("mode0"), 0.0);
  ListSource alone(b);
  const LogResult fresh = evaluate_log(bank, &alone, "b", "");
  EXPECT_NEAR(fresh.metrics.duration, logs[1].metrics.duration, 1e-12);
  EXPECT_NE(fresh.metrics.truth_probability, logs[1].metrics.truth_probability);
}

// Steps outside the input range a class was fitted on are counted against
// the class estimated there and against the true class. mode0 was fitted on
// u in [0.5, 1.5], mode1 on [0.9, 1.1]; log a (mode0, estimated mode0 on
// nearly every step) is driven at u = 1 for 10 steps, then at 2 (outside
// both) and at 1.2 (outside mode1 only). The counts are the steps', by hand.
TEST(EvaluateLog, CountsTheStepsOutsideTheInputsEachClassWasFittedOn) {
  Bank bank = two_modes();
  bank.config.modes[0].fitted_inputs["u"] = {0.5, 1.5};
  bank.config.modes[1].fitted_inputs["u"] = {0.9, 1.1};
  std::vector<LogSample> steps = log_of("mode0", 1.0, 0.0);
  for (int k = 10; k < 20; ++k) steps[static_cast<std::size_t>(k)].u = vec({2.0});
  for (int k = 20; k < 30; ++k) steps[static_cast<std::size_t>(k)].u = vec({1.2});
  ListSource source(steps);
  std::vector<std::string> estimates;
  const LogResult r =
      evaluate_log(bank, &source, "a", "", {}, EstimatorOptions{},
                   [&](const LogSample&, const LabelledStep& step) { estimates.push_back(step.estimate); });
  ASSERT_EQ(estimates.size(), 30u);
  long outside_estimate = 0, right_outside = 0, right_inside = 0;
  for (int k = 0; k < 30; ++k) {
    const bool mode0 = estimates[static_cast<std::size_t>(k)] == "mode0";
    const double u = steps[static_cast<std::size_t>(k)].u[0];
    if (mode0 ? (u < 0.5 || u > 1.5) : (u < 0.9 || u > 1.1)) ++outside_estimate;
    if (u > 1.5 && mode0) ++right_outside;
    if (u <= 1.5 && mode0) ++right_inside;
  }
  const ExtrapolationCounts& e = r.extrapolation;
  EXPECT_EQ(e.steps, 30);
  EXPECT_EQ(e.labelled, 30);
  EXPECT_EQ(e.outside_truth, 10) << "u = 2, outside mode0's [0.5, 1.5]";
  EXPECT_EQ(e.outside_truth_right, right_outside);
  EXPECT_EQ(e.inside_truth_right, right_inside);
  EXPECT_EQ(e.outside_estimate, outside_estimate);
  EXPECT_GE(e.outside_estimate, 10);
  EXPECT_EQ(e.farthest, "u 2 (mode0 fitted on 0.5 to 1.5)");
  EXPECT_DOUBLE_EQ(e.farthest_beyond, 0.5) << "0.5 beyond a range 1 wide";

  // A bank that records no ranges counts nothing.
  ListSource again(steps);
  EXPECT_EQ(evaluate_log(two_modes(), &again, "a", "").extrapolation.steps, 0);
}

// The observer sees every step, in order, as scored: its weighted log
// p(truth) (each step's interval to the next, the last's to the one before)
// over the seconds of the truth is the log's score, and each term is at most
// 0, which is what lets tune stop a losing candidate's scoring early.
TEST(EvaluateLog, ObserverSeesEachStepAsScored) {
  const Bank bank = two_modes();
  std::vector<LogSample> steps = log_of("mode0", 1.0, 0.0);
  const std::vector<LogSample> b = log_of("mode1", 0.25, 3.0);
  for (std::size_t k = 0; k < 10; ++k) steps.push_back(b[k]);  // the score of the main truth leaves these out
  std::vector<double> times;
  double weighted = 0.0, seconds = 0.0;
  ListSource source(steps);
  const LogResult result =
      evaluate_log(bank, &source, "a", "", {}, EstimatorOptions{}, [&](const LogSample& sample, const LabelledStep& s) {
        EXPECT_EQ(s.t, sample.t);
        EXPECT_LE(s.truth_probability, 1.0);
        times.push_back(s.t);
        if (s.truth != "mode0") return;
        const std::size_t k = times.size() - 1;
        const double w = k + 1 < steps.size() ? steps[k + 1].t - steps[k].t : steps[k].t - steps[k - 1].t;
        weighted += w * std::log(std::max(s.truth_probability, kMinScoredProbability));
        seconds += w;
      });
  ASSERT_EQ(times.size(), steps.size());
  for (std::size_t k = 0; k < steps.size(); ++k) EXPECT_EQ(times[k], steps[k].t);
  EXPECT_EQ(result.steps, static_cast<long>(steps.size()));
  EXPECT_LT(weighted, 0.0);
  EXPECT_NEAR(weighted / seconds, result.metrics.truth_mean_log_probability("mode0"), 1e-12);
}

// The smallest probability the filter gave a mode says whether the floor
// changed a step (tune runs no floor candidate that could not have): above
// the floor when it never bound, the floor itself when it did; not tracked
// for smoothed estimates.
TEST(EvaluateLog, SmallestProbabilitySaysWhetherTheFloorChangedAStep) {
  std::vector<LogSample> steps = log_of("mode0", 1.0, 0.0);
  const std::vector<LogSample> b = log_of("mode1", 0.25, 3.0);
  steps.insert(steps.end(), b.begin(), b.end());
  const auto smallest_seen = [&](const Bank& bank, LogResult* result) {
    double smallest = 1.0;  // two modes: the smaller is 1 - the estimate's
    ListSource source(steps);
    *result = evaluate_log(bank, &source, "ab", "", {}, EstimatorOptions{},
                           [&](const LogSample&, const LabelledStep& s) {
                             smallest = std::min(smallest, 1.0 - s.estimate_probability);
                           });
    return smallest;
  };
  LogResult free_run;
  const double seen = smallest_seen(two_modes(), &free_run);
  EXPECT_NEAR(free_run.smallest_probability, seen, 1e-15);
  EXPECT_GT(free_run.smallest_probability, 1e-9) << "the default floor never bound";
  EXPECT_LT(free_run.smallest_probability, 0.3);

  Bank floored = two_modes();
  floored.config.mode_probability_floor = 0.3;
  LogResult floored_run;
  smallest_seen(floored, &floored_run);
  EXPECT_EQ(floored_run.smallest_probability, 0.3) << "a floored mode gets exactly the floor";

  ListSource source(steps);
  EstimatorOptions smoothed;
  smoothed.kind = EstimatorOptions::Kind::kFixedInterval;
  EXPECT_TRUE(std::isnan(evaluate_log(two_modes(), &source, "ab", "", {}, smoothed).smallest_probability));
}

}  // namespace
}  // namespace evaluation
}  // namespace skidimm
