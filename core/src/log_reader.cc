#include "skidimm/io/log_reader.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <string>

#include "csv_table.h"
#include "log_reader_impl.h"
#include "not_a_number.h"
#include "skidimm/config/expression.h"
#include "skidimm/errors.h"
#include "skidimm/io/csv.h"
#include "skidimm/io/ros/bag_reader.h"
#include "skidimm/time_origin.h"

namespace skidimm {

using internal::AggregateTerm;
using internal::Stream;
using internal::trim;

namespace {

using ::skidimm::internal::kNaN;

// Whether a column text selects a sequence's entry by a name
// (`/joint_states.velocity[left]`), which has a value only in the messages
// that have that name, rather than by an index (`position[0]`).
bool selects_by_name(const std::string& text) {
  for (std::size_t open = text.find('['); open != std::string::npos; open = text.find('[', open + 1)) {
    const std::size_t close = text.find(']', open);
    if (close == std::string::npos) return false;
    if (close > open + 1 && text.find_first_not_of("0123456789", open + 1) < close) return true;
  }
  return false;
}

constexpr const char* kMaybeSelectedByNameHint =
    " (where it selects a sequence's entry by name, [NAME], that name may be in no message: `skidimm bag FILE` "
    "lists the names the bag has)";
constexpr const char* kSelectedByNameHint =
    " (a sequence's entry selected by name, [NAME], has a value only in messages that have that name: `skidimm bag "
    "FILE` lists the names the bag has)";

constexpr const char* kOutOfOrderHint =
    ". If the row repeats an earlier one or was written out of order, sampling.skip_out_of_order: true in the bank "
    "leaves out each row whose time is not after its file's last, counted in the summary";

}  // namespace

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
  // Until a row whose time is after the last (rows out of order are left
  // out with sampling.skip_out_of_order, and the next one read).
  for (;;) {
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
      throw s.files[a_longer]->error_at_row(
          "files read side by side (sampling.join: rows) must match row for row, but " +
          s.files[an_ended]->path().string() + " has ended");
    }
    const LogTable& reader = *s.files[static_cast<std::size_t>(s.time_file)];
    double t = 0.0;
    if (reader.number(s.time_index, &t) != LogTable::Cell::kNumber || !std::isfinite(t)) {
      throw reader.cell_error(s.time_index,
                              s.time_units_per_second == 1.0
                                  ? std::string("a finite time in seconds")
                                  : "a finite time in " + bank_.columns.time_unit_name + " (columns.time_unit)");
    }
    t /= s.time_units_per_second;
    t += s.offset;
    if (!std::isfinite(t)) {
      throw reader.cell_error(s.time_index, "a time that stays finite with the file's offset (" +
                                                CsvWriter::format(s.offset) + " s) added");
    }
    if (t <= s.read_t) {
      const std::string what = "column '" + bank_.columns.time + "': time must increase strictly, but " + time_text(t) +
                               " follows " + time_text(s.read_t);
      if (sampling_.skip_out_of_order) {
        // The row is left out, as if the file did not have it.
        if (stats_.out_of_order_skipped++ == 0) {
          stats_.first_out_of_order =
              reader.error_at_row("t = " + time_text(t) + " after " + time_text(s.read_t)).what();
        }
        continue;
      }
      // A driver that leaves its messages' stamps unset writes 0 in each; the
      // bag's own record of when each arrived is a time that increases.
      const bool unset_stamps = t == s.offset && s.read_t == s.offset && bank_.columns.time == "header.stamp";
      throw reader.error_at_row(what + (unset_stamps ? " (the topic's header.stamp is unset, 0, in its messages: "
                                                       "columns.time: log_time reads when the bag recorded each)"
                                                     : std::string(kOutOfOrderHint)));
    }
    s.read_t = t;
    s.row_t = t;
    s.has_row = true;
    if (s.rows_read++ == 0) s.first_t = t;
    return true;
  }
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
      if (!std::isnan(m.pending)) {
        ++stats_.superseded[i];
        ++m.superseded_in_step;
      }
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
      if (std::isfinite(value)) {
        term.accumulator.add(value);
      } else {
        ++term.left_out;
        ++stats_.left_out_of_aggregates[i];
      }
    }
  }
  if (truth_stream_ == k) {
    const std::string_view label = trim(s.files[static_cast<std::size_t>(truth_file_)]->text(truth_index_));
    // A blank cell is unlabelled, unless the bank says its logs write a label only when it changes.
    if (!label.empty() || !bank_.columns.carry_truth) held_truth_.assign(label);
  }
  // A stretch of this file without rows while the log went on: its held
  // values stood in for it there, which the summary says when that was long.
  // A gap of the whole log skipped since its last row (skip_gaps) is not.
  if (std::isfinite(s.last_t) && last_row_t_ > s.last_t && s.gaps_skipped_before == stats_.gaps_skipped &&
      s.row_t - s.last_t > s.longest_hole) {
    s.longest_hole = s.row_t - s.last_t;
    s.hole_from = s.last_t;
    s.hole_to = s.row_t;
  }
  s.gaps_skipped_before = stats_.gaps_skipped;
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
      term.left_out = 0;
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
      bool rows_left_out = false;
      for (std::size_t a = 0; a < m.aggregates.size(); ++a) {
        m.outer_scratch[a] = m.aggregates[a].accumulator.value(m.aggregates[a].kind);
        complete = complete && !std::isnan(m.outer_scratch[a]);
        rows_left_out = rows_left_out || m.aggregates[a].left_out > 0;
        m.aggregates[a].accumulator.reset();
        m.aggregates[a].left_out = 0;
      }
      // A step without rows of the measurement's file is not counted: a
      // slower sensor, or a gap, says nothing of its cells.
      if (!complete && rows_left_out) ++stats_.steps_without_enough_rows[i];
      value = complete ? m.outer->evaluate(m.outer_scratch.data()) : kNaN;
      if (complete && !std::isfinite(value)) {
        ++stats_.not_finite[i];
        value = kNaN;
      }
    }
    sample->z[static_cast<Eigen::Index>(i)] = value;
    if (!std::isnan(value)) {
      ++stats_.measured[i];
      unmeasured_run_[i] = 0;
    } else {
      if (unmeasured_run_[i]++ == 0) unmeasured_run_from_[i] = t;
      if (unmeasured_run_[i] > stats_.longest_unmeasured[i]) {
        stats_.longest_unmeasured[i] = unmeasured_run_[i];
        stats_.longest_unmeasured_from[i] = unmeasured_run_from_[i];
        stats_.longest_unmeasured_to[i] = t;
      }
    }
    m.pending = kNaN;
    m.superseded_in_step = 0;
  }
  for (Stream& s : streams_) s.delivered_t = s.last_t;
  rows_delivered_ = rows_applied_;
  delivered_step_t_ = t;
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
    int count = 0;
    for (const Column& c : columns_) {
      if (&streams_[static_cast<std::size_t>(c.stream)] != &s) continue;
      if (++count <= 4) used += (used.empty() ? "" : ", ") + Expression::excerpt(c.name);
    }
    if (count > 4) used += " and " + std::to_string(count - 4) + " more";
    const std::string never =
        used.empty() ? std::string() : ": its columns " + used + ", which the bank uses, would never have a value";
    const LogTable& table = *s.files.front();
    if (ros::BagReader::is_bag(table.path())) {
      // Messages that all lack the fields the bank reads (a name no message has) are not an empty topic.
      if (const long left_out = table.records_without_fields(); left_out > 0) {
        throw table.error("none of its " + std::to_string(left_out) + " message(s) has a field the bank reads from it" +
                          (used.empty() ? "" : " (" + used + ")") +
                          ": a sequence's entry selected by name, [NAME], has a value only in messages that have "
                          "that name: `skidimm bag FILE` lists the names the bag has");
      }
      // Each topic the bank names that has no message is said (the first found here; it has no header line).
      throw table.error("the topic has no message" + never +
                        ". A recording stopped before its first message, or the topic's publisher never ran: "
                        "`skidimm bag FILE` lists each topic's message count");
    }
    throw LogError(table.path().string(), 1,
                   "the file has a header but no data rows" + never + ". Leave it out of the log if that is meant");
  }
}

// Every file of the log has a row the steps used: a file whose rows all lie
// before the first step or after the last (an offset that misses, a file of
// another run) is an error, not a log silently run without it.
void LogReader::Impl::check_every_file_was_used() const {
  if (!started_) return;
  for (const Stream& s : streams_) {
    // Rows gathered for a last step past the end of the inputs were not used either.
    const bool applied = s.delivered_t > -std::numeric_limits<double>::infinity();
    if (s.rows_read == 0 || s.delivered_t >= first_step_t_ || (applied && s.holds_values)) continue;
    const LogTable& reader = *s.files[static_cast<std::size_t>(s.time_file)];
    const std::string offset =
        s.offset != 0.0 ? " (with its offset of " + CsvWriter::format(s.offset) + " s)" : std::string();
    const std::string end =
        stats_.dropped_last_step > 0
            ? ": the grid's next step, t = " + CsvWriter::format(stats_.step_not_taken_t) +
                  " s, is past the last row of the inputs (t = " + CsvWriter::format(stats_.inputs_end_t) + " s)"
            : ", where a file that feeds an input ends";
    const std::string where = s.first_t > delivered_step_t_
                                  ? "its rows start at t = " + CsvWriter::format(s.first_t) + " s" + offset +
                                        ", after the log's last step at t = " + CsvWriter::format(delivered_step_t_) +
                                        " s" + end
                                  : "its rows end at t = " + CsvWriter::format(s.last_t) + " s" + offset +
                                        ", before the log's first step at t = " + CsvWriter::format(first_step_t_) +
                                        " s, the first time every input has a value";
    const std::string unused = "none of its " + std::to_string(s.rows_read) + " row(s) was used: " + where + ". ";
    // A topic of a bag: an offset moves the whole bag, and a topic whose
    // stamps are on another clock than the others' (a driver stamping from
    // its own start, another in Unix time) is what misses most often.
    if (ros::BagReader::is_bag(reader.path())) {
      throw reader.error(unused +
                         "Do the bag's topics stamp by different clocks (header.stamp)? columns.time: log_time reads "
                         "every topic by the recorder's clock; `skidimm bag FILE` shows each topic's time");
    }
    throw LogError(reader.path().string(), 0,
                   unused + "Is the time offset (FILE@OFFSET) right, and are the files of the same run?");
  }
}

void LogReader::Impl::throw_if_an_input_never_had_a_value() const {
  long rows = 0;
  for (const long r : stats_.rows) rows += r;
  if (rows == 0) return;
  // Each column without a value once, with the inputs that read it.
  std::vector<std::pair<int, std::vector<std::string>>> missing;
  for (std::size_t i = 0; i < inputs_.size(); ++i) {
    for (const int c : inputs_[i].columns) {
      if (!std::isnan(held_values_[static_cast<std::size_t>(c)])) continue;
      auto it = std::find_if(missing.begin(), missing.end(), [c](const auto& m) { return m.first == c; });
      if (it == missing.end()) it = missing.insert(missing.end(), {c, {}});
      const std::string& name = bank_.input_names[i];
      if (std::find(it->second.begin(), it->second.end(), name) == it->second.end()) it->second.push_back(name);
    }
  }
  if (missing.empty()) return;
  std::string text, file;
  bool by_name = false;
  for (const auto& [c, inputs] : missing) {
    const Column& column = columns_[static_cast<std::size_t>(c)];
    std::string names;
    for (const std::string& name : inputs) names += (names.empty() ? "" : ", ") + name;
    text += std::string(text.empty() ? "" : "; ") + "column '" + Expression::excerpt(column.name) + "' (input" +
            (inputs.size() > 1 ? "s " : " ") + names + ")";
    if (file.empty()) {
      file = streams_[static_cast<std::size_t>(column.stream)]
                 .files[static_cast<std::size_t>(column.file)]
                 ->path()
                 .string();
    }
    by_name = by_name || selects_by_name(column.name);
  }
  throw LogError(file, 0,
                 "no step: " + text + (missing.size() == 1 ? " had" : " each had") + " no value in any of the log's " +
                     std::to_string(rows) + " row(s), and a step needs every input" +
                     (by_name ? std::string(kSelectedByNameHint) : std::string()));
}

bool LogReader::Impl::next(LogSample* sample) {
  throw_pending_error();
  // Until every input has a value: apply rows one time stamp at a time.
  while (!started_) {
    const double t = next_row_time();
    check_no_file_is_empty();
    // No step can come before the first, so nothing is lost by saying it at
    // once: a live log's other sensors would otherwise be read on and on
    // while the inputs never become known.
    throw_pending_error();
    if (!std::isfinite(t)) {
      throw_pending_error();
      throw_if_an_input_never_had_a_value();
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
      // A file that failed may have had rows for this step: none is given
      // that could lack them.
      throw_pending_error();
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
      if (step_t - last_row_t_ > sampling_.max_gap) pass_gap(step_t);
      for (std::size_t k = 0; k < streams_.size(); ++k) {
        if (streams_[k].has_row && streams_[k].row_t == step_t) apply_row(static_cast<int>(k));
      }
    }
  }
  if (past_end(step_t)) {
    throw_pending_error();
    if (sampling_.rate > 0.0) drop_last_step(step_t);
    // Count what is left unread so the summary can say so.
    read_pending_rows();
    for (Stream& s : streams_) {
      while (s.has_row) {
        ++stats_.dropped_after_end;
        read_row(s);
      }
    }
    // Rows after the end are not used, but a time that goes back among them
    // is a broken log all the same (it hid the rows a wrong stamp cut off).
    throw_pending_error();
    check_every_file_was_used();
    return false;
  }
  // A file that failed (a time that went back, an unreadable row) stopped
  // before the rows this step gathers from it were all read: the step would
  // stand on part of them, so it is not given, and the error is.
  throw_pending_error();
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
    pass_gap(next_row);
    // Restart the grid at the row after the gap: no step inside it.
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

// A stretch without rows from the last row applied to `next_row`, longer
// than sampling.max_gap: an error naming the row after it (a wrong time
// stamp, 1e9 for 1.0, would otherwise be stepped through by the grid, or
// crossed in one step whose row then stands for the whole gap in every
// time-weighted score), or, with sampling.skip_gaps, counted.
void LogReader::Impl::pass_gap(double next_row) {
  constexpr double kGapOfAnotherUnit = 86400.0;  // s
  const double gap = next_row - last_row_t_;
  if (!sampling_.skip_gaps) {
    const Stream* s = stream_at(next_row);
    const LogTable& reader = *s->files[static_cast<std::size_t>(s->time_file)];
    const std::string crossing =
        sampling_.rate > 0.0 ? "at " + CsvWriter::format(sampling_.rate) + " Hz the filter's grid would step " +
                                   CsvWriter::format(std::floor(gap * sampling_.rate)) + " times through it"
                             : "the filter would cross it in one step, and the row before it would stand for the whole "
                               "gap in every time-weighted score";
    throw reader.error_at_row(
        "column '" + bank_.columns.time + "': the log has no row from t = " + time_text(last_row_t_) + " to " +
        time_text(next_row) + " s, a gap of " + time_text(gap) + " s, longer than sampling.max_gap (" +
        CsvWriter::format(sampling_.max_gap) + " s): " + crossing + ". " +
        // Longer than a day, or already between the log's first rows: more
        // likely a unit than a pause.
        (gap > kGapOfAnotherUnit || rows_applied_ < 3
             ? (bank_.columns.time_units_per_second == 1.0
                    ? std::string("Are the time stamps in seconds? (columns.time_unit: ms, us or ns reads them in "
                                  "another unit) ")
                    : "Are the time stamps in " + bank_.columns.time_unit_name + " (columns.time_unit)? ")
             : std::string()) +
        "If a time stamp is wrong, fix it; if the recording paused, set sampling.skip_gaps: true in the bank to " +
        (sampling_.rate > 0.0 ? "restart the grid after" : "step across") + " such gaps, or raise sampling.max_gap");
  }
  ++stats_.gaps_skipped;
  stats_.seconds_skipped += gap;
}

// The grid's step at `step_t` lies after the last row of the inputs: the
// rows gathered for it since the last step are not used. Counted, and the
// values they replaced are no longer counted as replaced.
void LogReader::Impl::drop_last_step(double step_t) {
  stats_.dropped_last_step = rows_applied_ - rows_delivered_;
  if (stats_.dropped_last_step == 0) return;
  stats_.last_step_t = delivered_step_t_;
  stats_.step_not_taken_t = step_t;
  stats_.inputs_end_t = std::numeric_limits<double>::infinity();
  for (const Stream& s : streams_) {
    if (s.feeds_inputs && s.ended) stats_.inputs_end_t = std::min(stats_.inputs_end_t, s.last_t);
  }
  for (std::size_t i = 0; i < measurements_.size(); ++i) {
    stats_.superseded[i] -= measurements_[i].superseded_in_step;
    measurements_[i].superseded_in_step = 0;
  }
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
LogReader::LogReader(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
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

namespace {

// The measurements a log never gave a value, one line each.
std::vector<std::string> never_measured(const LogStats& s, const BankConfig& bank) {
  std::vector<std::string> out;
  for (std::size_t i = 0; i < s.measured.size(); ++i) {
    if (s.steps == 0 || s.measured[i] > 0) continue;
    const std::string& text = bank.columns.measurements[i];
    // Which of its columns lacked values is not known here: the hint says "if".
    out.push_back("measurement '" + bank.measurement.names[i] + "' (\"" + Expression::excerpt(text) +
                  "\") had no value at any step" +
                  (selects_by_name(text) ? std::string(kMaybeSelectedByNameHint) : std::string()));
  }
  return out;
}

// The measurements a log gave values but left without one for a stretch of
// steps far longer than they usually go without (a sensor that stopped, or
// paused, while the others went on), with the longest such stretch; those of
// one stretch (the columns of one sensor's file) on one line. "Far longer":
// at least 5 steps and 5 times the mean number of steps per value, so a
// sensor slower than the filter (a GPS fix every fifth step) is not named
// for its own rate.
// With `consequence`, each line says what that did to the filters.
std::vector<std::string> partly_measured(const LogStats& s, const BankConfig& bank, double last_step_t,
                                         bool consequence = false) {
  constexpr long kFewestSteps = 5;
  constexpr double kTimesItsSpacing = 5.0;
  std::vector<std::size_t> named;
  for (std::size_t i = 0; i < s.measured.size() && i < s.longest_unmeasured.size(); ++i) {
    if (s.measured[i] == 0) continue;
    const long longest = s.longest_unmeasured[i];
    const double steps_per_value = static_cast<double>(s.steps) / static_cast<double>(s.measured[i]);
    if (longest >= kFewestSteps && static_cast<double>(longest) >= kTimesItsSpacing * steps_per_value) {
      named.push_back(i);
    }
  }
  std::vector<std::string> out;
  std::vector<bool> said(named.size(), false);
  for (std::size_t a = 0; a < named.size(); ++a) {
    if (said[a]) continue;
    const std::size_t i = named[a];
    std::vector<std::size_t> group;
    for (std::size_t b = a; b < named.size(); ++b) {
      const std::size_t j = named[b];
      if (s.longest_unmeasured[j] == s.longest_unmeasured[i] &&
          s.longest_unmeasured_from[j] == s.longest_unmeasured_from[i] &&
          s.longest_unmeasured_to[j] == s.longest_unmeasured_to[i]) {
        group.push_back(j);
        said[b] = true;
      }
    }
    std::string names;
    long fewest = s.steps, most = 0;
    for (std::size_t g = 0; g < group.size(); ++g) {
      const std::size_t j = group[g];
      names += std::string(g == 0                  ? ""
                           : g + 1 == group.size() ? " and "
                                                   : ", ") +
               "'" + bank.measurement.names[j] + "' (\"" + Expression::excerpt(bank.columns.measurements[j]) + "\")";
      fewest = std::min(fewest, s.steps - s.measured[j]);
      most = std::max(most, s.steps - s.measured[j]);
    }
    const double from = s.longest_unmeasured_from[i], to = s.longest_unmeasured_to[i];
    out.push_back(std::string(group.size() > 1 ? "measurements " : "measurement ") + names +
                  " had no value from t = " + CsvWriter::format(from) + " to " + CsvWriter::format(to) + " s (" +
                  std::to_string(s.longest_unmeasured[i]) + " steps in a row" +
                  (to == last_step_t ? ", to the log's last step" : "") + "; " +
                  (fewest == most ? std::to_string(most) : std::to_string(fewest) + " to " + std::to_string(most)) +
                  " of " + std::to_string(s.steps) + " steps without " + (group.size() > 1 ? "a value" : "one") +
                  " in all)" +
                  (!consequence       ? ""
                   : group.size() > 1 ? ": the filters were not corrected by them there"
                                      : ": its filters were not corrected by it there"));
  }
  return out;
}

}  // namespace

std::vector<std::string> LogReader::unmeasured(const BankConfig& bank) const {
  std::vector<std::string> out = never_measured(impl_->stats_, bank);
  for (std::string& line : partly_measured(impl_->stats_, bank, impl_->delivered_step_t_)) out.push_back(line);
  return out;
}

std::vector<std::string> LogReader::skipped_by_options() const {
  const LogStats& s = impl_->stats_;
  std::vector<std::string> lines;
  if (s.gaps_skipped > 0) {
    const bool grid = impl_->sampling_.rate > 0.0;
    lines.push_back(std::to_string(s.gaps_skipped) + " gap(s) without rows longer than sampling.max_gap (" +
                    CsvWriter::format(impl_->sampling_.max_gap) + " s) were " + (grid ? "skipped, " : "crossed, ") +
                    CsvWriter::format(s.seconds_skipped) + " s in all: " +
                    (grid ? "the grid restarted at the row after each" : "the filter crossed each in one step") +
                    " (sampling.skip_gaps)");
  }
  if (s.out_of_order_skipped > 0) {
    lines.push_back(std::to_string(s.out_of_order_skipped) +
                    " row(s) whose time was not after their file's last row were left out "
                    "(sampling.skip_out_of_order), the first at " +
                    s.first_out_of_order);
  }
  return lines;
}

std::string LogReader::describe_stats(const BankConfig& bank) const {
  const LogStats& s = impl_->stats_;
  std::string out;
  if (s.dropped_before_start > 0) {
    out += "  " + std::to_string(s.dropped_before_start) +
           " measurement value(s) came before every input had a value and were not used\n";
  }
  if (s.dropped_last_step > 0) {
    out += "  " + std::to_string(s.dropped_last_step) +
           " row(s) after the last step (t = " + CsvWriter::format(s.last_step_t) +
           " s) were not used: the grid's next step, t = " + CsvWriter::format(s.step_not_taken_t) +
           " s, is past the last row of the inputs (t = " + CsvWriter::format(s.inputs_end_t) + " s)\n";
  }
  if (s.dropped_after_end > 0) {
    out += "  " + std::to_string(s.dropped_after_end) +
           " row(s) after the last row of a file that feeds an input were not used\n";
  }
  for (const std::string& line : skipped_by_options()) out += "  " + line + "\n";
  for (const auto& stream : impl_->streams_) {
    if (!stream.feeds_inputs || !(stream.longest_hole > impl_->sampling_.max_gap)) continue;
    out += "  " + s.files[stream.stat_index[static_cast<std::size_t>(stream.time_file)]] +
           " had no row from t = " + CsvWriter::format(stream.hole_from) + " to " + CsvWriter::format(stream.hole_to) +
           " s (" + CsvWriter::format(stream.hole_to - stream.hole_from) +
           " s, longer than sampling.max_gap) while the log's other rows went on: the inputs it gives were held "
           "at their last values there\n";
  }
  for (const std::string& line : never_measured(s, bank))
    out += "  " + line + ": its filters were never corrected by it\n";
  for (const std::string& line : partly_measured(s, bank, impl_->delivered_step_t_, true)) out += "  " + line + "\n";
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
    if (i < s.left_out_of_aggregates.size() && s.left_out_of_aggregates[i] > 0) {
      out += "  measurement '" + bank.measurement.names[i] + "' (\"" +
             Expression::excerpt(bank.columns.measurements[i]) + "\"): " + std::to_string(s.left_out_of_aggregates[i]) +
             " row value(s) were left out of its aggregates (an empty or nan cell, or not finite inside mean/std/rms)";
      if (s.steps_without_enough_rows[i] > 0) {
        out += "; " + std::to_string(s.steps_without_enough_rows[i]) +
               " step(s) were left with too few rows and count as missing";
      }
      out += "\n";
    }
  }
  return out;
}

}  // namespace skidimm
