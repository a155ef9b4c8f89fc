// Bank: a set of modes, their models and everything the IMM needs to run
// them, as described by one YAML file (docs/bank-format.md).
//
// Loading has two stages so each can be used alone:
//  * load_bank_config(file) parses and validates the file itself (shapes,
//    stochastic rows, SPD matrices, names) without loading any plugin;
//  * Bank::load(file, ...) then creates every mode's model through the plugin
//    registry and checks the models against the file (dimensions, names,
//    angles, parameter scopes).
// Every problem is a ConfigError naming the file, the line and the field.
//
// Thread safety: load_bank_config() and Bank::load() may run on several
// threads at once (each load has its own PluginRegistry); instantiate() uses
// the registry it is given, which one thread at a time may use. A loaded Bank
// is not changed by the engine: copies share its models and may be read, and
// run by separate Imms, on separate threads (imm.h). Pinned by
// tests/core/thread_safety_test.cc under ThreadSanitizer (docs/engine.md).
#ifndef SKIDIMM_CONFIG_BANK_H_
#define SKIDIMM_CONFIG_BANK_H_

#include <Eigen/Core>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "skidimm/engine/mode_transition.h"
#include "skidimm/engine/plugin_registry.h"
#include "skidimm/sdk/parameters.h"

namespace skidimm {

// The values an input took over the steps a mode was fitted on.
struct InputRange {
  double lowest = 0.0;
  double highest = 0.0;
};

struct ModeConfig {
  std::string name;
  std::string model;            // plugin name
  sdk::ParameterSet params;     // the mode's own `params:`
  Eigen::MatrixXd q_intensity;  // continuous-time process noise Q (per second)
  // The mode's own measurement noise (`R:` in its entry), m x m over every
  // measurement row; empty: the bank's measurement.r. What a filter takes
  // for noise includes its model's error where a row is an output the model
  // predicts (measurement.outputs), and models predict unequally well.
  Eigen::MatrixXd r;
  // Which steps of a log labelled with this mode's class train this mode: an
  // expression of the bank's inputs, true when non-zero ("dv > 0"). Empty:
  // every step not claimed by another mode of the class.
  std::string fit_when;
  // The covariance of the model's flat parameter vector as its fit left it
  // (`parameter_covariance:`, parameter_uncertainty.h); empty: none, the
  // parameters are taken as exact.
  Eigen::MatrixXd parameter_covariance;
  int parameter_covariance_line = 0;
  // The lag-1 correlation rho in (-1, 1) of the mode's whitened innovations
  // from one filter step to the next (`residual_correlation:`,
  // residual_correlation.h): the mode's likelihood of a step is conditioned on
  // its last innovation. 0: independent steps, the IMM as derived.
  double residual_correlation = 0.0;
  // Where the mode's parameters were estimated (`fitted_inputs:`, written by
  // fit and tune): each input's range over the steps its fit used, by input
  // name. A step outside it asks the mode to extrapolate. Empty: not
  // recorded (a bank written by hand or before fits recorded it); an input
  // left out has no range.
  std::map<std::string, InputRange> fitted_inputs;
  int fitted_inputs_line = 0;
  int line = 0;                 // where the mode starts in the file
  std::map<std::string, int> param_lines;
};


struct MeasurementConfig {
  std::vector<std::string> names;  // one per row of H
  Eigen::MatrixXd h;               // m x n
  Eigen::MatrixXd r;               // m x m, positive definite
  std::vector<bool> is_angle;      // row measures an angle state directly
  // The models' outputs measured (`outputs:`, sdk::MotionModel::outputs()):
  // the last rows of z, in this order, named as here. Their rows of H are
  // zero: an output depends on the input, not the state.
  std::vector<std::string> outputs;
  int first_output_row() const { return static_cast<int>(h.rows()) - static_cast<int>(outputs.size()); }
};

// Where the log's values come from. Each input or measurement is a CSV
// column or an expression of columns (csv.h); measurements may aggregate
// the rows of a filter step with mean(), std(), rms() or diff_std().
struct ColumnConfig {
  std::string time;
  // The unit of a CSV log's time column (`time_unit: s | ms | us | ns`), as
  // units per second (a time is divided by it, which reads 20 ms as 0.02 s
  // to the bit): a recorder's stamps in ms read as seconds make every row a
  // long gap. A bag's stamps are read in seconds; it must be 1 there.
  double time_units_per_second = 1.0;
  std::string time_unit_name = "s";
  std::vector<std::string> inputs;        // one per input, in input order
  std::vector<std::string> measurements;  // one per measurement row
  // The bank file's line of each text above; 0 where the bank does not
  // write it (a name that reads the column of the same name).
  std::vector<int> input_lines;
  std::vector<int> measurement_lines;
  std::string truth_mode;                 // empty: none
  // A blank truth cell: unlabelled (not scored, not fitted), or with
  // `truth_blank: carry` the last label again, for logs that write a label
  // only when it changes.
  bool carry_truth = false;
};

// How the files of one log become filter steps (docs/bank-format.md, `sampling`).
struct SamplingConfig {
  enum class Join {
    kTime,  // every file has its own time column; rows are merged by time
    kRows,  // files match row for row; the time comes from the first file that has it
  };
  Join join = Join::kTime;
  double rate = 0.0;  // Hz of the filter's steps on a fixed grid; 0: a step at every time stamp
  // With a rate: the longest stretch of the log without rows (s) the grid
  // steps through. A longer one (a wrong time stamp, a paused recording) is
  // an error naming it, or, with skip_gaps, the grid restarts at the row
  // after it (log_reader.h).
  double max_gap = 10.0;
  bool skip_gaps = false;
  // A row whose time is not after its file's last (a row written twice, a
  // stamp out of order) is an error naming it, or, with skip_out_of_order,
  // left out and counted (log_reader.h).
  bool skip_out_of_order = false;
};

// The longest min_hold a bank or a command line may state, in seconds.
inline constexpr double kLongestDecisionHold = 1e9;

// How a decision a controller can act on is made from the probabilities
// (decision.h, `decision:` in the bank).
struct DecisionConfig {
  double enter = 0.9;     // a mode (class) is taken when its probability reaches this
  double leave = 0.05;    // ... and given up for unknown when it falls below this (0: never)
  double min_hold = 1.0;  // s a decision is kept at least
  // s without any measurement after which a decision is given up for
  // unknown (and none is taken): with no evidence the probabilities only
  // relax, and a class of many can stay above `leave` for ever. 0: never;
  // < 0 (unset): the bank's shortest mean dwell time, the prior's own
  // time for a mode to have changed (never for a per-step transition).
  double stale_after = -1.0;
};

// Modes scored as one class by eval and tune (`classes:`), e.g. the left- and
// right-turn modes of one wheel configuration.
struct ClassConfig {
  std::string name;
  std::vector<int> modes;  // indices into BankConfig::modes
};

// An explicit "none of these" hypothesis beside the modes. It has no state:
// its likelihood of a step is the best-fitting mode's innovation under that
// mode's innovation covariance times `inflation`, so it wins only when every
// mode misses by far more than its covariance says. Each step it takes
// `enter` of the modes' probability and gives back `leave` of its own, spread
// evenly over the modes.
struct UnknownHypothesisConfig {
  double inflation = 0.0;  // > 1 when on; 0: no unknown hypothesis
  double enter = 0.0;      // per step, in [0, 1)
  double leave = 0.0;      // per step, in (0, 1]
  bool enabled() const { return inflation > 0.0; }
};

struct BankConfig {
  // Absolute, so that the files the bank names resolve wherever it is used
  // (another working directory, a Dask worker).
  std::filesystem::path file;
  // `file` as messages name it: relative to the working directory (as it
  // was most likely given, `../bank.yaml` too) unless that is longer than
  // the absolute path.
  std::string shown_file() const;
  std::string name;
  std::string description;
  std::vector<std::string> state_names;
  std::vector<bool> angle_mask;
  std::vector<std::string> input_names;
  ColumnConfig columns;
  SamplingConfig sampling;
  DecisionConfig decision;
  MeasurementConfig measurement;
  TransitionConfig transition;
  Eigen::VectorXd initial_state;
  Eigen::MatrixXd initial_covariance;
  Eigen::VectorXd initial_mode_probabilities;
  double mode_probability_floor = 1e-9;
  // The weight w in (0, 1] of each step's evidence in the mode probabilities:
  // mu_j is proportional to c_j * Lambda_j^w (docs/engine.md, "Likelihood
  // weight"). 1 is the IMM as derived; below 1 tempers likelihoods that count
  // the same evidence more than once (correlated features, correlated steps).
  double likelihood_weight = 1.0;
  // The degrees of freedom of a Student-t density scoring each mode's
  // innovation in the mode probabilities (docs/engine.md, "Heavy-tailed
  // likelihood"); 0: the Gaussian density of the IMM as derived. A mode far
  // off then loses by log, not by the square, of its miss, so one step that
  // no mode explains cannot make the filter sure of the least wrong one.
  double likelihood_dof = 0.0;
  // How far outside the inputs a class was fitted on (ModeConfig::fitted_inputs)
  // its modes' evidence fades: at a step whose inputs lie d of the class's
  // range widths outside them, each of its modes' log-likelihoods counts
  // exp(-d / scale) of itself and the rest that of the mixture of the
  // classes inside theirs, so a class that cannot predict the step is
  // neither confirmed nor refuted by it (docs/engine.md, "Extrapolation
  // discount"); 0: off.
  double extrapolation_scale = 0.0;
  // Chi-square innovation gate (docs/engine.md): the probability a consistent
  // measurement passes, in (0, 1); 0: no gate.
  double innovation_gate = 0.0;
  // The "none of these" hypothesis (`unknown:`, docs/engine.md, "Unknown
  // hypothesis"); off unless the bank asks for it.
  UnknownHypothesisConfig unknown;
  std::vector<std::filesystem::path> plugin_paths;  // absolute
  sdk::ParameterSet shared;
  std::map<std::string, int> shared_lines;
  std::vector<ModeConfig> modes;
  std::vector<ClassConfig> classes;  // empty: every mode is its own class

  int state_dim() const { return static_cast<int>(state_names.size()); }
  int input_dim() const { return static_cast<int>(input_names.size()); }
  int num_modes() const { return static_cast<int>(modes.size()); }
  int mode_index(const std::string& mode_name) const;  // -1 if absent
  // Whether a run output whose mu_<mode> columns name `modes`, in order, was
  // written with this bank: empty if so, else why not (for eval and plot).
  std::string estimates_modes_problem(const std::vector<std::string>& modes) const;
  // Mode j's measurement noise: its own R, else the bank's.
  const Eigen::MatrixXd& measurement_noise(int j) const {
    const Eigen::MatrixXd& own = modes[static_cast<std::size_t>(j)].r;
    return own.size() > 0 ? own : measurement.r;
  }
  bool any_mode_measurement_noise() const {
    for (const ModeConfig& m : modes) {
      if (m.r.size() > 0) return true;
    }
    return false;
  }
  // Whether some mode's innovations are correlated from step to step
  // (ModeConfig::residual_correlation).
  bool any_residual_correlation() const {
    for (const ModeConfig& m : modes) {
      if (m.residual_correlation != 0.0) return true;
    }
    return false;
  }
  // The class names in scoring order: the bank's classes, then every mode in
  // no class under its own name.
  std::vector<std::string> class_names() const;
  // For each mode, its index in class_names().
  std::vector<int> class_of_modes() const;
  // The index in class_names() of a truth label that names a class or a
  // mode; -1 if it names neither.
  int class_index(const std::string& label) const;
  // The message for a label that names neither a mode nor a class, with
  // what a label can name: "'ice' is neither a mode nor a class of bank
  // 'b'; its classes: A, B; its modes: a, b" (the modes alone in a bank
  // without classes), and where a name differs from `label` only in case,
  // "; names are case-sensitive: 'ICE'?".
  std::string unknown_label(const std::string& label) const;
};

// Parses and validates a bank file. Throws ConfigError.
BankConfig load_bank_config(const std::filesystem::path& file);

// Why `name` cannot name a mode or a class ("" when it can): it appears in
// output columns, tables and the YAML written back, so it must be non-empty,
// printable and one line, and not the decision's "unknown".
std::string name_problem(const std::string& name);

// Where a mode's model was created from: a plugin file (and its version),
// or another source (ModelProvider), for messages.
struct ModelSource {
  std::filesystem::path file;
  std::string plugin;  // the model's name, the mode's `model:`
  std::string version;
  std::string origin = "plugin";  // what made it: "plugin", "Python model"
  // The parameter keys its plugin documents, in the order of its table
  // (`skidimm plugins`); empty when undocumented. Fitted banks are written
  // in this order.
  std::vector<std::string> parameter_keys;
  // "plugin ltc_linear 1.0.0 (/path/skidimm_ltc_linear.so)", or
  // "Python model py_ltc (/path/models.py)".
  std::string describe() const;
};

// A source of models other than plugins (Python classes: python/src), which
// Bank::instantiate asks first for each mode's `model:`. The bank builder
// does everything else as for a plugin's model: it hands the model the
// bank's `shared:` parameters it takes and the mode's own `params:`, and
// checks its states, angles, inputs, outputs and parameter scopes against
// the bank. Called from the thread that builds the bank.
class ModelProvider {
 public:
  virtual ~ModelProvider() = default;

  // Whether this provider makes the model a mode's `model:` names.
  virtual bool provides(const std::string& model) const = 0;
  // The bank-level (`shared:`) parameter keys `model` takes.
  virtual std::vector<std::string> shared_parameter_keys(const std::string& model) const = 0;
  // Creates `model` with `params` (the bank's names set, set_bank_names).
  // Throws PluginError when it refuses the parameters (reported at the mode's
  // `params`), Error for anything else (reported at its `model`).
  virtual ModelHandle create(const std::string& model, const sdk::ParameterSet& params) const = 0;
  // Where `model` comes from.
  virtual ModelSource source(const std::string& model) const = 0;
  // What it provides, added to the message when a mode's model is neither
  // its nor a plugin's: "nor a Python model: registered are [a, b]".
  virtual std::string describe() const = 0;
};

struct Bank {
  BankConfig config;
  std::vector<ModelHandle> models;  // one per mode, same order
  // One per mode when the models came from plugins or a ModelProvider (load,
  // instantiate); empty for a Bank assembled from models made in process.
  std::vector<ModelSource> model_sources;

  // Loads the file and its plugins. The search path is `plugin_paths`
  // (e.g. --plugin-path), then the bank's, then the standard locations.
  static Bank load(const std::filesystem::path& file, const std::vector<std::filesystem::path>& plugin_paths = {});
  // Creates the models of an already parsed config: those `provider` (may be
  // null) provides from it, every other from a plugin of `registry`.
  static Bank instantiate(BankConfig config, PluginRegistry& registry, const ModelProvider* provider = nullptr);
};

}  // namespace skidimm

#endif  // SKIDIMM_CONFIG_BANK_H_
