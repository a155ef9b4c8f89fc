// EstimatesWriter: the per-step output of `skidimm run`, which `eval
// --estimates` and `plot` read back.
//
// Columns: t, mu_<mode> for every mode in bank order, the combined state (one
// column per state), var_<state> (the diagonal of the combined covariance),
// mode (the most likely), decision (decision.h: a class, or "unknown"),
// truth_mode (when there is a truth), status, reason (empty unless a mode's
// filter was rejected or gated in the step: "<mode>: <what>; ..."). Numbers
// are the shortest text that reads back to the same double. The file is
// written as <path>.partial and renamed by commit() (output_file.h; "-",
// devices and FIFOs are written directly).
//
// A path ending in ".npy" is written as a NumPy array instead (format 1.0,
// or 2.0 for very wide headers): one record per step with the same columns,
// numbers as the machine's doubles ('<f8' on every machine we build for,
// exactly the filter's values, no text round trip), the text columns as
// fixed-width byte strings ('S<n>': mode and decision as wide as the longest
// name, truth_mode 64 bytes or the longest name, status 18), and instead of
// reason a column reason_code ('<u4'): the index of the row's reason in a
// JSON array of texts written beside it (reasons_path(): out.npy ->
// out.reasons.json), 0 for "" (no reason). The reason is rarely set, and as
// a fixed-width column it was most of the file. numpy.load() reads the array,
// pandas.DataFrame() takes it as it is. A truth label longer than its column
// is an error (CSV has no such limit). Millions of rows load in a fraction of
// a second.
//
// A path ending in ".mcap" is written as an MCAP file that Foxglove plots
// (ros/estimates_mcap_writer.h): one JSON message per step on
// /skidimm/estimate; copy_topics() adds the topics of the bag the bank read.
//
// write() allocates nothing per row in the CSV and .npy formats (once the
// labels it has seen have been quoted).
#ifndef SKIDIMM_IO_ESTIMATES_WRITER_H_
#define SKIDIMM_IO_ESTIMATES_WRITER_H_

#include <cstdio>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "skidimm/config/bank.h"
#include "skidimm/engine/imm_estimate.h"
#include "skidimm/io/csv.h"

namespace skidimm {

namespace ros {
class EstimatesMcapWriter;
}

// The reason column's text for one step, into *out (cleared; its capacity is
// reused, so a run allocates only while the longest reason so far grows): for
// each mode rejected or gated in the step, "<mode>: <what>", joined by "; ".
// Empty when every mode ran normally. The Python package's run() writes the
// same column with it.
void describe_step(const ImmEstimate& estimate, const std::vector<std::string>& mode_names, std::string* out);

class EstimatesWriter {
 public:
  EstimatesWriter(const std::filesystem::path& path, const BankConfig& config, bool with_truth);
  ~EstimatesWriter();
  EstimatesWriter(const EstimatesWriter&) = delete;
  EstimatesWriter& operator=(const EstimatesWriter&) = delete;

  // One row; `truth` is written only when the writer has a truth column.
  void write(double t, const ImmEstimate& estimate, const std::string& decision, const std::string& truth);
  // Called with every row as it is written (run --serve publishes it live).
  using Observer = std::function<void(double t, const ImmEstimate&, const std::string& decision,
                                      const std::string& truth)>;
  void set_observer(Observer observer) { observer_ = std::move(observer); }
  // MCAP output only: copies the topics of `bag` that `column_texts` name
  // (ros/bag_log.h), definitions included. Throws Error for other outputs.
  void copy_topics(const std::filesystem::path& bag, const std::vector<std::string>& column_texts);
  void commit();
  // Every row handed to the file as it is written (CSV only; run --flush).
  // Throws Error for .npy, whose header is completed at the end.
  void flush_each_row();
  // A CSV output's rows computed before a crash are written before the
  // program ends (CsvWriter::write_rows_on_a_crash()); false, and nothing
  // done, for .npy and .mcap, which are complete only at the end.
  bool write_rows_on_a_crash();
  const std::filesystem::path& partial_path() const;

  static std::vector<std::string> header(const BankConfig& config, bool with_truth);
  // True for paths written as NumPy arrays (".npy").
  static bool is_npy(const std::filesystem::path& path);
  // The table of a .npy output's reason codes: `npy` with the extension
  // ".reasons.json". Written as <that>.partial and renamed with the array;
  // when a run fails, both .partial files are kept.
  static std::filesystem::path reasons_path(const std::filesystem::path& npy);

 private:
  class Npy;

  std::unique_ptr<CsvWriter> csv_;
  std::unique_ptr<Npy> npy_;
  std::unique_ptr<ros::EstimatesMcapWriter> mcap_;
  Observer observer_;
  std::vector<std::string> mode_names_;
  std::string reason_;  // the row's reason column, reused
  bool with_truth_;
  bool with_unknown_;  // the bank has an unknown hypothesis: its probability column
};

}  // namespace skidimm

#endif  // SKIDIMM_IO_ESTIMATES_WRITER_H_
