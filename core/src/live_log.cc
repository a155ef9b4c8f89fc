#include "skidimm/io/live_log.h"

#include <algorithm>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <exception>
#include <filesystem>
#include <limits>
#include <mutex>
#include <string>
#include <string_view>
#include <thread>
#include <utility>
#include <vector>

#include "log_reader_impl.h"
#include "log_table.h"
#include "skidimm/errors.h"
#include "skidimm/io/csv.h"
#include "skidimm/io/log_spec.h"

namespace skidimm {
namespace {

std::string quoted_names(const std::vector<LiveTable>& tables) {
  std::string out;
  for (const LiveTable& t : tables) out += (out.empty() ? "'" : ", '") + t.name + "'";
  return out;
}

// Thrown through the reader to stop its thread when the LiveLog goes away.
// Not an Error: the reader keeps Errors of a row for later (read_row), and
// this must leave it at once.
struct ReaderStopped {};

}  // namespace

namespace internal {

// What the program's thread and the reader's share, under one mutex.
struct LiveRows {
  std::mutex mutex;
  std::condition_variable rows_arrived;                 // the reader waits here for a row
  std::condition_variable reader_idle;                  // next() waits here for the reader
  std::vector<std::deque<std::vector<double>>> queued;  // per table: rows pushed, not yet read
  std::vector<long> pushed;                             // per table: rows pushed
  std::vector<double> last_time;                        // per table: the time of the last row pushed
  std::vector<bool> closed;
  std::size_t max_queued = LiveLog::kDefaultMaxQueuedRows;
  int waiting_for = -1;  // the table whose next row the reader waits for; -1 while it works
  bool finished = false;
  bool stopping = false;
  std::deque<LogSample> steps;  // steps made, not yet taken
  std::exception_ptr error;

  // The reader cannot go on until a row of a table is pushed (or it is closed).
  bool reader_waits() const {
    if (finished) return true;
    if (waiting_for < 0) return false;
    const std::size_t k = static_cast<std::size_t>(waiting_for);
    return queued[k].empty() && !closed[k];
  }
};

}  // namespace internal

namespace {

using internal::LiveRows;

// A table of a live log as the reader reads a file: rows taken from the
// queue the program pushes to, waiting there for the next.
class PushedTable : public LogTable {
 public:
  PushedTable(std::shared_ptr<LiveRows> rows, int index, const LiveTable& spec)
      : rows_(std::move(rows)),
        index_(index),
        columns_(spec.columns),
        path_(spec.name),
        shown_("live table '" + spec.name + "'") {}

  const std::filesystem::path& path() const override { return path_; }
  std::string name() const override { return shown_; }
  std::vector<std::string> columns_present() const override { return columns_; }
  int column(const std::string& name) override {
    for (std::size_t c = 0; c < columns_.size(); ++c) {
      if (columns_[c] == name) return static_cast<int>(c);
    }
    return -1;
  }

  bool next_row() override {
    std::unique_lock<std::mutex> lock(rows_->mutex);
    const std::size_t k = static_cast<std::size_t>(index_);
    while (rows_->queued[k].empty() && !rows_->closed[k] && !rows_->stopping) {
      rows_->waiting_for = index_;
      rows_->reader_idle.notify_all();
      rows_->rows_arrived.wait(lock);
    }
    rows_->waiting_for = -1;
    if (rows_->stopping) throw ReaderStopped();
    if (rows_->queued[k].empty()) return false;  // closed
    row_ = std::move(rows_->queued[k].front());
    rows_->queued[k].pop_front();
    ++row_number_;
    return true;
  }

  Cell number(int column, double* value) const override {
    *value = row_[static_cast<std::size_t>(column)];
    if (std::isnan(*value)) return Cell::kMissing;
    return std::isfinite(*value) ? Cell::kNumber : Cell::kNotANumber;
  }
  std::string_view text(int column) const override {
    text_ = CsvWriter::format(row_[static_cast<std::size_t>(column)]);
    return text_;
  }
  LogError cell_error(int column, const std::string& expected) const override {
    return error_at_row("column " + std::to_string(column + 1) + " ('" + columns_[static_cast<std::size_t>(column)] +
                        "'): expected " + expected + ", got " +
                        CsvWriter::format(row_[static_cast<std::size_t>(column)]));
  }
  LogError error_at_row(const std::string& message) const override {
    return LogError(shown_, 0, "row " + std::to_string(row_number_) + ": " + message);
  }
  LogError error(const std::string& message) const override { return LogError(shown_, 0, message); }
  std::uintmax_t bytes_read() const override { return 0; }
  std::uintmax_t size() const override { return 0; }

 private:
  std::shared_ptr<LiveRows> rows_;
  int index_;
  std::vector<std::string> columns_;
  std::filesystem::path path_;
  std::string shown_;
  std::vector<double> row_;
  long row_number_ = 0;
  mutable std::string text_;
};

}  // namespace

class LiveLog::Impl {
 public:
  using LiveRows = internal::LiveRows;

  Impl(const BankConfig& bank, std::vector<LiveTable> tables, const SamplingConfig& sampling)
      : bank_(bank), tables_(std::move(tables)), rows_(std::make_shared<LiveRows>()) {
    if (tables_.empty()) throw Error("a live log needs at least one table");
    for (std::size_t k = 0; k < tables_.size(); ++k) {
      const LiveTable& t = tables_[k];
      if (t.name.empty()) throw Error("live table " + std::to_string(k + 1) + " has no name");
      for (std::size_t j = 0; j < k; ++j) {
        if (tables_[j].name == t.name) throw Error("two live tables are named '" + t.name + "'");
      }
      if (t.columns.empty()) throw Error("live table '" + t.name + "' has no columns");
      for (std::size_t c = 0; c < t.columns.size(); ++c) {
        for (std::size_t d = 0; d < c; ++d) {
          if (t.columns[d] == t.columns[c]) {
            throw Error("live table '" + t.name + "' names column '" + t.columns[c] + "' twice");
          }
        }
      }
      if (!std::isfinite(t.time_offset) || std::abs(t.time_offset) > kLargestTimeOffset) {
        throw Error("live table '" + t.name + "': the time offset must be finite and at most 1e11 s in size " +
                    "(where times keep the precision to tell rows apart), got " + CsvWriter::format(t.time_offset));
      }
    }
    rows_->queued.resize(tables_.size());
    rows_->pushed.assign(tables_.size(), 0);
    rows_->last_time.assign(tables_.size(), -std::numeric_limits<double>::infinity());
    rows_->closed.assign(tables_.size(), false);
    std::vector<LogReader::Impl::TableOfLog> made;
    for (std::size_t k = 0; k < tables_.size(); ++k) {
      made.push_back({std::make_unique<PushedTable>(rows_, static_cast<int>(k), tables_[k]), tables_[k].time_offset});
    }
    // Bound here, on the program's thread: a bank that names a column no
    // table has is an error of the constructor.
    reader_ =
        std::unique_ptr<LogReader>(new LogReader(std::make_unique<LogReader::Impl>(bank_, std::move(made), sampling)));
    for (const LiveTable& t : tables_) {
      time_column_.push_back(
          static_cast<int>(std::find(t.columns.begin(), t.columns.end(), bank_.columns.time) - t.columns.begin()));
    }
    thread_ = std::thread([this] { read(); });
  }

  ~Impl() {
    {
      std::lock_guard<std::mutex> lock(rows_->mutex);
      rows_->stopping = true;
    }
    rows_->rows_arrived.notify_all();
    thread_.join();
  }

  int table(const std::string& name) const {
    for (std::size_t k = 0; k < tables_.size(); ++k) {
      if (tables_[k].name == name) return static_cast<int>(k);
    }
    throw Error("the live log has no table '" + name + "'; its tables: " + quoted_names(tables_));
  }

  void check_table(int table) const {
    if (table < 0 || table >= static_cast<int>(tables_.size())) {
      throw Error("the live log has no table " + std::to_string(table) + "; its tables are 0 to " +
                  std::to_string(tables_.size() - 1) + ": " + quoted_names(tables_));
    }
  }

  void push(int table, const double* values, std::size_t count) {
    check_table(table);
    const std::size_t k = static_cast<std::size_t>(table);
    const LiveTable& spec = tables_[k];
    const auto shown = [&] { return "live table '" + spec.name + "'"; };
    if (count != spec.columns.size()) {
      std::string names;
      for (const std::string& c : spec.columns) names += (names.empty() ? "" : ", ") + c;
      throw Error(shown() + ": a row has " + std::to_string(count) + " value(s), the table " +
                  std::to_string(spec.columns.size()) + " column(s): " + names);
    }
    {
      std::unique_lock<std::mutex> lock(rows_->mutex);
      // Every table is closed when the reader has ended without an error.
      if (rows_->closed[k]) throw Error(shown() + " was closed: no row may follow");
      if (rows_->queued[k].size() >= rows_->max_queued) {
        // Whether the reader can still take some is known once it waits.
        rows_->reader_idle.wait(lock, [&] { return rows_->reader_waits(); });
      }
      if (rows_->finished) return;  // stopped at a bad row, which next() throws: nothing reads this one
      if (rows_->queued[k].size() >= rows_->max_queued) {
        std::string waited;
        if (rows_->waiting_for >= 0 && rows_->waiting_for != table) {
          const std::size_t w = static_cast<std::size_t>(rows_->waiting_for);
          waited = ": the reader waits for a row of live table '" + tables_[w].name + "' (" +
                   std::to_string(rows_->pushed[w]) + " row(s) pushed" +
                   (rows_->pushed[w] > 0 ? ", the last at t = " + CsvWriter::format(rows_->last_time[w]) : "") +
                   "), which completes a step only with a row at or after it. A sensor that stopped: close() its "
                   "table, and the steps go on without it";
        }
        throw Error(shown() + " holds " + std::to_string(rows_->queued[k].size()) +
                    " rows the reader has not taken (max_queued_rows)" + waited);
      }
      rows_->queued[k].emplace_back(values, values + count);
      ++rows_->pushed[k];
      // In the reader's seconds, as its own messages give times.
      const std::size_t time = static_cast<std::size_t>(time_column_[k]);
      if (time < count) rows_->last_time[k] = values[time] / bank_.columns.time_units_per_second + spec.time_offset;
    }
    rows_->rows_arrived.notify_all();
  }

  void close(int table) {
    check_table(table);
    {
      std::lock_guard<std::mutex> lock(rows_->mutex);
      rows_->closed[static_cast<std::size_t>(table)] = true;
    }
    rows_->rows_arrived.notify_all();
  }

  void close() {
    {
      std::lock_guard<std::mutex> lock(rows_->mutex);
      rows_->closed.assign(rows_->closed.size(), true);
    }
    rows_->rows_arrived.notify_all();
  }

  bool next(LogSample* sample) {
    std::unique_lock<std::mutex> lock = wait_for_reader();
    if (!rows_->steps.empty()) {
      *sample = std::move(rows_->steps.front());
      rows_->steps.pop_front();
      return true;
    }
    if (rows_->error) std::rethrow_exception(rows_->error);
    return false;
  }

  bool ended() {
    std::unique_lock<std::mutex> lock = wait_for_reader();
    return rows_->finished && rows_->steps.empty();
  }

  LiveLog::Waiting waiting_for() {
    std::unique_lock<std::mutex> lock = wait_for_reader();
    LiveLog::Waiting out;
    if (rows_->finished) return out;
    out.table = rows_->waiting_for;
    const std::size_t k = static_cast<std::size_t>(out.table);
    out.rows = rows_->pushed[k];
    out.last_time = rows_->last_time[k];
    return out;
  }

  // The reader's state while it waits (it touches it only after the mutex).
  template <typename F>
  auto with_reader(F f) {
    std::unique_lock<std::mutex> lock = wait_for_reader();
    return f(*reader_);
  }

  std::size_t max_queued_rows() const {
    std::lock_guard<std::mutex> lock(rows_->mutex);
    return rows_->max_queued;
  }
  void set_max_queued_rows(std::size_t rows) {
    if (rows == 0) throw Error("a live log's max_queued_rows must be at least 1");
    std::lock_guard<std::mutex> lock(rows_->mutex);
    rows_->max_queued = rows;
  }

  const BankConfig bank_;
  const std::vector<LiveTable> tables_;

 private:
  std::unique_lock<std::mutex> wait_for_reader() {
    std::unique_lock<std::mutex> lock(rows_->mutex);
    rows_->reader_idle.wait(lock, [&] { return rows_->reader_waits(); });
    return lock;
  }

  // The reader's thread: steps made as the rows come, until the log ends,
  // an error, or the LiveLog goes away.
  void read() {
    try {
      for (;;) {
        LogSample sample;
        const bool more = reader_->next(&sample);
        std::lock_guard<std::mutex> lock(rows_->mutex);
        if (!more) {
          rows_->finished = true;
          rows_->reader_idle.notify_all();
          return;
        }
        rows_->steps.push_back(std::move(sample));
      }
    } catch (const ReaderStopped&) {
      return;
    } catch (...) {
      std::lock_guard<std::mutex> lock(rows_->mutex);
      rows_->error = std::current_exception();
      rows_->finished = true;
      rows_->reader_idle.notify_all();
    }
  }

  std::shared_ptr<LiveRows> rows_;
  std::unique_ptr<LogReader> reader_;
  std::vector<int> time_column_;  // per table
  std::thread thread_;
};

LiveLog::LiveLog(const BankConfig& bank, std::vector<LiveTable> tables, const SamplingConfig& sampling)
    : impl_(std::make_unique<Impl>(bank, std::move(tables), sampling)) {}
LiveLog::LiveLog(const BankConfig& bank, std::vector<LiveTable> tables)
    : LiveLog(bank, std::move(tables), bank.sampling) {}
LiveLog::~LiveLog() = default;

int LiveLog::table(const std::string& name) const { return impl_->table(name); }
int LiveLog::num_tables() const { return static_cast<int>(impl_->tables_.size()); }
const LiveTable& LiveLog::table_columns(int table) const {
  impl_->check_table(table);
  return impl_->tables_[static_cast<std::size_t>(table)];
}
void LiveLog::push(int table, const double* values, std::size_t count) { impl_->push(table, values, count); }
void LiveLog::close(int table) { impl_->close(table); }
void LiveLog::close() { impl_->close(); }
bool LiveLog::next(LogSample* sample) { return impl_->next(sample); }
bool LiveLog::ended() const { return impl_->ended(); }
LiveLog::Waiting LiveLog::waiting_for() const { return impl_->waiting_for(); }
LogStats LiveLog::stats() const {
  return impl_->with_reader([](const LogReader& r) { return r.stats(); });
}
std::string LiveLog::describe_stats() const {
  return impl_->with_reader([this](const LogReader& r) { return r.describe_stats(impl_->bank_); });
}
std::vector<std::string> LiveLog::unmeasured() const {
  return impl_->with_reader([this](const LogReader& r) { return r.unmeasured(impl_->bank_); });
}
std::size_t LiveLog::max_queued_rows() const { return impl_->max_queued_rows(); }
void LiveLog::set_max_queued_rows(std::size_t rows) { impl_->set_max_queued_rows(rows); }

}  // namespace skidimm
