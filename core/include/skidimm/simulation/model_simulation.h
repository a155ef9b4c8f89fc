// Simulating a bank's own models: logs whose truth is inside the model class,
// for checking that fitting and tuning recover what generated the data.
//
// The physical simulator (scenario.h) is the honest test of identification,
// because its dynamics are not the filter's. This is the controlled test: the
// data come from the bank's models exactly, so a fitted bank can be compared
// with the true one. The inputs, the time steps and the mode schedule are
// replayed from an existing log (its inputs and truth, read with the bank's
// columns, or its LABEL=). The state starts at the bank's initial state and
// follows the mode in effect at each step:
//
//   x_k = f_{m_k}(x_{k-1}, u_{k-1}, dt) + w,  w ~ N(0, Qd),  Qd = process_noise(Q_{m_k}, ...)
//   z_k = H x_k + v,                            v ~ N(0, R)
//
// with z written wherever the source log had that measurement, so its rates
// and gaps are kept. Deterministic for a seed on any platform.
#ifndef SKIDIMM_SIMULATION_MODEL_SIMULATION_H_
#define SKIDIMM_SIMULATION_MODEL_SIMULATION_H_

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "skidimm/config/bank.h"
#include "skidimm/io/log_reader.h"

namespace skidimm {
namespace simulation {

struct ModelSimulationSummary {
  long rows = 0;
  long mode_switches = 0;
};

// The columns of the log simulate_models() writes: the bank's time column,
// each input and measurement under the column the bank reads it from, or
// under its own name where the bank reads an expression (the bank itself
// then cannot read the log back), and the truth column (the bank's, or
// "mode" if none).
struct SimulatedColumns {
  std::string time;
  std::vector<std::string> inputs;        // per bank input
  std::vector<std::string> measurements;  // per measurement row
  std::string truth;
  // Those of `inputs` and `measurements` written under their own name, which
  // the bank reads from another column text: empty when the bank reads the
  // log back as it is.
  std::vector<std::string> renamed;
};
SimulatedColumns simulated_log_columns(const BankConfig& config);

// Writes the log (atomically) to `output`: simulated_log_columns(), then
// true_<state>. Throws Error when a step's mode is not in the bank.
ModelSimulationSummary simulate_models(const Bank& bank, const LogSpec& source, const SamplingConfig& sampling,
                                       std::uint64_t seed, const std::filesystem::path& output);

}  // namespace simulation
}  // namespace skidimm

#endif  // SKIDIMM_SIMULATION_MODEL_SIMULATION_H_
