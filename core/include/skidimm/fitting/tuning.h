// Tuning: choosing what decides identification by cross-validation grouped
// by log file (`skidimm tune`).
//
// Fitting makes each mode's filter predict its own logs well. Identification
// also hangs on settings no single mode's fit can choose: how noisy the
// sensors are taken to be (R), how much each mode's filter trusts its model
// (a scale on Q), how sticky the modes are (the mean dwell time), how far an
// unlikely mode may fall (the probability floor), how much one step's evidence
// counts (the likelihood weight), and which fit objective built the models.
// The tuner chooses them to maximise the held-out mean log probability of the
// truth (accuracy is reported beside it):
//
//   for each fold (one log held out, or K groups of logs), fit the bank on the
//   other logs with each candidate objective, then score the held-out logs
//   with the IMM under each candidate setting, searched coordinate-wise over
//   log-spaced grids. The score is the mean over classes of the mean over
//   their logs, so a terrain with many runs does not outvote one with few.
//
// Scores reported for the chosen settings on the same folds are optimistic:
// the settings were chosen on them. The assessment is therefore nested: every
// log is scored by settings tuned (by an inner cross-validation) and models
// fitted without it. No number the tuner reports as held out was scored on a
// log used to fit or tune what scored it.
#ifndef SKIDIMM_FITTING_TUNING_H_
#define SKIDIMM_FITTING_TUNING_H_

#include <Eigen/Core>
#include <filesystem>
#include <functional>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "skidimm/config/bank.h"
#include "skidimm/evaluation/log_scores.h"
#include "skidimm/evaluation/mode_metrics.h"
#include "skidimm/fitting/model_fitter.h"
#include "skidimm/io/log_reader.h"

namespace skidimm {
namespace fitting {

// One log of the tuning set: what the evaluator reads, and the segments it
// gives each mode for fitting.
struct TuningLog {
  LogSpec spec;
  std::vector<ModeLogs> fit_data;
  // Which session the log was recorded in (Protocol::kSessions): logs of one
  // session (one day, one place, one robot set-up) share what changes
  // between sessions, and are held out together. Empty: its own.
  std::string session;
  // Kept aside: neither fitted nor tuned on; scored once, by the bank fitted
  // and tuned on the other logs (TuneResult::lockbox).
  bool lockbox = false;
};

// How the nested assessment holds logs out (docs/tuning.md, "Protocols").
// Each asks a different question about the next run; the most pessimistic
// answer is the one to expect of a run unlike the training runs.
struct Protocol {
  enum class Kind {
    kLogs,           // another run like these: leave one log out (or TuneOptions::folds groups)
    kSessions,       // a run from a session none of these came from: leave one session out
    kExtrapolation,  // a run driven beyond these: per class, the logs driven hardest in an input, held out together
  };
  Kind kind = Kind::kLogs;
  // kExtrapolation: what ranks a class's logs, the mean absolute value over
  // a log's steps of `expression`, an expression of the log's columns as a
  // bank's (docs/bank-format.md), named `input`; empty expression: that of
  // the bank input named `input`. An expression of the columns ranks logs
  // the same way whatever the bank, so that banks compare on the same runs.
  std::string input;
  std::string expression;
  double fraction = 0.25;  // kExtrapolation: the share of each class's logs held out (at least one, never all)
  // "logs", "sessions", "extrapolation in speed"; slug(): "logs", "sessions", "extrapolation-speed".
  std::string name() const;
  std::string slug() const;
};
// "logs", "sessions", "extrapolation:INPUT[:FRACTION]" or
// "extrapolation:NAME=EXPRESSION[:FRACTION]". Throws Error naming what was expected.
Protocol protocol_from_string(const std::string& text);

// What a fit produced, apart from the bank it was fitted in.
struct FittedValues {
  std::vector<Eigen::VectorXd> parameters;  // per mode, the model's flat parameter vector
  std::vector<Eigen::MatrixXd> q;           // per mode, Q intensity
  Eigen::MatrixXd r;                        // the bank's R
  std::vector<Eigen::MatrixXd> mode_r;      // per mode, its own R (empty: the bank's)
  // Per mode, its parameters' covariance (ModeConfig::parameter_covariance); empty: none.
  std::vector<Eigen::MatrixXd> parameter_covariance;
  // Per mode, its innovations' lag-1 correlation (ModeConfig::residual_correlation).
  std::vector<double> residual_correlation;
  // Per mode, its inputs' ranges over the steps it was fitted on (ModeConfig::fitted_inputs).
  std::vector<std::map<std::string, InputRange>> fitted_inputs;
};

// Fits `bank` in place to `data` (parameters, Q, and R if the objective fits
// it). Throws FitError. Called from several threads, each with its own bank.
using BankFitter = std::function<void(Bank* bank, const std::vector<ModeLogs>& data)>;

// The settings the tuner chooses, applied on top of fitted values.
struct TunedSettings {
  std::string objective;             // which BankFitter built the models
  double r_scale = 1.0;              // R <- r_scale * diag(r_component) R diag(r_component), a mode's own R too
  Eigen::VectorXd r_component;       // per measurement component (sqrt scale on its std), empty = 1
  double q_scale = 1.0;              // Q_j <- q_scale * q_mode[j] * Q_j
  Eigen::VectorXd q_mode;            // per mode, empty = 1
  double dwell_seconds = 0.0;        // > 0: transition.mean_dwell_time for every mode
  double probability_floor = -1.0;   // >= 0: mode_probability_floor
  double likelihood_weight = -1.0;   // > 0: likelihood_weight
  double likelihood_dof = -1.0;      // >= 0: likelihood_dof (0: Gaussian)
  double unknown_inflation = -1.0;   // > 0: unknown.inflation (a bank with an unknown hypothesis)
  double extrapolation_scale = -1.0;  // >= 0: extrapolation_scale (0: no extrapolation discount)
  std::string describe(const BankConfig& config) const;
};

// Writes fitted values and settings into `bank` (its models' parameters and
// its config's Q, R, transition, floor and likelihood weight, and each mode's
// parameter covariance).
void apply(const FittedValues& fitted, const TunedSettings& settings, Bank* bank);
// Reads a bank's current values.
FittedValues values_of(const Bank& bank);

enum class Knob {
  kRScale,
  kRComponents,
  kQScale,
  kQModes,
  kDwell,
  kFloor,
  kLikelihoodWeight,
  kLikelihoodDof,
  kUnknownInflation,
  kExtrapolationScale
};
const char* to_string(Knob knob);
Knob knob_from_string(const std::string& name);  // throws Error listing the names

struct TuneOptions {
  std::vector<std::string> objectives;  // keys of the fitters map, compared by cross-validation
  // Objectives whose fit of a mode depends on that mode's logs alone (no
  // joint R, no bank-level parameters): each mode is fitted once per distinct
  // set of its training logs, and the folds share those fits.
  std::set<std::string> separable;
  // Separable objectives whose fit gives every fitted mode one Q, the mean of
  // their own (BankFitOptions::pooled_process_noise): each fold pools the
  // Q of the modes it fitted, so the folds still share each mode's fit.
  std::set<std::string> pooled_process_noise;
  // Separable objectives whose fits are pooled partially within each regime
  // (pool_parameters_partially, bank_fit.h), per fold over the modes it fitted.
  std::set<std::string> partial_pooling;
  // Objectives that fit nothing (the bank's models as they are, `tune
  // --objective none`): every mode keeps its starting values whether or not
  // a fold has logs of it, so no fold warns that one did.
  std::set<std::string> fit_nothing;
  std::vector<Knob> knobs = {Knob::kRScale, Knob::kQScale, Knob::kDwell, Knob::kFloor};
  int folds = 0;        // 0: leave one log out; K >= 2: K groups of logs (1 is an error)
  int inner_folds = 4;  // the nested assessment's inner cross-validation
  bool assess = true;   // run the nested assessment
  std::vector<Protocol> protocols{Protocol{}};  // how the nested assessment holds logs out, each reported
  // Score the logs a fold holds out as one run, spliced end to end (classes
  // taking turns), instead of one run each: a robot driving from one
  // terrain onto the next. The scores then include how fast a change is
  // followed and how sure the filter was before it, so the settings that
  // trade reaction for steadiness (dwell, likelihood weight and dof, floor)
  // are chosen on changes too; the inner search sees them with
  // inner_folds >= 2, the assessment with multi-log folds.
  bool splice = false;
  int sweeps = 2;       // coordinate-search passes over the knobs
  // How a log-spaced knob's line is searched: every candidate of its grid
  // (kGrid), or from the current value while each step beats the best
  // (kWalk): the grid's best, with fewer scorings, where the score rises to
  // one peak along the line; it can stop on the nearer of two.
  enum class LineSearch { kGrid, kWalk };
  LineSearch line_search = LineSearch::kGrid;
  int threads = 0;      // 0: the machine's cores; more than its cores: its cores
  SamplingConfig sampling;
  std::function<void(const std::string&)> progress;  // one line at a time; may be empty
  // Counted progress lines ("fitted 20/60 modes") also give the rate and the
  // time left (progress.h). The CLI asks for it only when stderr is a
  // terminal: in a captured log, times would differ from run to run.
  bool progress_rates = false;
  // When set, the nested assessment writes each held-out log's steps under
  // it, as `skidimm run` would, one folder per protocol and one for the
  // lockbox (<slug>/NNN_<label>_<first file>.csv), for `eval --estimates`.
  std::filesystem::path assessment_estimates;
};

// A held-out log's score, and their mean over classes (evaluation/log_scores.h).
using LogScore = evaluation::LogScore;
using Summary = evaluation::ScoreSummary;
using evaluation::summarize;

// What one protocol's nested assessment found: honest, as no log was scored
// by models fitted or settings tuned on it.
struct Assessment {
  Protocol protocol;
  Summary summary;
  std::vector<LogScore> scores;
  // TuneOptions::splice: the spliced runs' metrics, merged (their switches:
  // how fast the most likely class, and the decision, followed each change).
  evaluation::ModeMetrics spliced;
  evaluation::ModeMetrics spliced_decision;
};

struct TuneResult {
  TunedSettings settings;            // chosen on all logs but the lockbox
  Summary selection;                 // the folds' scores with the chosen settings: optimistic
  std::vector<LogScore> selection_scores;
  // The same folds scored at the bank's starting settings, the search's first
  // candidate (of the first objective): where a mode's model fails there and
  // not with the chosen settings, the search may have chosen settings that
  // keep it from failing, which the user should hear of.
  std::vector<LogScore> start_scores;
  std::vector<Assessment> assessments;  // one per protocol, in TuneOptions::protocols' order
  // The lockbox logs scored once by the final bank (protocol name "lockbox");
  // empty scores when no log was kept aside.
  Assessment lockbox;
  FittedValues fitted;               // the final fit on every log but the lockbox
  std::vector<std::string> warnings;
};

// `make_bank` returns a fresh bank at the starting values (it is called from
// the calling thread only). Throws FitError or Error.
TuneResult tune(const std::function<Bank()>& make_bank, const std::vector<TuningLog>& logs,
                const std::map<std::string, BankFitter>& fitters, const TuneOptions& options);

// Cross-validation groups of `members` (indices into `classes`): one log each
// when folds is 0 (or at least the number of logs), else `folds` groups dealt
// out class by class, so each group holds every class it can.
std::vector<std::vector<int>> grouped_folds(const std::vector<int>& members, const std::vector<std::string>& classes,
                                            int folds);

// The held-out sets of `protocol` over `members` (indices into the other
// vectors): kLogs, grouped_folds(members, classes, folds); kSessions, one set
// per session (a log of no session is its own); kExtrapolation, one set: per
// class, among its logs driven in the input at all (ranking at least a tenth
// of the class's largest), the round(fraction x them) of largest `ranking`,
// at least one and never all of them (a class with fewer than two such logs
// holds none out). Throws Error when a protocol cannot hold anything out.
std::vector<std::vector<int>> protocol_folds(const Protocol& protocol, const std::vector<int>& members,
                                             const std::vector<std::string>& classes,
                                             const std::vector<std::string>& sessions,
                                             const std::vector<double>& ranking, int folds);

// Scores logs with a bank as it is (no fitting): the evaluator tune uses.
// With `estimates`, one file per log is written there (estimates[i]).
std::vector<LogScore> score_logs(const Bank& bank, const std::vector<const TuningLog*>& logs,
                                 const SamplingConfig& sampling,
                                 const std::vector<std::filesystem::path>& estimates = {});

}  // namespace fitting
}  // namespace skidimm

#endif  // SKIDIMM_FITTING_TUNING_H_
