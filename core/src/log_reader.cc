#include "skidimm/log_reader.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <exception>
#include <limits>
#include <map>
#include <system_error>

#include "number_text.h"
#include "skidimm/errors.h"
#include "skidimm/expression.h"
#include "skidimm/log_io.h"
#include "skidimm/log_table.h"
#include "skidimm/ros/bag_log.h"
#include "skidimm/ros/bag_reader.h"

namespace skidimm {

namespace fs = std::filesystem;

// ---------------------------------------------------------------- LogSpec

std::string LogSpec::name() const {
  std::string out;
  for (const LogFile& f : files) out += (out.empty() ? "" : "+") + f.path.filename().string();
  return out;
}

LogSpec parse_log_spec(const std::string& text) {
  LogSpec spec;
  spec.text = text;
  std::string files = text;
  std::error_code ec;
  // "MODE=a.csv": a label, unless the whole text (or its first part) is a file with '=' in its name.
  const auto equals = text.find('=');
  const std::string first = text.substr(0, text.find('+'));
  if (equals != std::string::npos && !fs::exists(first, ec)) {
    spec.label = text.substr(0, equals);
    files = text.substr(equals + 1);
    if (spec.label.empty()) throw Error("log '" + text + "': empty label before '='");
  }
  std::size_t begin = 0;
  while (begin <= files.size()) {
    // '+' joins files, except right after '@', where it is an offset's sign.
    std::size_t end = files.find('+', begin);
    while (end != std::string::npos && end > 0 && files[end - 1] == '@') end = files.find('+', end + 1);
    if (end == std::string::npos) end = files.size();
    std::string part = files.substr(begin, end - begin);
    begin = end + 1;
    if (part.empty()) continue;
    LogFile file(part);
    const auto at = part.rfind('@');
    if (at != std::string::npos && !fs::exists(part, ec)) {
      const std::string offset = part.substr(at + 1);
      double value = 0.0;
      const char* b = offset.data();
      if (!offset.empty() && *b == '+') ++b;
      const auto parsed = std::from_chars(b, offset.data() + offset.size(), value);
      if (offset.empty() || parsed.ec != std::errc() || parsed.ptr != offset.data() + offset.size() ||
          !std::isfinite(value)) {
        throw Error("log '" + text + "': '" + offset + "' after '@' is not a time offset in seconds");
      }
      file = LogFile(part.substr(0, at), value);
    }
    spec.files.push_back(file);
  }
  if (spec.files.empty()) throw Error("log '" + text + "': no file given");
  return spec;
}

// ---------------------------------------------------------------- LogReader

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string_view trim(std::string_view s) {
  const auto begin = s.find_first_not_of(" \t");
  if (begin == std::string_view::npos) return {};
  const auto end = s.find_last_not_of(" \t");
  return s.substr(begin, end - begin + 1);
}

std::string trim(const std::string& s) { return std::string(trim(std::string_view(s))); }

// Locale-independent parse of a whole cell. Missing: empty, nan, NaN, NA.
bool parse_number(std::string_view cell, double* value, bool* missing) {
  const auto blank = [](char c) { return c == ' ' || c == '\t'; };
  const std::string_view text = !cell.empty() && (blank(cell.front()) || blank(cell.back())) ? trim(cell) : cell;
  *missing = false;
  if (text.empty() || ((text.front() == 'n' || text.front() == 'N') &&
                       (text == "nan" || text == "NaN" || text == "NAN" || text == "NA"))) {
    *missing = true;
    *value = kNaN;
    return true;
  }
  const char* begin = text.data();
  if (*begin == '+') ++begin;
  const char* end = text.data() + text.size();
  // Most cells are plain decimals: exactly from_chars's value, faster (number_text.h).
  if (number_text::parse_plain_decimal(std::string_view(begin, static_cast<std::size_t>(end - begin)), value)) {
    return true;
  }
  bool overflow = false;
  return number_text::parse_general(std::string_view(begin, static_cast<std::size_t>(end - begin)), value, &overflow);
}

// What a cell that parse_number refused was expected to be, for the message.
std::string bad_number(const CsvReader& reader, int index, std::string_view cell, const std::string& expected) {
  return "column " + std::to_string(index + 1) + " ('" +
         Expression::excerpt(reader.header()[static_cast<std::size_t>(index)]) + "'): expected " + expected +
         ", got '" + std::string(cell.substr(0, 80)) + (cell.size() > 80 ? "...'" : "'");
}

// A CSV file as a table of the log (log_table.h): cells parsed as parse_number does.
class CsvTable : public LogTable {
 public:
  explicit CsvTable(const fs::path& path) : reader_(path) {}
  const fs::path& path() const override { return reader_.path(); }
  std::string name() const override { return reader_.path().filename().string(); }
  std::vector<std::string> columns_present() const override { return reader_.header(); }
  int column(const std::string& name) override { return reader_.column(name); }
  bool next_row() override { return reader_.next_row(); }
  Cell number(int column, double* value) const override {
    bool missing = false;
    if (!parse_number(reader_.field(column), value, &missing)) return Cell::kNotANumber;
    return missing ? Cell::kMissing : Cell::kNumber;
  }
  std::string_view text(int column) const override { return reader_.field(column); }
  LogError cell_error(int column, const std::string& expected) const override {
    return error_at_row(bad_number(reader_, column, reader_.field(column), expected));
  }
  LogError error_at_row(const std::string& message) const override {
    return LogError(reader_.path().string(), reader_.line(), message);
  }
  LogError error(const std::string& message) const override { return LogError(reader_.path().string(), 1, message); }
  std::uintmax_t bytes_read() const override { return reader_.bytes_read(); }
  std::uintmax_t size() const override { return reader_.file_size(); }

 private:
  CsvReader reader_;
};

// A header made printable and short: a binary file given by mistake must not
// flood the terminal.
std::string printable_header(const std::vector<std::string>& header, int* listed, std::size_t budget) {
  std::string present;
  for (const std::string& h : header) {
    if (++*listed > 40 || present.size() > budget) {
      present += ", ...";
      break;
    }
    std::string printable;
    for (unsigned char c : h.substr(0, 40)) printable += (c >= 32 && c < 127) ? static_cast<char>(c) : '?';
    present += (present.empty() ? "" : ", ") + printable;
  }
  return present;
}

enum class Aggregation { kMean, kStd, kRms };

// Running moments of the values of one step (Welford: no cancellation).
struct Accumulator {
  long count = 0;
  double mean = 0.0;
  double m2 = 0.0;
  double sum_squares = 0.0;
  void add(double v) {
    ++count;
    const double delta = v - mean;
    mean += delta / static_cast<double>(count);
    m2 += delta * (v - mean);
    sum_squares += v * v;
  }
  double value(Aggregation a) const {
    switch (a) {
      case Aggregation::kMean:
        return count > 0 ? mean : kNaN;
      case Aggregation::kStd:
        return count > 1 ? std::sqrt(std::max(0.0, m2 / static_cast<double>(count - 1))) : kNaN;
      case Aggregation::kRms:
        return count > 0 ? std::sqrt(sum_squares / static_cast<double>(count)) : kNaN;
    }
    return kNaN;
  }
  void reset() { *this = Accumulator{}; }
};

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
      if (std::isnan(scratch[i])) return kNaN;
    }
    return expression ? expression->evaluate(scratch.data()) : scratch[0];
  }
};

struct AggregateTerm {
  Aggregation kind = Aggregation::kMean;
  RowValue inner;
  Accumulator accumulator;
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
  double pending = kNaN;
  bool aggregated() const { return outer != nullptr; }
};

// One time-ordered source of rows: a file (join: time) or all files read
// side by side (join: rows).
struct Stream {
  std::vector<std::unique_ptr<LogTable>> files;  // each holds its current row (a CSV file, a bag's topic)
  double offset = 0.0;
  int time_file = -1;
  int time_index = -1;
  std::vector<int> columns;             // column ids read from this stream
  std::vector<std::size_t> stat_index;  // per file, its entry in LogStats::rows
  bool has_row = false;      // the files hold a row not yet applied
  // Its next row is read only when it is needed (read_pending_rows): a log
  // coming through a pipe gives each step as soon as its row has arrived,
  // not when the row after it does.
  bool read_pending = false;
  bool ended = false;
  double row_t = 0.0;
  double last_t = -std::numeric_limits<double>::infinity();  // of the last row applied
  long rows_read = 0;
  double first_t = 0.0;  // of its first row
  bool feeds_inputs = false;
  // Its values are held into later steps (inputs, truth, true states), so
  // a row before the first step still counts.
  bool holds_values = false;
  // A bad row, found when it was read ahead: thrown when the steps before it
  // have been delivered, so a caller keeps everything computed up to it.
  std::exception_ptr error;
};

// The aggregates a measurement may take of its rows in a step.
const std::vector<std::string>& aggregate_names() {
  static const std::vector<std::string> names{"mean", "std", "rms"};
  return names;
}

Aggregation aggregation_of(const std::string& name) {
  if (name == "std") return Aggregation::kStd;
  if (name == "rms") return Aggregation::kRms;
  return Aggregation::kMean;
}

// The bank's column texts that may name a bag's topics (ros/bag_log.h).
std::vector<std::string> bag_column_texts(const BankConfig& bank) {
  std::vector<std::string> texts = bank.columns.inputs;
  texts.insert(texts.end(), bank.columns.measurements.begin(), bank.columns.measurements.end());
  return texts;
}

}  // namespace

class LogReader::Impl {
 public:
  Impl(const BankConfig& bank, const std::vector<LogFile>& files, const SamplingConfig& sampling);
  bool next(LogSample* sample);

  // A copy: a reader built from a temporary config (LogReader(load_bank_config(f), files))
  // once read it after its end, found by AddressSanitizer.
  const BankConfig bank_;
  SamplingConfig sampling_;
  std::vector<Stream> streams_;
  std::vector<Column> columns_;
  std::vector<double> row_values_;   // per column: this row's value, NaN if empty
  std::vector<double> held_values_;  // per column: the latest non-empty value
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
  double first_row_t_ = 0.0;
  double first_step_t_ = 0.0;
  double last_row_t_ = -std::numeric_limits<double>::infinity();
  LogStats stats_;

 private:
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
  void check_no_file_is_empty() const;
  void check_every_file_was_used() const;
  const Stream* stream_at(double t) const;
  void emit(double t, LogSample* sample);
};

LogReader::Impl::Impl(const BankConfig& bank, const std::vector<LogFile>& files, const SamplingConfig& sampling)
    : bank_(bank), sampling_(sampling) {
  if (files.empty()) throw LogError("", 0, "no input log given");
  if (!(sampling.rate == 0.0 || (sampling.rate > 0.0 && sampling.rate <= 1e6))) {
    throw Error(
        "the filter's rate (sampling.rate or --rate) must be in Hz, > 0 and at most 1e6, or 0 for a step at "
        "every time stamp; got " +
        CsvWriter::format(sampling.rate));
  }
  if (!(sampling.max_gap > 0.0)) {
    throw Error("sampling.max_gap must be a time in seconds, > 0; got " + CsvWriter::format(sampling.max_gap));
  }
  int standard_inputs = 0;
  for (const LogFile& file : files) standard_inputs += is_standard_input(file.path) ? 1 : 0;
  if (standard_inputs > 1) throw LogError("-", 0, "standard input ('-') can be one file of a log, not several");
  const bool by_rows = sampling.join == SamplingConfig::Join::kRows;
  if (by_rows) streams_.emplace_back();
  for (const LogFile& file : files) {
    if (!by_rows) {
      streams_.emplace_back();
      streams_.back().offset = file.time_offset;
    }
    if (!is_standard_input(file.path) && ros::BagReader::is_bag(file.path)) {
      // A ROS 2 bag: each topic the bank names is a file of its own (ros/bag_log.h).
      if (by_rows) {
        throw Error(bank.file.string() + ": sampling.join: rows is for CSV files that match row for row; " +
                    file.path.string() + " is a ROS 2 bag, whose topics are merged by time");
      }
      streams_.pop_back();
      for (auto& table : ros::open_bag_tables(file.path, bag_column_texts(bank), {bank.columns.truth_mode})) {
        streams_.emplace_back();
        streams_.back().offset = file.time_offset;
        streams_.back().stat_index.push_back(stats_.files.size());
        stats_.files.push_back(table->name());
        stats_.rows.push_back(0);
        streams_.back().files.push_back(std::move(table));
      }
      continue;
    }
    Stream& s = streams_.back();
    s.files.push_back(std::make_unique<CsvTable>(file.path));
    s.stat_index.push_back(stats_.files.size());
    stats_.files.push_back(file.path.string());
    stats_.rows.push_back(0);
  }
  // The time column: in every file (join: time) or in the first file that has it (join: rows).
  for (std::size_t k = 0; k < streams_.size(); ++k) {
    Stream& s = streams_[k];
    for (std::size_t f = 0; f < s.files.size() && s.time_file < 0; ++f) {
      const int index = s.files[f]->column(bank.columns.time);
      if (index >= 0) {
        s.time_file = static_cast<int>(f);
        s.time_index = index;
        if (by_rows) s.offset = files[f].time_offset;
      }
    }
    if (s.time_file < 0) {
      int listed = 0;
      const LogTable& reader = *s.files.front();
      std::string message = "no time column '" + bank.columns.time + "' (the bank's columns.time); columns present: " +
                            printable_header(reader.columns_present(), &listed, 400);
      if (!by_rows) {
        message +=
            ". Every file of a log is merged on its own time column (sampling.join: time); files that match row "
            "for row and share one time column need sampling.join: rows";
      }
      throw reader.error(message);
    }
  }

  for (std::size_t i = 0; i < bank.columns.inputs.size(); ++i) {
    const std::string field = "columns.inputs." + bank.input_names[i];
    inputs_.push_back(bind_row_value(bank.columns.inputs[i], field));
    for (int s : inputs_.back().streams) streams_[static_cast<std::size_t>(s)].feeds_inputs = true;
  }
  measurements_.resize(bank.columns.measurements.size());
  for (std::size_t i = 0; i < measurements_.size(); ++i) {
    measurements_[i].field = "columns.measurements." + bank.measurement.names[i];
    bind_measurement(&measurements_[i], bank.columns.measurements[i]);
  }
  if (!bank.columns.truth_mode.empty()) {
    for (std::size_t k = 0; k < streams_.size() && truth_stream_ < 0; ++k) {
      for (std::size_t f = 0; f < streams_[k].files.size() && truth_stream_ < 0; ++f) {
        const int index = streams_[k].files[f]->column(bank.columns.truth_mode);
        if (index >= 0) {
          truth_stream_ = static_cast<int>(k);
          truth_file_ = static_cast<int>(f);
          truth_index_ = index;
        }
      }
    }
  }
  for (const std::string& state : bank.state_names) {
    true_state_columns_.push_back(column_id("true_" + state, "", /*required=*/false));
    has_true_states_ = has_true_states_ || true_state_columns_.back() >= 0;
  }
  for (Stream& s : streams_) s.holds_values = s.feeds_inputs;
  if (truth_stream_ >= 0) streams_[static_cast<std::size_t>(truth_stream_)].holds_values = true;
  for (int c : true_state_columns_) {
    if (c >= 0) streams_[static_cast<std::size_t>(columns_[static_cast<std::size_t>(c)].stream)].holds_values = true;
  }
  row_values_.assign(columns_.size(), kNaN);
  held_values_.assign(columns_.size(), kNaN);
  stats_.superseded.assign(measurements_.size(), 0);
  stats_.not_finite.assign(measurements_.size(), 0);
  stats_.measured.assign(measurements_.size(), 0);
  for (Stream& s : streams_) s.read_pending = true;
}

void LogReader::Impl::missing_column(const std::string& column, const std::string& field) const {
  std::string present;
  int listed = 0;
  for (const Stream& s : streams_) {
    for (const auto& reader : s.files) {
      const std::string h = printable_header(reader->columns_present(), &listed, 400);
      if (!h.empty()) present += (present.empty() ? "" : ", ") + h;
    }
  }
  throw streams_.front().files.front()->error("no column '" + Expression::excerpt(column) + "' (the bank's " + field +
                                              "); columns present: " + present);
}

int LogReader::Impl::column_id(const std::string& name, const std::string& field, bool required) {
  for (std::size_t c = 0; c < columns_.size(); ++c) {
    if (columns_[c].name == name) return static_cast<int>(c);
  }
  Column found;
  found.name = name;
  for (std::size_t k = 0; k < streams_.size(); ++k) {
    for (std::size_t f = 0; f < streams_[k].files.size(); ++f) {
      const int index = streams_[k].files[f]->column(name);
      if (index < 0) continue;
      if (found.stream >= 0) {
        const Stream& first = streams_[static_cast<std::size_t>(found.stream)];
        throw streams_[k].files[f]->error("column '" + name + "' (the bank's " + field + ") is also in " +
                                          first.files[static_cast<std::size_t>(found.file)]->path().string() +
                                          ": a column the bank uses must be in one file of the log");
      }
      found.stream = static_cast<int>(k);
      found.file = static_cast<int>(f);
      found.index = index;
    }
  }
  if (found.stream < 0) {
    if (required) missing_column(name, field);
    return -1;
  }
  streams_[static_cast<std::size_t>(found.stream)].columns.push_back(static_cast<int>(columns_.size()));
  columns_.push_back(found);
  return static_cast<int>(columns_.size()) - 1;
}

RowValue LogReader::Impl::bind_row_value(const std::string& text, const std::string& field) {
  RowValue v;
  v.text = text;
  // A column's exact name is that column, whatever characters it has.
  if (is_column(text)) {
    v.columns.push_back(column_id(text, field, true));
  } else {
    try {
      v.expression = std::make_unique<Expression>(text);
    } catch (const ExpressionError& e) {
      if (Expression::is_identifier(trim(text))) missing_column(trim(text), field);
      throw Error(bank_.file.string() + ": " + field + ": " + e.what());
    }
    if (v.expression->variables().empty()) {
      throw Error(bank_.file.string() + ": " + field + ": \"" + Expression::excerpt(text) +
                  "\" uses no column of the log");
    }
    for (const std::string& name : v.expression->variables()) v.columns.push_back(column_id(name, field, true));
  }
  v.scratch.resize(v.columns.size());
  for (int c : v.columns) {
    const int s = columns_[static_cast<std::size_t>(c)].stream;
    if (std::find(v.streams.begin(), v.streams.end(), s) == v.streams.end()) v.streams.push_back(s);
  }
  return v;
}

bool LogReader::Impl::is_column(const std::string& name) const {
  for (const Stream& s : streams_) {
    for (const auto& reader : s.files) {
      if (reader->column(name) >= 0) return true;
    }
  }
  return false;
}

void LogReader::Impl::bind_measurement(MeasurementBinding* m, const std::string& text) {
  const std::string quoted = "\"" + Expression::excerpt(text) + "\"";
  auto one_stream = [&](const RowValue& v, const std::string& what) {
    if (v.streams.size() > 1) {
      std::string names;
      for (int c : v.columns) {
        const Column& col = columns_[static_cast<std::size_t>(c)];
        names += (names.empty() ? "" : ", ") + col.name + " (" +
                 streams_[static_cast<std::size_t>(col.stream)].files[static_cast<std::size_t>(col.file)]->name() +
                 ")";
      }
      throw Error(bank_.file.string() + ": " + m->field + ": " + what +
                  " uses columns of different files [" + names +
                  "]; a measurement arrives with a row of one file (inputs may mix files)");
    }
    return v.streams.front();
  };
  Expression::WithCalls cut;
  if (!is_column(text)) {
    try {
      cut = Expression::cut_calls(text, aggregate_names());
    } catch (const ExpressionError& e) {
      if (Expression::is_identifier(trim(text))) missing_column(trim(text), m->field);
      throw Error(bank_.file.string() + ": " + m->field + ": " + e.what());
    }
  }
  if (cut.calls.empty()) {
    m->row = bind_row_value(text, m->field);
    m->stream = one_stream(m->row, quoted);
    return;
  }
  if (!cut.names_outside.empty()) {
    throw Error(bank_.file.string() + ": " + m->field + ": " + quoted + " uses column '" +
                Expression::excerpt(cut.names_outside.front()) +
                "' outside mean(), std() or rms(); in an aggregated measurement every column is inside one");
  }
  m->outer = std::move(cut.outer);
  for (const Expression::Call& call : cut.calls) {
    AggregateTerm t;
    t.kind = aggregation_of(call.function);
    t.inner = bind_row_value(call.argument, m->field);
    const int s = one_stream(t.inner, call.function + "(" + Expression::excerpt(call.argument) + ")");
    if (m->stream >= 0 && s != m->stream) {
      throw Error(bank_.file.string() + ": " + m->field + ": " + quoted +
                  " aggregates columns of different files; a measurement arrives with the rows of one file");
    }
    m->stream = s;
    m->aggregates.push_back(std::move(t));
  }
  m->outer_scratch.resize(m->aggregates.size());
  if (sampling_.rate <= 0.0) {
    throw Error(bank_.file.string() + ": " + m->field + ": " + quoted + " aggregates the rows of a filter step, " +
                "which needs a fixed step: set sampling.rate (Hz) in the bank or --rate");
  }
}

// Reads the next row of a stream (one row of each of its files) into its
// fields; checks its time. Returns false at the end.
bool LogReader::Impl::read_row(Stream& s) {
  try {
    return read_row_or_throw(s);
  } catch (const Error&) {
    s.error = std::current_exception();
    s.has_row = false;
    s.ended = true;
    return false;
  }
}

void LogReader::Impl::throw_pending_error() const {
  for (const Stream& s : streams_) {
    if (s.error) std::rethrow_exception(s.error);
  }
}

bool LogReader::Impl::read_row_or_throw(Stream& s) {
  s.has_row = false;
  if (s.ended) return false;
  std::size_t ended = 0, an_ended = 0, a_longer = 0;
  for (std::size_t f = 0; f < s.files.size(); ++f) {
    if (s.files[f]->next_row()) {
      a_longer = f;
    } else {
      ++ended;
      an_ended = f;
    }
  }
  if (ended == s.files.size()) {
    s.ended = true;
    return false;
  }
  if (ended != 0) {
    throw s.files[a_longer]->error_at_row("files read side by side (sampling.join: rows) must match row for row, but " +
                                         s.files[an_ended]->path().string() + " has ended");
  }
  const LogTable& reader = *s.files[static_cast<std::size_t>(s.time_file)];
  double t = 0.0;
  if (reader.number(s.time_index, &t) != LogTable::Cell::kNumber || !std::isfinite(t)) {
    throw reader.cell_error(s.time_index, "a finite time in seconds");
  }
  t += s.offset;
  if (!std::isfinite(t)) {
    throw reader.cell_error(
        s.time_index, "a time that stays finite with the file's offset (" + CsvWriter::format(s.offset) + " s) added");
  }
  if (t <= s.last_t) {
    throw reader.error_at_row("column '" + bank_.columns.time + "': time must increase strictly, but " +
                              CsvWriter::format(t) + " follows " + CsvWriter::format(s.last_t));
  }
  s.row_t = t;
  s.has_row = true;
  if (s.rows_read++ == 0) s.first_t = t;
  return true;
}

// Applies the pending row of stream k: holds its values, and hands its
// measurements to the current step.
void LogReader::Impl::apply_row(int k) {
  Stream& s = streams_[static_cast<std::size_t>(k)];
  for (int c : s.columns) {
    const Column& col = columns_[static_cast<std::size_t>(c)];
    const LogTable& reader = *s.files[static_cast<std::size_t>(col.file)];
    double value = kNaN;
    const LogTable::Cell cell = reader.number(col.index, &value);
    const bool missing = cell == LogTable::Cell::kMissing;
    if (cell == LogTable::Cell::kNotANumber || (!missing && !std::isfinite(value))) {
      throw reader.cell_error(col.index, "a finite number (or an empty cell, nan or NA for none)");
    }
    row_values_[static_cast<std::size_t>(c)] = value;
    if (!missing) held_values_[static_cast<std::size_t>(c)] = value;
  }
  for (std::size_t i = 0; i < measurements_.size(); ++i) {
    MeasurementBinding& m = measurements_[i];
    if (m.stream != k) continue;
    if (!m.aggregated()) {
      const double value = m.row.evaluate(row_values_);
      if (std::isnan(value) && !m.row.expression) continue;  // the cell is empty: not measured in this row
      if (!std::isnan(m.pending)) ++stats_.superseded[i];
      m.pending = value;
      if (!std::isfinite(value)) {
        // An expression of present cells that is not finite (log(0)): missing, counted.
        bool all_present = true;
        for (int c : m.row.columns) all_present = all_present && !std::isnan(row_values_[static_cast<std::size_t>(c)]);
        if (all_present) ++stats_.not_finite[i];
        m.pending = kNaN;
      }
      continue;
    }
    for (AggregateTerm& term : m.aggregates) {
      const double value = term.inner.evaluate(row_values_);
      if (std::isfinite(value)) term.accumulator.add(value);
    }
  }
  if (truth_stream_ == k) {
    const std::string_view label = trim(s.files[static_cast<std::size_t>(truth_file_)]->text(truth_index_));
    // A blank cell is unlabelled, unless the bank says its logs write a label only when it changes.
    if (!label.empty() || !bank_.columns.carry_truth) held_truth_.assign(label);
  }
  s.last_t = s.row_t;
  if (rows_applied_++ == 0) first_row_t_ = s.row_t;
  last_row_t_ = std::max(last_row_t_, s.row_t);
  for (std::size_t i : s.stat_index) ++stats_.rows[i];
  s.has_row = false;
  s.read_pending = true;
}

void LogReader::Impl::read_pending_rows() {
  for (Stream& s : streams_) {
    if (!s.read_pending) continue;
    s.read_pending = false;
    read_row(s);
  }
}

double LogReader::Impl::next_row_time() {
  read_pending_rows();
  double t = std::numeric_limits<double>::infinity();
  for (const Stream& s : streams_) {
    if (s.has_row) t = std::min(t, s.row_t);
  }
  return t;
}

bool LogReader::Impl::inputs_known() const {
  for (const RowValue& v : inputs_) {
    for (int c : v.columns) {
      if (std::isnan(held_values_[static_cast<std::size_t>(c)])) return false;
    }
  }
  return true;
}

void LogReader::Impl::discard_measurements() {
  for (MeasurementBinding& m : measurements_) {
    if (!std::isnan(m.pending)) ++stats_.dropped_before_start;
    m.pending = kNaN;
    for (AggregateTerm& term : m.aggregates) {
      stats_.dropped_before_start += term.accumulator.count;
      term.accumulator.reset();
    }
  }
}

// True if t lies after the last row of a stream that feeds an input: its
// inputs would be held past their data. A log without inputs ends with its
// last stream.
bool LogReader::Impl::past_end(double t) const {
  bool any_input_stream = false;
  bool all_ended_before = true;
  for (const Stream& s : streams_) {
    if (s.feeds_inputs) {
      any_input_stream = true;
      if (s.ended && t > s.last_t) return true;
    }
    all_ended_before = all_ended_before && s.ended && t > s.last_t;
  }
  return !any_input_stream && all_ended_before;
}

void LogReader::Impl::emit(double t, LogSample* sample) {
  const Eigen::Index input_dim = static_cast<Eigen::Index>(inputs_.size());
  sample->u.resize(input_dim);
  for (std::size_t i = 0; i < inputs_.size(); ++i) {
    const double value = inputs_[i].evaluate(held_values_);
    if (!std::isfinite(value)) {
      std::string values;
      for (int c : inputs_[i].columns) {
        values += (values.empty() ? "" : ", ") + columns_[static_cast<std::size_t>(c)].name + " = " +
                  CsvWriter::format(held_values_[static_cast<std::size_t>(c)]);
      }
      const Column& first = columns_[static_cast<std::size_t>(inputs_[i].columns.front())];
      throw LogError(
          streams_[static_cast<std::size_t>(first.stream)].files[static_cast<std::size_t>(first.file)]->path().string(),
          0,
          "input '" + bank_.input_names[i] + "' = \"" + Expression::excerpt(inputs_[i].text) +
              "\" is not finite at t = " + CsvWriter::format(t) + " (latest values: " + values + ")");
    }
    sample->u[static_cast<Eigen::Index>(i)] = value;
  }
  sample->z.resize(static_cast<Eigen::Index>(measurements_.size()));
  for (std::size_t i = 0; i < measurements_.size(); ++i) {
    MeasurementBinding& m = measurements_[i];
    double value = m.pending;
    if (m.aggregated()) {
      // Missing unless every aggregate has enough rows in this step.
      bool complete = true;
      for (std::size_t a = 0; a < m.aggregates.size(); ++a) {
        m.outer_scratch[a] = m.aggregates[a].accumulator.value(m.aggregates[a].kind);
        complete = complete && !std::isnan(m.outer_scratch[a]);
        m.aggregates[a].accumulator.reset();
      }
      value = complete ? m.outer->evaluate(m.outer_scratch.data()) : kNaN;
      if (complete && !std::isfinite(value)) {
        ++stats_.not_finite[i];
        value = kNaN;
      }
    }
    sample->z[static_cast<Eigen::Index>(i)] = value;
    if (!std::isnan(value)) ++stats_.measured[i];
    m.pending = kNaN;
  }
  sample->t = t;
  sample->truth_mode = held_truth_;
  sample->true_state.resize(static_cast<Eigen::Index>(true_state_columns_.size()));
  for (std::size_t s = 0; s < true_state_columns_.size(); ++s) {
    const int c = true_state_columns_[s];
    sample->true_state[static_cast<Eigen::Index>(s)] = c < 0 ? kNaN : held_values_[static_cast<std::size_t>(c)];
  }
  sample->row = ++steps_;
  stats_.steps = steps_;
  last_step_t_ = t;
}

// A file with a header and no row gives none of its columns: said before
// any step, rather than a log running without them.
void LogReader::Impl::check_no_file_is_empty() const {
  for (const Stream& s : streams_) {
    if (!s.ended || s.rows_read > 0 || s.error) continue;
    std::string used;
    for (const Column& c : columns_) {
      if (&streams_[static_cast<std::size_t>(c.stream)] == &s) used += (used.empty() ? "" : ", ") + c.name;
    }
    throw LogError(s.files.front()->path().string(), 1,
                   "the file has a header but no data rows" +
                       (used.empty() ? std::string()
                                     : ": its columns " + Expression::excerpt(used) +
                                           ", which the bank uses, would never have a value") +
                       ". Leave it out of the log if that is meant");
  }
}

// Every file of the log has a row the steps used: a file whose rows all lie
// before the first step or after the last (an offset that misses, a file of
// another run) is an error, not a log silently run without it.
void LogReader::Impl::check_every_file_was_used() const {
  if (!started_) return;
  for (const Stream& s : streams_) {
    const bool applied = s.last_t > -std::numeric_limits<double>::infinity();
    if (s.rows_read == 0 || s.last_t >= first_step_t_ || (applied && s.holds_values)) continue;
    const LogTable& reader = *s.files[static_cast<std::size_t>(s.time_file)];
    const std::string offset =
        s.offset != 0.0 ? " (with its offset of " + CsvWriter::format(s.offset) + " s)" : std::string();
    const std::string where = s.first_t > last_step_t_
                                  ? "its rows start at t = " + CsvWriter::format(s.first_t) + " s" + offset +
                                        ", after the log's last step at t = " + CsvWriter::format(last_step_t_) +
                                        " s, where a file that feeds an input ends"
                                  : "its rows end at t = " + CsvWriter::format(s.last_t) + " s" + offset +
                                        ", before the log's first step at t = " + CsvWriter::format(first_step_t_) +
                                        " s, the first time every input has a value";
    throw LogError(reader.path().string(), 0,
                   "none of its " + std::to_string(s.rows_read) + " row(s) was used: " + where +
                       ". Is the time offset (FILE@OFFSET) right, and are the files of the same run?");
  }
}

bool LogReader::Impl::next(LogSample* sample) {
  throw_pending_error();
  // Until every input has a value: apply rows one time stamp at a time.
  while (!started_) {
    const double t = next_row_time();
    check_no_file_is_empty();
    if (!std::isfinite(t)) {
      throw_pending_error();
      return false;
    }
    discard_measurements();
    for (std::size_t k = 0; k < streams_.size(); ++k) {
      if (streams_[k].has_row && streams_[k].row_t == t) apply_row(static_cast<int>(k));
    }
    if (inputs_known()) {
      started_ = true;
      grid_origin_ = t;
      grid_index_ = 0;
      first_step_t_ = t;
      emit(t, sample);
      return true;
    }
  }
  double step_t = 0.0;
  if (sampling_.rate > 0.0) {
    step_t = next_grid_time();
    while (next_row_time() <= step_t) {
      const double t = next_row_time();
      for (std::size_t k = 0; k < streams_.size(); ++k) {
        if (streams_[k].has_row && streams_[k].row_t == t) apply_row(static_cast<int>(k));
      }
    }
  } else {
    step_t = next_row_time();
    if (!std::isfinite(step_t)) {
      throw_pending_error();
      check_every_file_was_used();
      return false;
    }
    if (!past_end(step_t)) {
      for (std::size_t k = 0; k < streams_.size(); ++k) {
        if (streams_[k].has_row && streams_[k].row_t == step_t) apply_row(static_cast<int>(k));
      }
    }
  }
  if (past_end(step_t)) {
    throw_pending_error();
    // Count what is left unread so the summary can say so.
    read_pending_rows();
    for (Stream& s : streams_) {
      while (s.has_row) {
        ++stats_.dropped_after_end;
        read_row(s);
      }
    }
    check_every_file_was_used();
    return false;
  }
  emit(step_t, sample);
  return true;
}

// The next step of the fixed-rate grid, t0 + k / rate (multiplying, not
// accumulating, keeps the grid free of drift), with the work it may do
// bounded: it never steps through a gap longer than sampling.max_gap, nor
// takes more than kMaxStepsPerRow steps per row of the log.
double LogReader::Impl::next_grid_time() {
  const double next_row = next_row_time();
  const double step_t = grid_origin_ + static_cast<double>(grid_index_ + 1) / sampling_.rate;
  if (past_end(step_t)) return step_t;  // the log ends before this step
  if (std::isfinite(next_row) && next_row > step_t && next_row - last_row_t_ > sampling_.max_gap) {
    const Stream* s = stream_at(next_row);
    const LogTable& reader = *s->files[static_cast<std::size_t>(s->time_file)];
    const double gap = next_row - last_row_t_;
    if (!sampling_.skip_gaps) {
      const double steps = gap * sampling_.rate;
      throw reader.error_at_row("column '" + bank_.columns.time + "': the log has no row from t = " +
                                CsvWriter::format(last_row_t_) + " to " + CsvWriter::format(next_row) +
                                " s, a gap of " + CsvWriter::format(gap) + " s, longer than sampling.max_gap (" +
                                CsvWriter::format(sampling_.max_gap) + " s): at " + CsvWriter::format(sampling_.rate) +
                                " Hz the filter's grid would step " + CsvWriter::format(std::floor(steps)) +
                                " times through it. If a time stamp is wrong, fix it; if the recording paused, set "
                                "sampling.skip_gaps: true in the bank to restart the grid after such gaps, or raise "
                                "sampling.max_gap");
    }
    // Restart the grid at the row after the gap: no step inside it.
    ++stats_.gaps_skipped;
    stats_.seconds_skipped += gap;
    grid_origin_ = next_row;
    grid_index_ = 0;
    last_step_t_ = next_row;
    return next_row;
  }
  if (!(step_t > last_step_t_)) {
    // Time stamps so large that t0 + k / rate no longer moves (1e300 s).
    throw LogError(stats_.files.front(), 0,
                   "the filter's grid at " + CsvWriter::format(sampling_.rate) +
                       " Hz cannot step on from t = " + CsvWriter::format(last_step_t_) +
                       " s: at times this large a step of " + CsvWriter::format(1.0 / sampling_.rate) +
                       " s is lost in the rounding of a double. Are the "
                       "time stamps in seconds?");
  }
  // The rows read: those applied and the one read ahead.
  const long rows_read = rows_applied_ + (std::isfinite(next_row) ? 1 : 0);
  if (steps_ >= kMaxStepsPerRow * std::max(rows_read, 1L)) {
    // The rows so far, up to the one read ahead, give the log's own rate.
    const double span = next_row - first_row_t_;
    const std::string row_rate =
        std::isfinite(span) && span > 0.0
            ? " (its rows so far come at about " +
                  CsvWriter::format(std::round(static_cast<double>(rows_applied_) / span * 10.0) / 10.0) + " Hz)"
            : "";
    throw LogError(stats_.files.front(), 0,
                   "the filter's rate, " + CsvWriter::format(sampling_.rate) + " Hz (sampling.rate or --rate), has " +
                       "taken " + std::to_string(steps_) + " steps for the first " + std::to_string(rows_read) +
                       " row(s) of the log" + row_rate + ": a grid may take at most " +
                       std::to_string(kMaxStepsPerRow) + " steps per row. Choose a rate near the fastest sensor's");
  }
  ++grid_index_;
  last_step_t_ = step_t;
  return step_t;
}

// The stream whose pending row is at time t.
const Stream* LogReader::Impl::stream_at(double t) const {
  for (const Stream& s : streams_) {
    if (s.has_row && s.row_t == t) return &s;
  }
  return &streams_.front();
}

LogReader::LogReader(const BankConfig& bank, const std::vector<LogFile>& files, const SamplingConfig& sampling)
    : impl_(std::make_unique<Impl>(bank, files, sampling)) {}
LogReader::LogReader(const BankConfig& bank, const std::vector<LogFile>& files)
    : LogReader(bank, files, bank.sampling) {}
LogReader::~LogReader() = default;

bool LogReader::next(LogSample* sample) { return impl_->next(sample); }
bool LogReader::has_truth() const { return impl_->truth_stream_ >= 0; }
bool LogReader::has_true_states() const { return impl_->has_true_states_; }
const LogStats& LogReader::stats() const { return impl_->stats_; }

double LogReader::progress() const {
  std::uintmax_t done = 0, total = 0;
  for (const Stream& s : impl_->streams_) {
    for (const auto& reader : s.files) {
      done += reader->bytes_read();
      total += reader->size();
    }
  }
  return total == 0 ? 1.0 : std::min(1.0, static_cast<double>(done) / static_cast<double>(total));
}

std::string LogReader::describe_stats(const BankConfig& bank) const {
  const LogStats& s = impl_->stats_;
  std::string out;
  if (s.dropped_before_start > 0) {
    out += "  " + std::to_string(s.dropped_before_start) +
           " measurement value(s) came before every input had a value and were not used\n";
  }
  if (s.dropped_after_end > 0) {
    out += "  " + std::to_string(s.dropped_after_end) +
           " row(s) after the last row of a file that feeds an input were not used\n";
  }
  if (s.gaps_skipped > 0) {
    out += "  " + std::to_string(s.gaps_skipped) + " gap(s) without rows longer than sampling.max_gap (" +
           CsvWriter::format(impl_->sampling_.max_gap) + " s) were skipped, " + CsvWriter::format(s.seconds_skipped) +
           " s in all: the grid restarted at the row after each (sampling.skip_gaps)\n";
  }
  for (std::size_t i = 0; i < s.measured.size(); ++i) {
    if (s.steps > 0 && s.measured[i] == 0) {
      out += "  measurement '" + bank.measurement.names[i] + "' (\"" +
             Expression::excerpt(bank.columns.measurements[i]) +
             "\") had no value at any step: its filters were never corrected by it\n";
    }
  }
  for (std::size_t i = 0; i < s.superseded.size(); ++i) {
    if (s.superseded[i] > 0) {
      out += "  measurement '" + bank.measurement.names[i] + "': " + std::to_string(s.superseded[i]) +
             " value(s) were replaced by a later one in the same step (the filter steps less often than this "
             "sensor reports; mean(...) in columns.measurements would average them)\n";
    }
    if (s.not_finite[i] > 0) {
      out += "  measurement '" + bank.measurement.names[i] + "': " + std::to_string(s.not_finite[i]) +
             " value(s) of its expression were not finite and count as missing\n";
    }
  }
  return out;
}

}  // namespace skidimm
