#include "skidimm/fitting/tuning.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "core/temp_files.h"
#include "skidimm/fitting/sessions.h"

namespace skidimm {
namespace fitting {
namespace {

using skidimm_test::test_directory;
using skidimm_test::write_file;

// A log's score with only what the summaries read.
LogScore scored(const char* log, const char* truth, double accuracy, double mean_log_probability, double seconds) {
  LogScore s;
  s.log = log;
  s.truth = truth;
  s.accuracy = accuracy;
  s.mean_log_probability = mean_log_probability;
  s.seconds = seconds;
  return s;
}

TEST(GroupedFolds, LeaveOneOutAndStratifiedGroupsPartitionTheLogs) {
  const std::vector<std::string> classes{"ice", "ice", "ice", "snow", "snow", "sand", "sand", "sand", "sand"};
  std::vector<int> all(classes.size());
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  const auto loo = grouped_folds(all, classes, 0);
  ASSERT_EQ(loo.size(), all.size());
  for (std::size_t i = 0; i < loo.size(); ++i) EXPECT_EQ(loo[i], std::vector<int>{static_cast<int>(i)});

  const auto three = grouped_folds(all, classes, 3);
  ASSERT_EQ(three.size(), 3u);
  std::multiset<int> seen;
  for (const auto& fold : three) {
    seen.insert(fold.begin(), fold.end());
    std::set<std::string> fold_classes;
    for (int i : fold) fold_classes.insert(classes[static_cast<std::size_t>(i)]);
    EXPECT_GE(fold_classes.size(), 2u) << "classes are dealt out, not left in one fold";
  }
  EXPECT_EQ(seen, std::multiset<int>(all.begin(), all.end())) << "every log in exactly one fold";
  // Inner folds of a subset stay inside it.
  const std::vector<int> subset{0, 2, 3, 5, 8};
  for (const auto& fold : grouped_folds(subset, classes, 2)) {
    for (int i : fold) EXPECT_NE(std::find(subset.begin(), subset.end(), i), subset.end());
  }
  EXPECT_EQ(grouped_folds(subset, classes, 10).size(), subset.size()) << "more folds than logs: one log each";
}

TEST(Protocols, ParseTheirNamesAndRefuseOthers) {
  EXPECT_EQ(protocol_from_string("logs").kind, Protocol::Kind::kLogs);
  EXPECT_EQ(protocol_from_string("sessions").kind, Protocol::Kind::kSessions);
  const Protocol speed = protocol_from_string("extrapolation:speed");
  EXPECT_EQ(speed.kind, Protocol::Kind::kExtrapolation);
  EXPECT_EQ(speed.input, "speed");
  EXPECT_EQ(speed.fraction, 0.25);
  EXPECT_EQ(speed.name(), "extrapolation in speed");
  EXPECT_EQ(speed.slug(), "extrapolation-speed");
  EXPECT_EQ(protocol_from_string("extrapolation:turn:0.4").fraction, 0.4);
  const Protocol named = protocol_from_string("extrapolation:speed=abs(velL + velR) / 2:0.3");
  EXPECT_EQ(named.input, "speed");
  EXPECT_EQ(named.expression, "abs(velL + velR) / 2");
  EXPECT_EQ(named.fraction, 0.3);
  EXPECT_EQ(named.slug(), "extrapolation-speed");
  EXPECT_EQ(protocol_from_string("extrapolation:s=max(velL, velR)").expression, "max(velL, velR)");
  for (const char* bad : {"runs", "extrapolation:", "extrapolation:turn:1.5", "extrapolation:turn:x", "",
                          "extrapolation:speed=", "extrapolation:a b=velL", "extrapolation:=velL"}) {
    try {
      protocol_from_string(bad);
      ADD_FAILURE() << "accepted '" << bad << "'";
    } catch (const Error& e) {
      EXPECT_THAT(e.what(), ::testing::HasSubstr("protocol '" + std::string(bad) + "'"));
    }
  }
}

// Extrapolation holds out, per class, the logs driven hardest in the input
// (largest ranking), round(fraction x logs) of those driven in it at all (a
// tenth of the class's largest or more), at least one and never all of them;
// sessions hold out every log of a session together.
TEST(Protocols, ExtrapolationHoldsOutTheHardestDrivenLogsOfEachClassAndSessionsHoldOutWholeSessions) {
  const std::vector<std::string> classes{"ice", "ice", "ice", "ice", "snow", "snow", "sand", "rock", "rock", "ice", "ice"};
  // ice 9 and 10 are runs on the spot (a speed under a tenth of ice's fastest):
  // not slower straight runs, they stay in training.
  const std::vector<double> speed{0.2, 0.8, 0.3, 0.5, 0.1, 0.4, 9.0, 0.3, 0.3, 0.0, 0.05};
  const std::vector<int> all{0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10};
  Protocol extrapolation = protocol_from_string("extrapolation:speed");
  auto folds = protocol_folds(extrapolation, all, classes, {}, speed, 0);
  ASSERT_EQ(folds.size(), 1u);
  // ice: round(0.25 x 4 driven) = 1, the fastest (1); snow: 1 of 2, the faster
  // (5); sand: its only log stays; rock: a tie, the first listed (7).
  EXPECT_EQ(folds[0], (std::vector<int>{1, 5, 7}));
  extrapolation.fraction = 0.6;  // ice: round(2.4) = 2; snow: 1 (never all)
  EXPECT_EQ(protocol_folds(extrapolation, all, classes, {}, speed, 0)[0], (std::vector<int>{1, 3, 5, 7}));
  extrapolation.fraction = 0.99;  // never every driven log: ice keeps its slowest driven run (0)
  EXPECT_EQ(protocol_folds(extrapolation, all, classes, {}, speed, 0)[0], (std::vector<int>{1, 2, 3, 5, 7}));
  // Only the members count: without log 1, ice's fastest is 3.
  EXPECT_EQ(protocol_folds(protocol_from_string("extrapolation:speed"), {0, 2, 3, 4, 5}, classes, {}, speed, 0)[0],
            (std::vector<int>{3, 5}));
  // One driven ice run and runs on the spot: nothing of ice to hold out.
  EXPECT_THROW(protocol_folds(extrapolation, {6, 4, 1, 9, 10}, classes, {}, speed, 0), Error);

  const std::vector<std::string> sessions{"mon", "mon", "tue", "", "tue", "mon", "", "wed", "wed", "wed", "tue"};
  folds = protocol_folds(protocol_from_string("sessions"), all, classes, sessions, {}, 0);
  std::set<std::vector<int>> got(folds.begin(), folds.end());
  EXPECT_EQ(got, (std::set<std::vector<int>>{{0, 1, 5}, {2, 4, 10}, {7, 8, 9}, {3}, {6}}));
  EXPECT_THROW(protocol_folds(protocol_from_string("sessions"), {0, 1}, classes, sessions, {}, 0), Error);
  EXPECT_EQ(protocol_folds(Protocol{}, all, classes, sessions, {}, 0), grouped_folds(all, classes, 0));
}

// Four classes: a uniform guess scores log(1/4) = -1.386 at every step.
TEST(Separability, SaysWhetherHeldOutScoresBeatAUniformGuess) {
  auto scores = [](std::initializer_list<std::pair<const char*, double>> logs) {
    std::vector<LogScore> out;
    for (const auto& [truth, log_p] : logs) out.push_back(scored("log", truth, 0.25, log_p, 10));
    return out;
  };
  const evaluation::Separability none =
      evaluation::separability(scores({{"a", -1.5}, {"b", -1.39}, {"c", -1.3}, {"d", -1.40}}), 4);
  EXPECT_NEAR(none.uniform, -std::log(4.0), 1e-15);
  EXPECT_EQ(none.verdict, evaluation::Separability::Verdict::kNotSeparated);
  EXPECT_THAT(none.describe(), ::testing::StartsWith("these modes cannot be told apart from these logs"));
  EXPECT_THAT(none.describe(), ::testing::HasSubstr("-1.386 for a uniform guess over 4 classes"));
  EXPECT_THAT(none.describe(), ::testing::HasSubstr("fit on logs that excite what differs")) << "accuracy 0.25";
  // The same log probabilities where the most likely class is right 90% of the time: sure when wrong, not alike.
  std::vector<LogScore> sure = scores({{"a", -1.5}, {"b", -1.39}, {"c", -1.3}, {"d", -1.40}});
  for (LogScore& l : sure) l.accuracy = 0.9;
  const evaluation::Separability overconfident = evaluation::separability(sure, 4);
  EXPECT_EQ(overconfident.verdict, evaluation::Separability::Verdict::kNotSeparated);
  EXPECT_NEAR(overconfident.accuracy, 0.9, 1e-15);
  EXPECT_THAT(overconfident.describe(),
              ::testing::HasSubstr("here the most likely class is right 0.900 of the time against 0.250 by chance, so "
                                   "the classes differ and the probabilities are too sure when wrong"));
  EXPECT_THAT(overconfident.describe(), ::testing::Not(::testing::HasSubstr("fit on logs that excite")));

  const evaluation::Separability clear =
      evaluation::separability(scores({{"a", -0.2}, {"b", -0.3}, {"c", -1.6}, {"d", -0.25}}), 4);
  EXPECT_EQ(clear.verdict, evaluation::Separability::Verdict::kSeparated);  // mean -0.5875 +- 0.34
  EXPECT_EQ(clear.not_separated, std::vector<std::string>{"c"});
  EXPECT_THAT(clear.describe(), ::testing::EndsWith("no better than the guess: c"));

  const evaluation::Separability unclear =
      evaluation::separability(scores({{"a", -0.2}, {"b", -2.5}, {"c", -1.3}, {"d", -1.0}}), 4);
  EXPECT_EQ(unclear.verdict, evaluation::Separability::Verdict::kUnclear);  // mean -1.25, SE 0.47
  EXPECT_NEAR(unclear.standard_error, std::sqrt((1.1025 + 1.5625 + 0.0025 + 0.0625) / 3.0 / 4.0), 1e-12);

  const evaluation::Separability worse = evaluation::separability(scores({{"a", -4.0}, {"b", -3.9}}), 4);
  EXPECT_EQ(worse.verdict, evaluation::Separability::Verdict::kWorse);
  EXPECT_THAT(worse.describe(), ::testing::StartsWith("worse than a uniform guess"));

  // A mean that is the guess to round-off (uniform probabilities summed in
  // another order): not told apart, nor worse, whichever side it lands on.
  // One log has no standard error: said so, not shown as +- 0.
  const double guess = -std::log(4.0);
  for (const double log_p :
       {guess, std::nextafter(guess, 0.0), std::nextafter(guess, -1.0), guess * (1.0 + 4e-16), guess * (1.0 - 4e-16)}) {
    const evaluation::Separability one = evaluation::separability(scores({{"a", log_p}}), 4);
    EXPECT_EQ(one.verdict, evaluation::Separability::Verdict::kNotSeparated) << log_p - guess;
    EXPECT_THAT(one.describe(), ::testing::HasSubstr("on one log (no standard error over logs)"));
  }
  EXPECT_EQ(evaluation::separability(scores({{"a", guess}, {"b", std::nextafter(guess, 0.0)}}), 4).verdict,
            evaluation::Separability::Verdict::kNotSeparated);
}

TEST(TuningSummary, AveragesLogsWithinAClassThenClasses) {
  std::vector<LogScore> scores(4);
  scores[0] = scored("a", "ice", 1.0, -0.1, 10);
  scores[1] = scored("b", "ice", 0.5, -0.5, 100);
  scores[2] = scored("c", "ice", 0.0, -3.0, 10);
  scores[3] = scored("d", "snow", 0.2, -1.0, 10);
  const Summary s = summarize(scores);
  EXPECT_DOUBLE_EQ(s.class_accuracy.at("ice"), 0.5);
  EXPECT_DOUBLE_EQ(s.class_log_probability.at("ice"), -3.6 / 3.0);
  EXPECT_DOUBLE_EQ(s.accuracy, 0.35);
  EXPECT_DOUBLE_EQ(s.mean_log_probability, (-1.2 - 1.0) / 2.0);
}

const std::string kTuningBank = R"(name: tune_test
states: [V, omega]
inputs: [phi_dot_L, phi_dot_R]
measurement: {observe: [V, omega], R: {std: [0.02, 0.03]}}
transition: {stay: 0.99}
initial: {covariance: {std: [1, 1]}}
modes:
  - {name: a, model: ltc_linear, params: {A: [[-1, 0], [0, -1]], B: [[0.1, 0.1], [-0.1, 0.1]]}, Q: {diagonal: [0.01, 0.02]}}
  - {name: b, model: ltc_linear, params: {A: [[-2, 0], [0, -2]], B: [[0.2, 0.2], [-0.2, 0.2]]}, Q: {diagonal: [0.03, 0.04]}}
)";

TEST(TunedSettings, ApplyScalesFittedValuesAndSetsTheTransitionAndFloor) {
  Bank bank = Bank::load(write_file(test_directory() / "b.yaml", kTuningBank), {SKIDIMM_PLUGIN_DIR});
  bank.config.modes[1].r = Eigen::Vector2d(0.01, 0.0025).asDiagonal();  // mode b's own R: scaled alike
  FittedValues fitted = values_of(bank);
  fitted.parameters[1][0] = -3.0;
  TunedSettings s;
  s.r_scale = 4.0;
  s.r_component = Eigen::Vector2d(1.0, 2.0);
  s.q_scale = 10.0;
  s.q_mode = Eigen::Vector2d(1.0, 0.5);
  s.dwell_seconds = 20.0;
  s.probability_floor = 1e-4;
  s.likelihood_weight = 0.25;
  apply(fitted, s, &bank);
  Eigen::VectorXd p(8);
  bank.models[1]->get_parameters(p);
  EXPECT_EQ(p[0], -3.0);
  EXPECT_NEAR(bank.config.measurement.r(0, 0), 4.0 * 0.0004, 1e-15);
  EXPECT_NEAR(bank.config.measurement.r(1, 1), 4.0 * 4.0 * 0.0009, 1e-15);
  EXPECT_EQ(bank.config.modes[0].r.size(), 0);
  EXPECT_NEAR(bank.config.modes[1].r(0, 0), 4.0 * 0.01, 1e-15);
  EXPECT_NEAR(bank.config.modes[1].r(1, 1), 4.0 * 4.0 * 0.0025, 1e-15);
  EXPECT_NEAR(bank.config.modes[0].q_intensity(1, 1), 10.0 * 0.02, 1e-15);
  EXPECT_NEAR(bank.config.modes[1].q_intensity(0, 0), 5.0 * 0.03, 1e-15);
  EXPECT_EQ(bank.config.transition.kind, TransitionConfig::Kind::kDwellTimes);
  EXPECT_EQ(bank.config.transition.dwell_seconds, Eigen::Vector2d(20.0, 20.0));
  EXPECT_EQ(bank.config.mode_probability_floor, 1e-4);
  EXPECT_EQ(bank.config.likelihood_weight, 0.25);
  EXPECT_EQ(
      s.describe(bank.config),
      "objective , R x 4, R[omega] std x 2, Q x 10, Q[b] x 0.5, dwell 20 s, floor 0.0001, likelihood weight 0.25");
  EXPECT_THROW(knob_from_string("r_scale"), Error);
  EXPECT_EQ(knob_from_string("q-modes"), Knob::kQModes);
  EXPECT_EQ(knob_from_string("likelihood-weight"), Knob::kLikelihoodWeight);
  EXPECT_EQ(knob_from_string("likelihood-dof"), Knob::kLikelihoodDof);
  s.likelihood_dof = 4.0;
  apply(fitted, s, &bank);
  EXPECT_EQ(bank.config.likelihood_dof, 4.0);
  EXPECT_THAT(s.describe(bank.config), ::testing::EndsWith("likelihood weight 0.25, likelihood dof 4"));
  EXPECT_EQ(knob_from_string("extrapolation-scale"), Knob::kExtrapolationScale);
  s.extrapolation_scale = 0.5;
  apply(fitted, s, &bank);
  EXPECT_EQ(bank.config.extrapolation_scale, 0.5);
  EXPECT_THAT(s.describe(bank.config), ::testing::EndsWith("likelihood dof 4, extrapolation scale 0.5"));
  // Searched and kept off: said so, and the bank has none.
  s.extrapolation_scale = 0.0;
  apply(fitted, s, &bank);
  EXPECT_EQ(bank.config.extrapolation_scale, 0.0);
  EXPECT_THAT(s.describe(bank.config), ::testing::EndsWith("extrapolation scale off"));
}

TEST(Sessions, APatternMatchesAPathOrItsEndAndEveryLogNeedsOne) {
  const auto file = write_file(test_directory() / "sessions.txt",
                               "# glob            session\n"
                               "SNOW/pro_0[0-2].csv  snow-a   # the first three runs\n"
                               "\n"
                               "SNOW/pro_*.csv  snow-b\n"
                               "/abs/ice/*.csv  ice\n");
  const auto patterns = read_sessions_file(file);
  ASSERT_EQ(patterns.size(), 3u);
  EXPECT_EQ(patterns[1].line, 4);
  EXPECT_EQ(sessions_of({"../data/SNOW/pro_01.csv", "SNOW/pro_05.csv", "/abs/ice/pro_00.csv"}, patterns, file),
            (std::vector<std::string>{"snow-a", "snow-b", "ice"}));
  try {
    sessions_of({"SNOW/pro_01.csv", "ice/pro_00.csv", "x/SNOW/sub/pro_01.csv"}, patterns, file);
    ADD_FAILURE() << "accepted logs of no session";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("sessions.txt: no line gives the session of 2 log(s)"));
    EXPECT_THAT(e.what(), ::testing::HasSubstr("\n  ice/pro_00.csv\n  x/SNOW/sub/pro_01.csv"));
  }
  const auto bad = write_file(test_directory() / "bad.txt", "SNOW/*.csv snow extra\n");
  EXPECT_THROW(
      {
        try {
          read_sessions_file(bad);
        } catch (const Error& e) {
          EXPECT_THAT(e.what(), ::testing::HasSubstr("bad.txt:1: expected 'GLOB SESSION'"));
          throw;
        }
      },
      Error);
}

const std::string kBorealTc = std::string(SKIDIMM_SHARED_DATA_DIR) + "/borealtc";

// A BorealTC run of the shared data, its IMU file merged.
TuningLog borealtc_log(const std::string& terrain, const std::string& run, const std::string& session = "") {
  TuningLog l;
  l.spec = parse_log_spec(terrain + "=" + kBorealTc + "/" + terrain + "/pro_" + run + ".csv+" + kBorealTc + "/" +
                          terrain + "/imu_" + run + ".csv");
  l.session = session;
  return l;
}

Bank bundled_borealtc_bank() {
  return Bank::load(std::string(SKIDIMM_SOURCE_DIR) + "/configs/borealtc/terrains.yaml", {SKIDIMM_PLUGIN_DIR});
}

// The bundled BorealTC bank's models kept (objective none), its likelihood
// weight tuned in one sweep, leave-one-log-out inside.
TuneOptions weight_only_options() {
  TuneOptions options;
  options.objectives = {"none"};
  options.separable = {"none"};
  options.knobs = {Knob::kLikelihoodWeight};
  options.sweeps = 1;
  options.inner_folds = 0;
  options.threads = 2;
  options.sampling = bundled_borealtc_bank().config.sampling;
  return options;
}

const std::map<std::string, BankFitter> kKeepModels{{"none", [](Bank*, const std::vector<ModeLogs>&) {}}};

// Logs kept aside are neither fitted nor tuned on: tuning with them in the
// lockbox chooses what tuning without them does, and scores them once with
// the bank it ends with. On real BorealTC runs, the bundled bank's models
// kept (objective none), the likelihood weight tuned.
TEST(Tune, LockboxLogsAreScoredOnceAndChangeNothingElse) {
  if (!std::filesystem::exists(kBorealTc)) GTEST_SKIP() << "no shared data at " << kBorealTc;
  const auto log = [](const std::string& terrain, const std::string& run) { return borealtc_log(terrain, run); };
  const auto make_bank = bundled_borealtc_bank;
  const auto& fitters = kKeepModels;
  std::vector<TuningLog> development{log("ICE", "04"), log("ICE", "11"), log("FLOORING", "01"), log("FLOORING", "08")};
  std::vector<TuningLog> with_lockbox = development;
  with_lockbox.push_back(log("ICE", "07"));
  with_lockbox.back().lockbox = true;
  TuneOptions options = weight_only_options();
  const TuneResult without = tune(make_bank, development, fitters, options);
  const TuneResult with = tune(make_bank, with_lockbox, fitters, options);
  EXPECT_EQ(with.settings.likelihood_weight, without.settings.likelihood_weight);
  ASSERT_EQ(with.assessments.size(), 1u);
  ASSERT_EQ(with.assessments[0].scores.size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(with.assessments[0].scores[i].log, without.assessments[0].scores[i].log);
    EXPECT_EQ(with.assessments[0].scores[i].mean_log_probability,
              without.assessments[0].scores[i].mean_log_probability);
  }
  // Each held-out log is its own fold here, and its settings were chosen by
  // the inner cross-validation over the other three: the score that chose
  // them is what a tune of those three alone selects by.
  for (std::size_t i = 0; i < 4; ++i) EXPECT_EQ(without.assessments[0].scores[i].fold, static_cast<int>(i));
  const std::vector<TuningLog> others(development.begin() + 1, development.end());
  TuneOptions selection_only = options;
  selection_only.assess = false;
  const TuneResult without_first = tune(make_bank, others, fitters, selection_only);
  EXPECT_EQ(without.assessments[0].scores[0].selection_score, without_first.selection.mean_log_probability);
  for (const LogScore& s : without_first.selection_scores) {
    EXPECT_EQ(s.selection_score, without_first.selection.mean_log_probability);
    EXPECT_EQ(s.fold, -1);
  }
  EXPECT_TRUE(without.lockbox.scores.empty());
  ASSERT_EQ(with.lockbox.scores.size(), 1u);
  EXPECT_EQ(with.lockbox.scores[0].selection_score, with.selection.mean_log_probability);
  EXPECT_EQ(with.lockbox.scores[0].log, "pro_07.csv+imu_07.csv");
  EXPECT_EQ(with.lockbox.scores[0].truth, "ICE");
  // Scored by the bank the tune ends with.
  Bank tuned = make_bank();
  apply(with.fitted, with.settings, &tuned);
  const TuningLog held = log("ICE", "07");
  const LogScore direct = score_logs(tuned, {&held}, options.sampling).front();
  EXPECT_EQ(with.lockbox.scores[0].mean_log_probability, direct.mean_log_probability);
  EXPECT_EQ(with.lockbox.scores[0].accuracy, direct.accuracy);

  // Spliced: two folds of one ICE and one FLOORING run each, each fold one
  // run with a change of class; every log still scored once.
  options.splice = true;
  options.folds = 2;
  options.inner_folds = 2;
  const TuneResult spliced = tune(make_bank, development, fitters, options);
  ASSERT_EQ(spliced.assessments[0].scores.size(), 4u);
  EXPECT_EQ(spliced.assessments[0].spliced.switches.size(), 2u);
  EXPECT_EQ(spliced.assessments[0].spliced_decision.switches.size(), 2u);
  for (const evaluation::SwitchDetection& d : spliced.assessments[0].spliced.switches) {
    EXPECT_EQ(d.from, "FLOORING") << "classes take turns, in name order";
    EXPECT_EQ(d.to, "ICE");
  }
}

// A held-out set two protocols share is searched once: a session of one log
// holds out what that log's fold of `logs` does, and gets the same settings
// and scores; the work statement counts the searches made.
TEST(Tune, ProtocolsThatHoldOutTheSameLogsShareTheirSearch) {
  if (!std::filesystem::exists(kBorealTc)) GTEST_SKIP() << "no shared data at " << kBorealTc;
  // Sessions: ICE 04 alone, ICE 11 alone, the two FLOORING runs together.
  const std::vector<TuningLog> logs{borealtc_log("ICE", "04", "ice-a"), borealtc_log("ICE", "11", "ice-b"),
                                    borealtc_log("FLOORING", "01", "floor"), borealtc_log("FLOORING", "08", "floor")};
  TuneOptions options = weight_only_options();
  options.protocols = {protocol_from_string("logs"), protocol_from_string("sessions")};
  std::vector<std::string> lines;
  options.progress = [&](const std::string& line) { lines.push_back(line); };
  const TuneResult result = tune(bundled_borealtc_bank, logs, kKeepModels, options);
  // The selection, four folds of `logs`, and the FLOORING session: six
  // searches, not eight.
  ASSERT_FALSE(lines.empty());
  EXPECT_THAT(lines.front(), ::testing::HasSubstr(" 6 searches of at most")) << lines.front();
  ASSERT_EQ(result.assessments.size(), 2u);
  const Assessment& by_log = result.assessments[0];
  const Assessment& by_session = result.assessments[1];
  ASSERT_EQ(by_log.scores.size(), 4u);
  ASSERT_EQ(by_session.scores.size(), 4u);
  for (const LogScore& s : by_session.scores) {
    const auto same = std::find_if(by_log.scores.begin(), by_log.scores.end(),
                                   [&](const LogScore& l) { return l.log == s.log; });
    ASSERT_NE(same, by_log.scores.end()) << s.log;
    if (s.truth == "ICE") {
      EXPECT_EQ(s.settings, same->settings) << s.log;
      EXPECT_EQ(s.mean_log_probability, same->mean_log_probability) << s.log;
    }
  }
}

// A line is searched over its whole grid (the default), or walked from its
// start while each step beats the best (LineSearch::kWalk): on real BorealTC
// runs, the likelihood weight, started from the best of the bundled bank's
// times powers of 4, from 16 times less and from 4 times more (within the
// first sweep's reach of 4^3: a line whose farthest candidate wins goes
// on). The grid's scores are computed here, each candidate's bank scoring
// every log (the models are kept, so every fold's are the bank's), and each
// search's choice and its number of runs follow from them: both choose the
// grid's best (these scores rise to one peak), the walk after the runs up
// to it and the first that lost, downward from one start and upward from
// another.
TEST(Tune, AWalkChoosesTheGridsBestOfOnePeakWithFewerRuns) {
  if (!std::filesystem::exists(kBorealTc)) GTEST_SKIP() << "no shared data at " << kBorealTc;
  const std::vector<TuningLog> logs{borealtc_log("ICE", "04"), borealtc_log("ICE", "11"),
                                    borealtc_log("FLOORING", "01"), borealtc_log("FLOORING", "08")};
  std::vector<const TuningLog*> each;
  for (const TuningLog& l : logs) each.push_back(&l);
  const double bundled = bundled_borealtc_bank().config.likelihood_weight;
  double best = bundled;
  {
    TuneOptions options = weight_only_options();
    double best_score = -std::numeric_limits<double>::infinity();
    for (int k = -4; k <= 4; ++k) {
      Bank b = bundled_borealtc_bank();
      b.config.likelihood_weight = bundled * std::pow(4.0, k);
      if (b.config.likelihood_weight > 1.0) continue;
      const double score = summarize(score_logs(b, each, options.sampling)).mean_log_probability;
      if (score > best_score) {
        best_score = score;
        best = b.config.likelihood_weight;
      }
    }
    ASSERT_LT(best, bundled * 64) << "a peak inside the powers tried";
    ASSERT_GT(best, bundled / 64) << "a peak inside the powers tried";
  }
  bool walked_down = false, walked_up = false;
  int all_walk_runs = 0, all_grid_runs = 0;
  for (const double start : {best / 16, best, best * 4}) {
    SCOPED_TRACE("start " + std::to_string(start));
    const auto starting_bank = [start] {
      Bank b = bundled_borealtc_bank();
      b.config.likelihood_weight = start;
      return b;
    };
    TuneOptions options = weight_only_options();
    options.assess = false;
    std::vector<std::string> lines;
    options.progress = [&](const std::string& line) { lines.push_back(line); };
    std::map<int, double> grid;  // 4^k times the start, within [1e-4, 1]
    for (int k = -3; k <= 3; ++k) {
      Bank b = starting_bank();
      b.config.likelihood_weight = start * std::pow(4.0, k);
      if (b.config.likelihood_weight < 1e-4 || b.config.likelihood_weight > 1.0) continue;
      grid[k] = summarize(score_logs(b, each, options.sampling)).mean_log_probability;
    }
    ASSERT_GE(grid.size(), 4u) << "the start and three others at least";
    int peak = 0;
    for (const auto& [k, score] : grid) {
      if (score > grid[peak]) peak = k;
    }
    for (const auto& [k, score] : grid) {
      if (k < peak) {
        EXPECT_LT(score, grid.at(k + 1)) << "one peak: rising to it, k = " << k;
      } else if (k > peak) {
        EXPECT_LT(score, grid.at(k - 1)) << "one peak: falling after it, k = " << k;
      }
    }
    int walked = 0, walk_runs = 1;  // the start's own scoring
    for (const int direction : {-1, 1}) {
      for (int k = direction; grid.count(k) != 0; k += direction) {
        ++walk_runs;
        if (!(grid[k] > grid[walked] + 1e-9)) break;
        walked = k;
      }
      if (walked != 0) break;
    }
    EXPECT_EQ(walked, peak);
    walked_down = walked_down || walked < 0;
    walked_up = walked_up || walked > 0;

    const TuneResult by_grid = tune(starting_bank, logs, kKeepModels, options);
    EXPECT_EQ(by_grid.settings.likelihood_weight, start * std::pow(4.0, peak));
    EXPECT_EQ(by_grid.selection.mean_log_probability, grid[peak]);
    ASSERT_FALSE(lines.empty());
    EXPECT_THAT(lines.back(), ::testing::HasSubstr("searches: " + std::to_string(grid.size()) + " settings scored"));

    lines.clear();
    options.line_search = TuneOptions::LineSearch::kWalk;
    const TuneResult by_walk = tune(starting_bank, logs, kKeepModels, options);
    EXPECT_EQ(by_walk.settings.likelihood_weight, by_grid.settings.likelihood_weight);
    EXPECT_EQ(by_walk.selection.mean_log_probability, by_grid.selection.mean_log_probability);
    ASSERT_FALSE(lines.empty());
    EXPECT_THAT(lines.back(), ::testing::HasSubstr("searches: " + std::to_string(walk_runs) + " settings scored"));
    EXPECT_LE(walk_runs, static_cast<int>(grid.size()));
    all_walk_runs += walk_runs;
    all_grid_runs += static_cast<int>(grid.size());
  }
  EXPECT_TRUE(walked_down) << "from the start above the peak";
  EXPECT_TRUE(walked_up) << "from the start below it";
  EXPECT_LT(all_walk_runs, all_grid_runs);
}

// A line whose farthest candidate one way is its best goes on, a factor at
// a time, while the score rises: what the search hands on does not depend
// on how far from it the bank started. R scaled up 4^5 = 1024 times in the
// start bank puts R's best beyond the first sweep's reach (4^3 each way);
// the search from there ends on the R the search from the bank's own R
// chooses, on the same grid of powers of 4. Grid and walk alike.
TEST(Tune, ASearchGoesOnBeyondItsSweepWhileTheScoreRises) {
  if (!std::filesystem::exists(kBorealTc)) GTEST_SKIP() << "no shared data at " << kBorealTc;
  const std::vector<TuningLog> logs{borealtc_log("ICE", "04"), borealtc_log("ICE", "11"),
                                    borealtc_log("FLOORING", "01"), borealtc_log("FLOORING", "08")};
  for (const auto search : {TuneOptions::LineSearch::kGrid, TuneOptions::LineSearch::kWalk}) {
    SCOPED_TRACE(search == TuneOptions::LineSearch::kGrid ? "grid" : "walk");
    TuneOptions options = weight_only_options();
    options.knobs = {Knob::kRScale};
    options.assess = false;
    options.line_search = search;
    options.sweeps = 1;  // factors of 4 alone: both starts' candidates lie on one grid
    const auto bank_with_r_times = [](double factor) {
      return [factor] {
        Bank b = bundled_borealtc_bank();
        b.config.measurement.r *= factor;
        return b;
      };
    };
    const TuneResult near = tune(bank_with_r_times(1.0), logs, kKeepModels, options);
    const TuneResult far = tune(bank_with_r_times(1024.0), logs, kKeepModels, options);
    EXPECT_LT(far.settings.r_scale, std::pow(4.0, -3)) << "beyond the farthest the first sweep tries";
    EXPECT_EQ(far.settings.r_scale * 1024.0, near.settings.r_scale) << "the same R from either start";
    EXPECT_EQ(far.selection.mean_log_probability, near.selection.mean_log_probability);
    // One factor further would have lost: the line stopped where the score
    // stopped rising, not at a bound. (Scaling by powers of 2 is exact.)
    options.sweeps = 0;
    const TuneResult one_further =
        tune(bank_with_r_times(1024.0 * far.settings.r_scale / 4.0), logs, kKeepModels, options);
    EXPECT_LT(one_further.selection.mean_log_probability, far.selection.mean_log_probability);
  }
}

// A floor candidate below the smallest probability every run of the best
// settings reached, and above their own floor, changes no step: its runs
// would be the best's bit for bit, a tie, and the search does not run it.
// The tune's last line counts the settings scored and those known to tie.
TEST(Tune, FloorCandidatesNoRunMeetsAreTiesWithoutARun) {
  if (!std::filesystem::exists(kBorealTc)) GTEST_SKIP() << "no shared data at " << kBorealTc;
  const std::vector<TuningLog> logs{borealtc_log("ICE", "04"), borealtc_log("ICE", "11"),
                                    borealtc_log("FLOORING", "01"), borealtc_log("FLOORING", "08")};
  TuneOptions options = weight_only_options();
  options.knobs = {Knob::kFloor};
  std::vector<std::string> lines;
  options.progress = [&](const std::string& line) { lines.push_back(line); };
  const Bank bundled = bundled_borealtc_bank();
  const double start = bundled.config.mode_probability_floor;
  std::vector<double> smallest;
  std::vector<const TuningLog*> each;
  for (const TuningLog& l : logs) each.push_back(&l);
  for (const LogScore& s : score_logs(bundled, each, options.sampling)) smallest.push_back(s.smallest_probability);
  const double least = *std::min_element(smallest.begin(), smallest.end());
  ASSERT_GT(least, start * 64) << "these runs never meet the bundled floor or the candidates above it";

  // The premise: scored with the highest candidate, every log scores the same.
  Bank highest = bundled_borealtc_bank();
  highest.config.mode_probability_floor = start * 64;
  const std::vector<LogScore> at_start = score_logs(bundled, each, options.sampling);
  const std::vector<LogScore> at_highest = score_logs(highest, each, options.sampling);
  for (std::size_t i = 0; i < logs.size(); ++i) {
    EXPECT_EQ(at_highest[i].mean_log_probability, at_start[i].mean_log_probability) << logs[i].spec.name();
  }
  // The selection and the four nested searches: 5 start scorings, and each
  // search's six candidates (factors of 4 around the floor) all ties.
  const TuneResult ties = tune(bundled_borealtc_bank, logs, kKeepModels, options);
  EXPECT_EQ(ties.settings.probability_floor, start);
  ASSERT_FALSE(lines.empty());
  EXPECT_THAT(lines.back(), ::testing::HasSubstr("searches: 5 settings scored, 30 more known to tie"));

  // Started just below the smallest probability: the candidates under it
  // are ties, those above it are run. A search's logs are all four
  // (selection) or the three a nested fold leaves (the bank is not refitted:
  // the same runs).
  const double near = 0.9 * least;
  const double highest_floor = 0.5 / bundled.config.num_modes();
  long expected_ties = 0, expected_runs = 5;
  for (int held = -1; held < static_cast<int>(logs.size()); ++held) {
    double search_least = 1.0;
    for (int i = 0; i < static_cast<int>(logs.size()); ++i) {
      if (i != held) search_least = std::min(search_least, smallest[static_cast<std::size_t>(i)]);
    }
    for (int k = -3; k <= 3; ++k) {
      const double candidate = near * std::pow(4.0, k);
      if (k == 0 || candidate > highest_floor) continue;
      (candidate < search_least ? expected_ties : expected_runs) += 1;
    }
  }
  lines.clear();
  const auto near_bank = [&] {
    Bank b = bundled_borealtc_bank();
    b.config.mode_probability_floor = near;
    return b;
  };
  tune(near_bank, logs, kKeepModels, options);
  ASSERT_FALSE(lines.empty());
  EXPECT_THAT(lines.back(), ::testing::HasSubstr("searches: " + std::to_string(expected_runs) + " settings scored, " +
                                                 std::to_string(expected_ties) + " more known to tie"));
  EXPECT_GE(expected_ties, 15) << "the three below the start, in each of the five searches";
  EXPECT_LT(expected_ties, 30);
}

}  // namespace
}  // namespace fitting
}  // namespace skidimm
