// Fitting and simulating for Python: the CLI's `fit` and `simulate` as
// functions on values, and the pieces skidimm.dask distributes (one log's
// segments per mode; one mode's fit).
#ifndef SKIDIMM_PYTHON_FIT_AND_SIMULATE_H_
#define SKIDIMM_PYTHON_FIT_AND_SIMULATE_H_

#include <Eigen/Core>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "skidimm/bank.h"
#include "skidimm/fitting/bank_fit.h"
#include "skidimm/fitting/model_fitter.h"
#include "skidimm/log_reader.h"

namespace skidimm {
namespace python {

struct FitRequest {
  std::vector<std::string> logs;  // as `fit --log`: [MODE=]FILE[@OFFSET][+FILE...], directories, patterns
  std::string mode;               // --mode
  std::string name;               // --name
  double rate = 0.0;              // --rate
  fitting::BankFitOptions options;
  std::vector<std::string> header;  // comment lines heading the written bank
};

// The logs of `arguments` by mode, as `skidimm fit` reads them.
std::vector<fitting::ModeLogs> load_fit_logs(const BankConfig& config, const std::vector<std::string>& arguments,
                                             const std::string& default_mode, const SamplingConfig& sampling);

// One mode's fit as the CLI reports it.
struct FittedMode {
  int mode = 0;
  int logs = 0;  // how many segments it was fitted on
  fitting::FitReport report;
};

// The texts `skidimm fit` writes for fitted modes of `bank` (already fitted
// in place): `entries` as it prints them, and the whole bank as
// `--output-bank` writes it (validated, written to `output` then read back).
struct FitTexts {
  std::string entries;
  std::string bank_yaml;
};
FitTexts fit_texts(const Bank& bank, const std::vector<FittedMode>& fitted, const FitRequest& request,
                   const std::filesystem::path& output);

// `skidimm simulate --scenario`: writes the log to `output`.
void simulate_scenario(const std::filesystem::path& scenario, bool has_seed, unsigned long long seed, double duration,
                       const std::filesystem::path& output);

// A CSV file as columns: numbers (NaN where empty or nan), or text where a
// column has any other cell. Exact (std::from_chars).
struct CsvColumns {
  std::vector<std::string> names;
  std::vector<std::vector<double>> numbers;    // per column; empty for a text column
  std::vector<std::vector<std::string>> text;  // per column; empty for a numeric column
  std::vector<bool> is_text;
};
CsvColumns read_csv_columns(const std::filesystem::path& file);

}  // namespace python
}  // namespace skidimm

#endif  // SKIDIMM_PYTHON_FIT_AND_SIMULATE_H_
