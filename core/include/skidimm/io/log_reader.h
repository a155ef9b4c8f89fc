// LogReader: turns a robot's log files into the filter's steps.
//
// A log is one recording: one CSV file, or several that share a clock (wheel
// speeds and currents at 6.5 Hz in one file, the IMU at 100 Hz in another).
// Each file is read as a table (log_table.h); a ROS 2 bag (.mcap, .db3, a
// bag directory) is one table per topic the bank's columns name
// (ros/bag_log.h), merged by time like the files of a multi-rate log.
// The bank says how its files combine (`sampling.join`, bank.h):
//
//  * join: time (default). Every file has the bank's time column; rows of all
//    files are merged in time order. A file may carry a time offset (added to
//    its times) to align clocks.
//  * join: rows. The files match row for row (the Husky ice export); the time
//    comes from the first file that has the time column.
//
// and where the filter steps (`sampling.rate`):
//
//  * no rate: a step at every distinct time stamp of the log;
//  * rate R Hz: steps on the grid t0 + k/R, where t0 is the first time every
//    input has a value. The grid's work is bounded by the log's rows: it
//    never steps through a stretch without rows longer than
//    sampling.max_gap (a LogError naming the row after it and the limit,
//    or, with sampling.skip_gaps, a new grid from that row, counted in
//    stats()), nor takes more than kMaxStepsPerRow steps per row read (a
//    rate far above every sensor's is a LogError).
//
// What a step sees:
//  * inputs are held: each is evaluated from the latest value of its columns
//    (an empty cell keeps the previous value), so a 6.5 Hz wheel speed drives
//    every step of a 100 Hz filter;
//  * a measurement is applied at the step it arrived in (a row of its file
//    with its columns present, at or before the step's time and after the
//    previous step's). If several rows of it arrive within one step, the last
//    is used, unless the measurement aggregates them: `mean(x)`, `std(x)` (the
//    sample standard deviation, needs two rows) and `rms(x)` over the rows of
//    the step, e.g. `mean(wz)` or `log(std(az))`. A step without it has it
//    missing (NaN). A measurement whose value is not finite (log(0)) is
//    missing too, and counted.
//  * the truth columns (`columns.truth_mode`, `true_<state>`) are held
//    between their file's rows; a blank truth cell makes the steps after it
//    unlabelled (an empty truth_mode), unless the bank's
//    `columns.truth_blank: carry` repeats the last label.
//
// Rows before every input has a value, and after the last row of a file that
// feeds an input, are not used (counted in stats()). Nothing is lost
// silently: a file with a header and no rows is a LogError before the first
// step, and a file none of whose rows the steps used (all before the first
// step or after the last: an offset that misses) one after the last step.
// Errors are LogErrors naming the file, line and column; expressions
// (expression.h) are checked against the files' headers before any row is
// read, and errors about them name the bank file and the field. Numbers: see parse_finite_number
// (csv.h); a subnormal cell (1e-320) is read as the nearest double.
//
// A file may be "-" (standard input, once per log), a pipe or a FIFO: it is
// read front to back, once, and a stream's next row is read only when a step
// needs it, so without a fixed rate next() returns a row's step as soon as
// the row has arrived (with a rate, when a row after the grid step has).
#ifndef SKIDIMM_IO_LOG_READER_H_
#define SKIDIMM_IO_LOG_READER_H_

#include <Eigen/Core>
#include <filesystem>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "skidimm/config/bank.h"
#include "skidimm/io/log_spec.h"
#include "skidimm/io/sample_source.h"

namespace skidimm {

// One filter step of a log, in bank order.
// LogSample: sample_source.h.

// What reading a log did with its rows, for the summary a user reads.
struct LogStats {
  long steps = 0;
  std::vector<std::string> files;
  std::vector<long> rows;         // data rows read, per file
  long dropped_before_start = 0;  // measurement values before every input had a value
  long dropped_after_end = 0;     // rows after the end of a file feeding an input (rows join: none)
  // Rows gathered for a grid step past the last row of the inputs, which is
  // not taken; the last step taken, the one not taken, and where the inputs end.
  long dropped_last_step = 0;
  double last_step_t = 0.0;
  double step_not_taken_t = 0.0;
  double inputs_end_t = 0.0;
  std::vector<long> superseded;   // per measurement: values replaced by a later one in the same step
  std::vector<long> not_finite;   // per measurement: expression values that were not finite
  // Per aggregated measurement (mean/std/rms over a step): row values inside
  // an aggregate that were left out (an empty or nan cell, an inner
  // expression that is not finite), and the steps left with too few of them.
  std::vector<long> left_out_of_aggregates;
  std::vector<long> steps_without_enough_rows;
  std::vector<long> measured;     // per measurement: steps that had a value for it
  // Per measurement: its longest stretch of consecutive steps without a
  // value (a sensor that stopped, or paused, while the others went on), and
  // the times of the stretch's first and last steps.
  std::vector<long> longest_unmeasured;
  std::vector<double> longest_unmeasured_from;
  std::vector<double> longest_unmeasured_to;
  long gaps_skipped = 0;          // gaps longer than sampling.max_gap the grid restarted after (skip_gaps)
  double seconds_skipped = 0.0;   // ... and the time they spanned
  // Rows whose time was not after their file's last, left out (skip_out_of_order),
  // and where the first was: "<file>:<line>: t = 2.5 after 2.5".
  long out_of_order_skipped = 0;
  std::string first_out_of_order;
};

class LogReader : public SampleSource {
 public:
  // A fixed-rate grid takes at most this many steps per row of the log (a
  // rate far above every sensor's is refused, not stepped through).
  static constexpr long kMaxStepsPerRow = 1000;

  // Opens the files, resolves every column and expression the bank names and
  // checks them against the headers. `sampling` overrides the bank's (e.g. the
  // command line's --rate). The reader keeps its own copy of what it needs of
  // `bank`, which may be a temporary. Throws LogError or Error.
  LogReader(const BankConfig& bank, const std::vector<LogFile>& files, const SamplingConfig& sampling);
  LogReader(const BankConfig& bank, const std::vector<LogFile>& files);
  ~LogReader() override;
  LogReader(const LogReader&) = delete;
  LogReader& operator=(const LogReader&) = delete;

  // The bank's column texts (columns.inputs, columns.measurements) that no
  // log can give as the bank means them, found without a log: each is
  // neither a plain name nor an expression the reader evaluates (a syntax
  // error, an unknown function, no column at all, a column outside every
  // aggregate of an aggregated measurement). One line each, located as the
  // bank loader's errors are: "<bank file>:<line>: FIELD: why".
  // A log with a column of exactly such a text (a dotted ROS export name,
  // `field.angular_velocity.z`) is still read as that column, so these are
  // warnings, not errors.
  static std::vector<std::string> unreadable_column_texts(const BankConfig& bank);
  // The fields (columns.measurements.NAME) whose text aggregates the rows of
  // a filter step (mean(...), last(...), ...), which a reader can bind only
  // with a fixed step (sampling.rate).
  static std::vector<std::string> aggregated_measurements(const BankConfig& bank);

  // Reads the next step. Returns false at the end of the log.
  bool next(LogSample* sample) override;

  bool has_truth() const override;
  bool has_true_states() const;
  double progress() const;  // fraction of bytes read, 0..1
  const LogStats& stats() const;
  // A few lines for the user about rows not used or measurements replaced;
  // empty when there is nothing to say.
  std::string describe_stats(const BankConfig& bank) const;
  // Of those, the lines about what the bank's options left out of the log
  // (sampling.skip_gaps, sampling.skip_out_of_order), one each, without
  // indentation: what a command that scores or fits a log says of it.
  std::vector<std::string> skipped_by_options() const;
  // Each measurement that had no value at any step so far, as
  // "measurement 'NAME' (\"TEXT\") had no value at any step" (and, for a
  // sequence's entry selected by a name, where the names are listed): a
  // misspelt column of a log that still runs, on the other measurements.
  // Then each that had values but went without one for a stretch far longer
  // than it usually does (at least 5 steps and 5 times its mean steps per
  // value), as "... had no value from t = A to B s (N steps in a row; ...)":
  // a sensor that stopped or paused while the others went on.
  std::vector<std::string> unmeasured(const BankConfig& bank) const;

 private:
  class Impl;
  // A log whose tables the library makes (LiveLog's, live_log.h).
  explicit LogReader(std::unique_ptr<Impl> impl);
  friend class LiveLog;

  std::unique_ptr<Impl> impl_;
};

}  // namespace skidimm

#endif  // SKIDIMM_IO_LOG_READER_H_
