// LogReader's state (log_reader.h), shared by the two halves of its work:
// binding the bank's columns and expressions to the log's files
// (log_reader_binding.cc) and merging the files' rows into the filter's steps
// (log_reader.cc). Private to core/src.
#ifndef SKIDIMM_CORE_SRC_LOG_READER_IMPL_H_
#define SKIDIMM_CORE_SRC_LOG_READER_IMPL_H_

#include <cmath>
#include <exception>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "log_table.h"
#include "measurement_aggregates.h"
#include "skidimm/config/expression.h"
#include "skidimm/io/log_reader.h"

namespace skidimm {
namespace internal {

// A column of one of the log's files that the bank uses.
struct Column {
  std::string name;
  int stream = -1;
  int file = -1;   // within the stream
  int index = -1;  // within the file's header
};

// A value computed from the columns of a row: a plain column or an expression.
struct RowValue {
  std::string text;
  std::unique_ptr<Expression> expression;  // null: the plain column columns[0]
  std::vector<int> columns;                // column ids, in the expression's variable order
  std::vector<double> scratch;
  std::vector<int> streams;  // the distinct streams its columns come from

  // Evaluates with `values` (one per column id); NaN if any is missing.
  double evaluate(const std::vector<double>& values) {
    for (std::size_t i = 0; i < columns.size(); ++i) {
      scratch[i] = values[static_cast<std::size_t>(columns[i])];
      if (std::isnan(scratch[i])) return std::numeric_limits<double>::quiet_NaN();
    }
    return expression ? expression->evaluate(scratch.data()) : scratch[0];
  }
};

struct AggregateTerm {
  Aggregation kind = Aggregation::kMean;
  RowValue inner;
  Accumulator accumulator;
  long left_out = 0;  // rows of the step being gathered whose value was not finite
};

struct MeasurementBinding {
  std::string field;  // "columns.measurements.omega"
  // Not aggregated: the value of the last row of its stream in the step.
  RowValue row;
  // Aggregated: outer(aggregates), e.g. log(std(az)).
  std::unique_ptr<Expression> outer;
  std::vector<AggregateTerm> aggregates;  // in the outer expression's variable order
  std::vector<double> outer_scratch;
  int stream = -1;
  double pending = std::numeric_limits<double>::quiet_NaN();
  long superseded_in_step = 0;  // values of the step being gathered replaced by a later one
  bool aggregated() const { return outer != nullptr; }
};

// One time-ordered source of rows: a file (join: time) or all files read
// side by side (join: rows).
struct Stream {
  std::vector<std::unique_ptr<LogTable>> files;  // each holds its current row (a CSV file, a bag's topic)
  double offset = 0.0;
  double time_units_per_second = 1.0;  // of its time column (columns.time_unit; a bag's: 1)
  int time_file = -1;
  int time_index = -1;
  std::vector<int> columns;             // column ids read from this stream
  std::vector<std::size_t> stat_index;  // per file, its entry in LogStats::rows
  bool has_row = false;                 // the files hold a row not yet applied
  // Its next row is read only when it is needed (read_pending_rows): a log
  // coming through a pipe gives each step as soon as its row has arrived,
  // not when the row after it does.
  bool read_pending = false;
  bool ended = false;
  double row_t = 0.0;
  double last_t = -std::numeric_limits<double>::infinity();       // of the last row applied
  // Of the last row read, applied or not: the rows left after the log's end
  // are read (and counted) without being applied, and their times must
  // increase too, or a stamp past the end followed by one back inside it
  // would pass for rows after the end.
  double read_t = -std::numeric_limits<double>::infinity();
  double delivered_t = -std::numeric_limits<double>::infinity();  // of the last row a delivered step took
  long rows_read = 0;
  double first_t = 0.0;  // of its first row
  bool feeds_inputs = false;
  // Its longest stretch without rows while another file's rows went on
  // (so not a gap of the whole log), from the row before to the row after.
  double longest_hole = 0.0;
  double hole_from = 0.0;
  double hole_to = 0.0;
  long gaps_skipped_before = 0;  // the log's gaps skipped before its last row (not holes of its own)
  // Its values are held into later steps (inputs, truth, true states), so
  // a row before the first step still counts.
  bool holds_values = false;
  // A bad row, found when it was read ahead: thrown when the steps before it
  // have been delivered, so a caller keeps everything computed up to it.
  std::exception_ptr error;
};

}  // namespace internal

class LogReader::Impl {
 public:
  using Column = internal::Column;
  using RowValue = internal::RowValue;
  using MeasurementBinding = internal::MeasurementBinding;
  using Stream = internal::Stream;

  // One of the tables a log is made of, read as a file of it (join: time).
  struct TableOfLog {
    std::unique_ptr<LogTable> table;
    double time_offset = 0.0;
  };

  Impl(const BankConfig& bank, const std::vector<LogFile>& files, const SamplingConfig& sampling);
  // A log whose tables are made by the library itself (live_log.h): each is
  // a file of it, merged by time.
  Impl(const BankConfig& bank, std::vector<TableOfLog> tables, const SamplingConfig& sampling);
  bool next(LogSample* sample);

  // A copy: a reader built from a temporary config (LogReader(load_bank_config(f), files))
  // once read it after its end, found by AddressSanitizer.
  const BankConfig bank_;
  SamplingConfig sampling_;
  std::vector<Stream> streams_;
  std::vector<Column> columns_;
  std::vector<double> row_values_;   // per column: this row's value, NaN if empty
  std::vector<double> held_values_;  // per column: the latest non-empty value
  // Per measurement: the steps since its last value, and the first one's time.
  std::vector<long> unmeasured_run_;
  std::vector<double> unmeasured_run_from_;
  std::vector<RowValue> inputs_;
  std::vector<MeasurementBinding> measurements_;
  int truth_stream_ = -1, truth_file_ = -1, truth_index_ = -1;
  std::string held_truth_;
  std::vector<int> true_state_columns_;  // per state, column id or -1
  bool has_true_states_ = false;

  bool started_ = false;
  long steps_ = 0;
  long grid_index_ = 0;
  double grid_origin_ = 0.0;
  double last_step_t_ = -std::numeric_limits<double>::infinity();
  long rows_applied_ = 0;  // rows (of a stream) applied, over all streams
  long rows_delivered_ = 0;                                             // of those, the rows a delivered step took
  double delivered_step_t_ = -std::numeric_limits<double>::infinity();  // the last step delivered
  double first_row_t_ = 0.0;
  double first_step_t_ = 0.0;
  double last_row_t_ = -std::numeric_limits<double>::infinity();
  LogStats stats_;

 private:
  Impl(const BankConfig& bank, const SamplingConfig& sampling);  // checks `sampling`
  void find_time_columns();
  void bind_columns();
  int column_id(const std::string& name, const std::string& field, bool required);
  RowValue bind_row_value(const std::string& text, const std::string& field);
  bool is_column(const std::string& name) const;
  void bind_measurement(MeasurementBinding* m, const std::string& text);
  [[noreturn]] void missing_column(const std::string& column, const std::string& field) const;
  bool read_row(Stream& s);
  bool read_row_or_throw(Stream& s);
  void throw_pending_error() const;
  void apply_row(int stream);
  void read_pending_rows();
  double next_row_time();
  bool inputs_known() const;
  void discard_measurements();
  bool past_end(double t) const;
  double next_grid_time();
  void pass_gap(double next_row);
  void drop_last_step(double step_t);
  void check_no_file_is_empty() const;
  void check_every_file_was_used() const;
  // At the end of a log that gave no step: throws LogError naming each input
  // column that had no value in any row (a misspelt name in a sequence
  // selected by name, a column empty throughout). Nothing when the log had
  // no data rows at all, which its caller says.
  void throw_if_an_input_never_had_a_value() const;
  const Stream* stream_at(double t) const;
  void emit(double t, LogSample* sample);
};

}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_LOG_READER_IMPL_H_
