// Checks a bank's models where its logs drive them: the conformance kit's
// checks (sdk/testing/model_checks.h: the Jacobian against central
// differences, finiteness, dt = 0 is the identity, ...) on each mode, at
// operating points taken from logs. A wrong analytic Jacobian in a plugin
// does not stop a run, it only makes the filter worse; this finds it without
// the author's tests (`skidimm validate --check LOG`).
#ifndef SKIDIMM_ENGINE_MODEL_CONFORMANCE_H_
#define SKIDIMM_ENGINE_MODEL_CONFORMANCE_H_

#include <string>
#include <vector>

#include "skidimm/config/bank.h"
#include "skidimm/io/log_reader.h"
#include "skidimm/sdk/testing/model_checks.h"

namespace skidimm {

// One operating point and the log row it comes from, for messages.
struct LogOperatingPoint {
  sdk::testing::OperatingPoint point;
  std::string log;  // the log's text, as given
  long row = 0;     // the step (LogSample::row)
  double t = 0.0;
};

// `count` operating points spread evenly over the steps of `log` (fewer if
// it has fewer steps after its first): the step's inputs, the time since the
// previous step as dt, and as state the bank's initial state with each state
// the bank measures alone (an `observe:` row) replaced by its latest measured
// value; angles wrapped to [-pi, pi). Throws LogError or Error as LogReader
// does, and LogError when the log has no step to take a point from. With
// `unmeasured`, the reader's words for each measurement the log never gave
// (LogReader::unmeasured()). With `labels`, the distinct truth labels of its
// steps (the bank's truth column, or the log's MODE= label), in the order
// met, at most kMostLabelsListed of them.
constexpr std::size_t kMostLabelsListed = 50;
std::vector<LogOperatingPoint> operating_points_from_log(const BankConfig& bank, const LogSpec& log, int count = 20,
                                                         std::vector<std::string>* unmeasured = nullptr,
                                                         std::vector<std::string>* labels = nullptr);

// What the checks found on one mode.
struct ModeConformance {
  std::string mode;
  int points = 0;         // operating points checked
  int failed_points = 0;  // points where at least one check failed
  // The first failing point and every check that failed there (the kit's
  // messages name the entry, the point and both values).
  std::string first_failure_at;
  std::vector<std::string> failures;
  bool ok() const { return failed_points == 0; }
};

// Runs the kit's checks on every mode of `bank` at every point. The models
// are left with the parameters they had.
std::vector<ModeConformance> check_models(const Bank& bank, const std::vector<LogOperatingPoint>& points);

}  // namespace skidimm

#endif  // SKIDIMM_ENGINE_MODEL_CONFORMANCE_H_
