#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <exception>
#include <filesystem>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "csv_table.h"
#include "log_reader_impl.h"
#include "not_a_number.h"
#include "ros/bag_log.h"
#include "skidimm/errors.h"
#include "skidimm/io/ros/bag_reader.h"

namespace skidimm {

using internal::aggregate_names;
using internal::AggregateTerm;
using internal::aggregation_of;
using internal::CsvTable;
using internal::printable_header;
using internal::trim;

namespace {

using ::skidimm::internal::kNaN;

// A writer that opens every FIFO of a log before it writes to any (a
// recorder streaming two sensors at once) waits in each open() until a
// reader opens that FIFO. Opened one by one, each read for its header before
// the next is opened, the log would wait on the first FIFO's header while
// its writer waits for the second FIFO's reader. So every FIFO of the log is
// opened first, without waiting (the writer's opens all return), and each is
// read through that descriptor (CsvReader waits there for its writer).
class FifosHeldOpen {
 public:
  explicit FifosHeldOpen(const std::vector<LogFile>& files) {
    for (const LogFile& file : files) {
      std::error_code ec;
      if (!std::filesystem::is_fifo(file.path, ec)) continue;
      const int fd = ::open(file.path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
      if (fd < 0) continue;  // the path's own open says why
      fds_.push_back(fd);
      paths_.push_back(file.path);
    }
  }
  ~FifosHeldOpen() {
    for (const int fd : fds_) {
      if (fd >= 0) ::close(fd);
    }
  }
  // The descriptor opened for `path`, now the caller's; -1 if none.
  int take(const std::filesystem::path& path) {
    for (std::size_t k = 0; k < fds_.size(); ++k) {
      if (paths_[k] == path && fds_[k] >= 0) return std::exchange(fds_[k], -1);
    }
    return -1;
  }
  FifosHeldOpen(const FifosHeldOpen&) = delete;
  FifosHeldOpen& operator=(const FifosHeldOpen&) = delete;

 private:
  std::vector<int> fds_;
  std::vector<std::filesystem::path> paths_;
};

// The bank's column texts that may name a bag's topics (ros/bag_log.h).
std::vector<std::string> bag_column_texts(const BankConfig& bank) {
  std::vector<std::string> texts = bank.columns.inputs;
  texts.insert(texts.end(), bank.columns.measurements.begin(), bank.columns.measurements.end());
  return texts;
}

// Why an aggregated measurement cannot use `name` outside its aggregates.
std::string outside_aggregates(const std::string& text, const std::string& name) {
  return "\"" + Expression::excerpt(text) + "\" uses column '" + Expression::excerpt(name) +
         "' outside mean(), std(), rms() or diff_std(); in an aggregated measurement every column is inside one";
}

// A column text that is no column of the log, read as an expression into
// *parsed: why it cannot be ("" when it can), as the reader says it.
std::string row_value_problem(const std::string& text, std::unique_ptr<Expression>* parsed) {
  try {
    *parsed = std::make_unique<Expression>(text);
  } catch (const ExpressionError& e) {
    return e.what();
  }
  if ((*parsed)->variables().empty()) return "\"" + Expression::excerpt(text) + "\" uses no column of the log";
  return std::string();
}

// A header whose fields, split at ';' or tabs, give `wanted`: the file is
// separated by another character than the comma the reader splits on (a
// spreadsheet's export in a locale whose decimal mark is the comma). Said
// beside "no column", which alone reads as a misspelt name; a header that
// only holds such a character (a note, a column named with it) gets nothing.
std::string separator_hint(const std::vector<std::string>& header, const std::string& wanted) {
  const auto unquoted = [](const std::string& text) {
    const std::string part(trim(text));
    if (part.size() >= 2 && part.front() == '"' && part.back() == '"') return part.substr(1, part.size() - 2);
    return part;
  };
  // "sep=," is split at its comma: its line is separated as the file is, and
  // only in the way.
  if (header.size() == 2 && header[0] == "sep=" && header[1].empty()) {
    return ". Its first line, 'sep=,', is a spreadsheet's separator line, not the header: delete that line "
           "(skidimm reads comma-separated files whose first line is the header)";
  }
  if (header.size() == 1 && header.front().rfind("sep=", 0) == 0) {
    return ". Its first line, '" + header.front() +
           "', is a spreadsheet's separator line: skidimm reads comma-separated files whose first line is the "
           "header; write it with commas between values and points as decimal marks";
  }
  for (const char separator : {';', '\t'}) {
    for (const std::string& field : header) {
      for (std::size_t at = 0; at <= field.size();) {
        const std::size_t next = std::min(field.find(separator, at), field.size());
        if (next == field.size() && at == 0) break;  // no separator in this field
        if (unquoted(field.substr(at, next - at)) == wanted) {
          return std::string(". Its header holds '") + wanted + "' between " + (separator == ';' ? "';'" : "tabs") +
                 ": the file is not comma-separated, which is what skidimm reads; write it with commas between "
                 "values and points as decimal marks";
        }
        at = next + 1;
      }
    }
  }
  return std::string();
}

// A file of one run beside `file` that has `column`: the same name but for
// what comes before the run's number ("imu_00.csv" beside "pro_00.csv"), as
// a robot's sensors are often logged one file each. Said beside "no column"
// for a log of one file, which then reads as a wrong bank, when the run's
// other file was only not named with it (a directory of such runs read file
// by file). "" when there is none.
std::string partner_file_hint(const std::filesystem::path& file, const std::string& column) {
  namespace fs = std::filesystem;
  const std::string stem = file.stem().string();
  std::size_t digits = stem.size();
  while (digits > 0 && std::isdigit(static_cast<unsigned char>(stem[digits - 1])) != 0) --digits;
  if (file.extension() != ".csv" || digits == stem.size() || digits == 0) return std::string();
  const std::string run = stem.substr(digits), prefix = stem.substr(0, digits);
  const fs::path directory = file.has_parent_path() ? file.parent_path() : fs::path(".");
  std::vector<fs::path> partners;
  std::error_code ec;
  for (fs::directory_iterator it(directory, ec), end; !ec && it != end; it.increment(ec)) {
    const fs::path& candidate = it->path();
    const std::string other = candidate.stem().string();
    if (candidate.extension() != file.extension() || other.size() <= run.size() ||
        other.compare(other.size() - run.size(), run.size(), run) != 0) {
      continue;
    }
    const std::string other_prefix = other.substr(0, other.size() - run.size());
    if (other_prefix == prefix || std::isdigit(static_cast<unsigned char>(other_prefix.back())) != 0) continue;
    partners.push_back(candidate);
  }
  std::sort(partners.begin(), partners.end());
  for (const fs::path& candidate : partners) {
    try {
      if (!fs::is_regular_file(candidate, ec) || CsvReader(candidate).column(column) < 0) continue;
    } catch (const std::exception&) {
      continue;  // unreadable: no hint from it
    }
    const std::string other = candidate.stem().string();
    const std::string other_prefix = other.substr(0, other.size() - run.size());
    const std::string extension = file.extension().string();
    const auto in_directory = [&](const std::string& name) {
      return file.has_parent_path() ? (file.parent_path() / name).string() : name;
    };
    return ". " + candidate.filename().string() + " beside it has column '" + column +
           "': name a run's files together, '" + file.string() + "+" + in_directory(candidate.filename().string()) +
           "' (every run of the folder: '" + in_directory(prefix + "*" + extension) + "+" +
           in_directory(other_prefix + "*" + extension) + "')";
  }
  return std::string();
}

}  // namespace

LogReader::Impl::Impl(const BankConfig& bank, const SamplingConfig& sampling) : bank_(bank), sampling_(sampling) {
  if (!(sampling.rate == 0.0 || (sampling.rate > 0.0 && sampling.rate <= 1e6))) {
    throw Error(
        "the filter's rate (sampling.rate or --rate) must be in Hz, > 0 and at most 1e6, or 0 for a step at "
        "every time stamp; got " +
        CsvWriter::format(sampling.rate));
  }
  if (!(sampling.max_gap > 0.0)) {
    throw Error("sampling.max_gap must be a time in seconds, > 0; got " + CsvWriter::format(sampling.max_gap));
  }
}

LogReader::Impl::Impl(const BankConfig& bank, const std::vector<LogFile>& files, const SamplingConfig& sampling)
    : Impl(bank, sampling) {
  if (files.empty()) throw LogError("", 0, "no input log given");
  int standard_inputs = 0;
  for (const LogFile& file : files) standard_inputs += is_standard_input(file.path) ? 1 : 0;
  if (standard_inputs > 1) throw LogError("-", 0, "standard input ('-') can be one file of a log, not several");
  const bool by_rows = sampling.join == SamplingConfig::Join::kRows;
  if (by_rows) streams_.emplace_back();
  FifosHeldOpen fifos(files);
  for (const LogFile& file : files) {
    if (!by_rows) {
      streams_.emplace_back();
      streams_.back().offset = file.time_offset;
    }
    if (!is_standard_input(file.path) && ros::BagReader::is_bag(file.path)) {
      // A ROS 2 bag: each topic the bank names is a file of its own (ros/bag_log.h).
      if (by_rows) {
        throw Error(bank.shown_file() + ": sampling.join: rows is for CSV files that match row for row; " +
                    file.path.string() + " is a ROS 2 bag, whose topics are merged by time");
      }
      streams_.pop_back();
      if (bank.columns.time_units_per_second != 1.0) {
        throw Error(bank.shown_file() + ": columns.time_unit: " + bank.columns.time_unit_name +
                    " is the unit of a CSV file's time column; " + file.path.string() +
                    " is a ROS 2 bag, whose stamps are read in seconds: leave columns.time_unit out");
      }
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
    s.time_units_per_second = bank.columns.time_units_per_second;
    const int fifo = fifos.take(file.path);
    s.files.push_back(fifo >= 0 ? std::make_unique<CsvTable>(file.path, fifo) : std::make_unique<CsvTable>(file.path));
    s.stat_index.push_back(stats_.files.size());
    stats_.files.push_back(file.path.string());
    stats_.rows.push_back(0);
  }
  find_time_columns();
  if (by_rows) {
    // Read row for row, the files share the time of the one with the time
    // column: an offset on another would be ignored without a word.
    const std::size_t timed = static_cast<std::size_t>(streams_.front().time_file);
    streams_.front().offset = files[timed].time_offset;
    for (std::size_t f = 0; f < files.size(); ++f) {
      if (f != timed && files[f].time_offset != 0.0) {
        throw LogError(
            files[f].path.string(), 0,
            "an offset (@" + CsvWriter::format(files[f].time_offset) +
                ") on a file without the log's time: with sampling.join: rows every file takes the time of " +
                files[timed].path.string() + ", so put the offset there");
      }
    }
  }
  bind_columns();
}

LogReader::Impl::Impl(const BankConfig& bank, std::vector<TableOfLog> tables, const SamplingConfig& sampling)
    : Impl(bank, sampling) {
  if (tables.empty()) throw LogError("", 0, "no input log given");
  if (sampling.join == SamplingConfig::Join::kRows) {
    throw Error(bank.shown_file() +
                ": sampling.join: rows reads files that match row for row; the tables of a live log are merged by "
                "time (sampling.join: time)");
  }
  for (TableOfLog& t : tables) {
    streams_.emplace_back();
    Stream& s = streams_.back();
    s.offset = t.time_offset;
    s.time_units_per_second = bank.columns.time_units_per_second;
    s.stat_index.push_back(stats_.files.size());
    stats_.files.push_back(t.table->name());
    stats_.rows.push_back(0);
    s.files.push_back(std::move(t.table));
  }
  find_time_columns();
  bind_columns();
}

void LogReader::Impl::find_time_columns() {
  const BankConfig& bank = bank_;
  const bool by_rows = sampling_.join == SamplingConfig::Join::kRows;
  // The time column: in every file (join: time) or in the first file that has it (join: rows).
  for (std::size_t k = 0; k < streams_.size(); ++k) {
    Stream& s = streams_[k];
    for (std::size_t f = 0; f < s.files.size() && s.time_file < 0; ++f) {
      const int index = s.files[f]->column(bank.columns.time);
      if (index >= 0) {
        s.time_file = static_cast<int>(f);
        s.time_index = index;
      }
    }
    if (s.time_file < 0) {
      int listed = 0;
      const LogTable& reader = *s.files.front();
      std::string message = "no time column '" + bank.columns.time + "' (the bank's columns.time); columns present: " +
                            printable_header(reader.columns_present(), &listed, 400);
      const std::string hint = separator_hint(reader.columns_present(), bank.columns.time);
      if (!hint.empty()) throw reader.error(message + hint);
      if (!by_rows && streams_.size() > 1) {
        // A multi-rate log (an IMU file beside a wheel file) whose files stamp in their own column names or
        // units: one bank reads them all, so each needs the same column in the same unit.
        message +=
            ". Every file of a log is merged on its own time column (sampling.join: time), the one the bank names "
            "in the unit it reads (columns.time, columns.time_unit): a file that stamps under another name or unit "
            "needs that column renamed or converted. Files that match row for row with one time column between "
            "them need sampling.join: rows instead";
      }
      throw reader.error(message);
    }
  }
}

void LogReader::Impl::bind_columns() {
  const BankConfig& bank = bank_;
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
  stats_.left_out_of_aggregates.assign(measurements_.size(), 0);
  stats_.steps_without_enough_rows.assign(measurements_.size(), 0);
  stats_.measured.assign(measurements_.size(), 0);
  stats_.longest_unmeasured.assign(measurements_.size(), 0);
  stats_.longest_unmeasured_from.assign(measurements_.size(), kNaN);
  stats_.longest_unmeasured_to.assign(measurements_.size(), kNaN);
  unmeasured_run_.assign(measurements_.size(), 0);
  unmeasured_run_from_.assign(measurements_.size(), kNaN);
  for (Stream& s : streams_) s.read_pending = true;
}

std::vector<std::string> LogReader::unreadable_column_texts(const BankConfig& bank) {
  std::vector<std::string> problems;
  // Located as the loader's errors are: "<file>:<line>: <field>: <why>".
  const auto say = [&](const std::vector<int>& lines, std::size_t i, const std::string& field, const std::string& why) {
    problems.push_back(ConfigError(bank.shown_file(), i < lines.size() ? lines[i] : 0, field, why).what());
  };
  // As bind_row_value() reads a text when no column has its exact name.
  const auto check_row_value = [&](const std::string& text, const std::vector<int>& lines, std::size_t i,
                                   const std::string& field) {
    if (Expression::is_identifier(std::string(trim(text)))) return;
    std::unique_ptr<Expression> parsed;
    const std::string problem = row_value_problem(text, &parsed);
    if (!problem.empty()) say(lines, i, field, problem);
  };
  for (std::size_t i = 0; i < bank.columns.inputs.size() && i < bank.input_names.size(); ++i) {
    check_row_value(bank.columns.inputs[i], bank.columns.input_lines, i, "columns.inputs." + bank.input_names[i]);
  }
  // As bind_measurement() reads a text: its aggregates cut out first.
  const std::vector<int>& lines = bank.columns.measurement_lines;
  for (std::size_t i = 0; i < bank.columns.measurements.size() && i < bank.measurement.names.size(); ++i) {
    const std::string& text = bank.columns.measurements[i];
    const std::string field = "columns.measurements." + bank.measurement.names[i];
    if (Expression::is_identifier(std::string(trim(text)))) continue;
    Expression::WithCalls cut;
    try {
      cut = Expression::cut_calls(text, aggregate_names());
    } catch (const ExpressionError& e) {
      say(lines, i, field, e.what());
      continue;
    }
    if (cut.calls.empty()) {
      check_row_value(text, lines, i, field);
    } else if (!cut.names_outside.empty()) {
      say(lines, i, field, outside_aggregates(text, cut.names_outside.front()));
    } else {
      for (const Expression::Call& call : cut.calls) check_row_value(call.argument, lines, i, field);
    }
  }
  return problems;
}

std::vector<std::string> LogReader::aggregated_measurements(const BankConfig& bank) {
  std::vector<std::string> fields;
  for (std::size_t i = 0; i < bank.columns.measurements.size() && i < bank.measurement.names.size(); ++i) {
    const std::string& text = bank.columns.measurements[i];
    if (Expression::is_identifier(std::string(trim(text)))) continue;
    try {
      if (!Expression::cut_calls(text, aggregate_names()).calls.empty()) {
        fields.push_back("columns.measurements." + bank.measurement.names[i]);
      }
    } catch (const ExpressionError&) {
      // unreadable_column_texts() says why
    }
  }
  return fields;
}

void LogReader::Impl::missing_column(const std::string& column, const std::string& field) const {
  // Each file's columns after its name when the log has several: one list
  // read as the first file's (an IMU column reported missing from the wheels').
  std::size_t files = 0;
  for (const Stream& s : streams_) files += s.files.size();
  std::string present;
  std::string hint;
  int listed = 0;
  for (const Stream& s : streams_) {
    for (const auto& reader : s.files) {
      if (hint.empty()) {
        hint = separator_hint(reader->columns_present(), column);
        if (!hint.empty() && files > 1) hint += " (" + reader->path().filename().string() + ")";
      }
      const std::string h = printable_header(reader->columns_present(), &listed, 400);
      if (h.empty()) continue;
      present += (present.empty() ? "" : "; ") + h;
      if (files > 1) present += " (" + reader->path().filename().string() + ")";
    }
  }
  if (files == 1 && hint.empty() && !is_standard_input(streams_.front().files.front()->path())) {
    hint = partner_file_hint(streams_.front().files.front()->path(), column);
  }
  throw streams_.front().files.front()->error("no column '" + Expression::excerpt(column) + "' (the bank's " + field +
                                              ")" + (files > 1 ? " in any file of the log" : "") +
                                              "; columns present: " + present + hint);
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

LogReader::Impl::RowValue LogReader::Impl::bind_row_value(const std::string& text, const std::string& field) {
  RowValue v;
  v.text = text;
  // A column's exact name is that column, whatever characters it has.
  if (is_column(text)) {
    v.columns.push_back(column_id(text, field, true));
  } else {
    const std::string problem = row_value_problem(text, &v.expression);
    if (!problem.empty()) {
      if (!v.expression && Expression::is_identifier(std::string(trim(text)))) {
        missing_column(std::string(trim(text)), field);
      }
      throw Error(bank_.shown_file() + ": " + field + ": " + problem);
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
                 streams_[static_cast<std::size_t>(col.stream)].files[static_cast<std::size_t>(col.file)]->name() + ")";
      }
      throw Error(bank_.shown_file() + ": " + m->field + ": " + what + " uses columns of different files [" + names +
                  "]; a measurement arrives with a row of one file (inputs may mix files)");
    }
    return v.streams.front();
  };
  Expression::WithCalls cut;
  if (!is_column(text)) {
    try {
      cut = Expression::cut_calls(text, aggregate_names());
    } catch (const ExpressionError& e) {
      if (Expression::is_identifier(std::string(trim(text)))) missing_column(std::string(trim(text)), m->field);
      throw Error(bank_.shown_file() + ": " + m->field + ": " + e.what());
    }
  }
  if (cut.calls.empty()) {
    m->row = bind_row_value(text, m->field);
    m->stream = one_stream(m->row, quoted);
    return;
  }
  if (!cut.names_outside.empty()) {
    throw Error(bank_.shown_file() + ": " + m->field + ": " + outside_aggregates(text, cut.names_outside.front()));
  }
  m->outer = std::move(cut.outer);
  for (const Expression::Call& call : cut.calls) {
    AggregateTerm t;
    t.kind = aggregation_of(call.function);
    t.inner = bind_row_value(call.argument, m->field);
    const int s = one_stream(t.inner, call.function + "(" + Expression::excerpt(call.argument) + ")");
    if (m->stream >= 0 && s != m->stream) {
      throw Error(bank_.shown_file() + ": " + m->field + ": " + quoted +
                  " aggregates columns of different files; a measurement arrives with the rows of one file");
    }
    m->stream = s;
    m->aggregates.push_back(std::move(t));
  }
  m->outer_scratch.resize(m->aggregates.size());
  if (sampling_.rate <= 0.0) {
    throw Error(bank_.shown_file() + ": " + m->field + ": " + quoted + " aggregates the rows of a filter step, " +
                "which needs a fixed step: set sampling.rate (Hz) in the bank or --rate");
  }
}

}  // namespace skidimm
