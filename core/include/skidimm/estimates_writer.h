// EstimatesWriter: the per-step output of `skidimm run`, which `eval
// --estimates` and `plot` read back.
//
// Columns: t, mu_<mode> for every mode in bank order, the combined state (one
// column per state), var_<state> (the diagonal of the combined covariance),
// mode (the most likely), decision (decision.h: a class, or "unknown"),
// truth_mode (when there is a truth), status. Numbers
// are the shortest text that reads back to the same double. The file is
// written as <path>.partial and renamed by commit() (log_io.h, CsvWriter).
#ifndef SKIDIMM_ESTIMATES_WRITER_H_
#define SKIDIMM_ESTIMATES_WRITER_H_

#include <filesystem>
#include <string>
#include <vector>

#include "skidimm/bank.h"
#include "skidimm/imm_estimate.h"
#include "skidimm/log_io.h"

namespace skidimm {

class EstimatesWriter {
 public:
  EstimatesWriter(const std::filesystem::path& path, const BankConfig& config, bool with_truth);

  // One row; `truth` is written only when the writer has a truth column.
  void write(double t, const ImmEstimate& estimate, const std::string& decision, const std::string& truth);
  void commit() { writer_.commit(); }
  const std::filesystem::path& partial_path() const { return writer_.partial_path(); }

  static std::vector<std::string> header(const BankConfig& config, bool with_truth);

 private:
  CsvWriter writer_;
  std::vector<std::string> mode_names_;
  bool with_truth_;
  std::vector<std::string> cells_;
};

}  // namespace skidimm

#endif  // SKIDIMM_ESTIMATES_WRITER_H_
