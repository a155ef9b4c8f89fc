// What a fit writes, for every front end (`skidimm fit`, Python's
// skidimm.fit, skidimm.dask.fit): each fitted mode's bank entry with a
// comment saying how it was fitted and how well, and the whole bank with the
// fitted values.
#ifndef SKIDIMM_FITTING_FIT_OUTPUT_H_
#define SKIDIMM_FITTING_FIT_OUTPUT_H_

#include <Eigen/Core>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "skidimm/config/bank.h"
#include "skidimm/fitting/bank_fit.h"
#include "skidimm/fitting/model_fitter.h"

namespace skidimm {
namespace fitting {

// How a fit was asked for, as the written comments tell it.
struct FitRequest {
  BankFitOptions options;
  std::string mode;  // the mode logs without a label show (`fit --mode`)
  std::string name;  // that mode's name in the output (a new terrain); empty: its own
  // How the logs were stepped (sampling_of() the bank and `--rate`). Where
  // its rate is not the bank's, it is the written bank's `sampling:`: a bank
  // runs at the rate it was fitted at.
  std::optional<SamplingConfig> sampling;
};

// One mode's fit.
struct FittedMode {
  int mode = 0;  // index in the bank
  int logs = 0;  // how many logs it was fitted on
  FitReport report;
};

// The name mode j is written under: request.name for request.mode, else its own.
std::string output_mode_name(const BankConfig& config, const FitRequest& request, int j);

// Empty, or why the whole bank written from `config` (write_fitted_bank)
// cannot rename mode `mode` to `name` (--name): the bank keeps its
// `classes:`, and one that lists the mode by its old name would make it
// invalid, which writing finds only after the fit; and a class's modes
// would keep their names, the name ignored. For every front end, before
// the fit.
std::string renaming_problem(const BankConfig& config, const std::string& mode, const std::string& name);

// Values per measurement row as "V 0.01234, omega 0.005" (`digits` significant digits).
std::string measurement_values_text(const BankConfig& config, const Eigen::VectorXd& values, int digits = 4);

// One-step RMSE per measurement row of "nothing changes" (z_{k+1} = z_k, over
// each row's measured steps): the baseline a model must beat.
Eigen::VectorXd persistence_rmse(const ModeLogs& data);

// The fitted modes' `modes:` entries (bank_writer.h), in the order of
// `fitted`, each under a comment naming the objective, the number of logs
// and the residual RMSE. `bank` holds the fitted values.
std::string format_fitted_entries(const Bank& bank, const std::vector<FittedMode>& fitted, const FitRequest& request);

// Writes `output`: `template_file` (a bank) with the fitted `modes:` (every
// mode of `bank`, those not in `fitted` as they are, saying so), the fitted
// `shared:` and `measurement:` blocks when the request fitted them, and
// `header` as its leading comment. Validated before it replaces anything
// (bank_writer.h). Throws ConfigError or Error.
void write_fitted_bank(const Bank& bank, const std::vector<FittedMode>& fitted, const FitRequest& request,
                       const std::filesystem::path& template_file, const std::filesystem::path& output,
                       const std::vector<std::string>& header);

}  // namespace fitting
}  // namespace skidimm

#endif  // SKIDIMM_FITTING_FIT_OUTPUT_H_
