#include "bag_log.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <exception>
#include <limits>

#include "bundled_message_definitions.h"
#include "not_a_number.h"
#include "ros_time.h"
#include "skidimm/errors.h"
#include "skidimm/io/csv.h"

namespace skidimm {
namespace ros {

namespace fs = std::filesystem;

namespace {

using ::skidimm::internal::kNaN;

std::string topic_list(const BagReader& bag) {
  std::string out;
  for (const BagTopic& t : bag.topics()) {
    out += (out.empty() ? "" : ", ") + t.name + (t.type.empty() ? "" : " (" + t.type + ")");
  }
  // No channel at all is the file's problem, not the bank's: a recording cut
  // short before its first chunk ended, or one that recorded nothing.
  return out.empty() ? "none: no channel was read from the file (a recording cut short inside its first chunk, or an "
                       "empty one; `skidimm bag " +
                           bag.path().string() + "` says where it ends)"
                     : out;
}

// Whether `rest` (what follows a topic in a column name) is a field path:
// ".name" and "[...]" segments only. Anything else (an expression that
// starts with a topic path) is not a column of the topic.
bool is_field_path(const std::string& rest) {
  std::size_t i = 0;
  if (rest.empty()) return false;
  while (i < rest.size()) {
    if (rest[i] == '.') {
      std::size_t end = i + 1;
      while (end < rest.size() && (std::isalnum(static_cast<unsigned char>(rest[end])) || rest[end] == '_')) ++end;
      if (end == i + 1) return false;
      i = end;
    } else if (rest[i] == '[') {
      const auto close = rest.find(']', i);
      if (close == std::string::npos) return false;
      i = close + 1;
    } else {
      return false;
    }
  }
  return true;
}

bool is_topic_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '/'; }

std::string seconds_text(std::uint64_t ns) {
  std::string frac = std::to_string(ns % 1000000000);
  return std::to_string(ns / 1000000000) + "." + std::string(9 - frac.size(), '0') + frac;
}

class BagTopicTable;

// The bag read once, front to back, for all of its tables.
struct BagCursor {
  std::unique_ptr<BagReader> bag;
  std::vector<BagTopicTable*> tables;  // per topic of the bag; null: not used
  std::exception_ptr error;            // the bag itself could not be read further
  bool ended = false;
  std::uintmax_t size = 0;

  // Reads messages until `table` has a row, the bag ends or fails.
  void fill(BagTopicTable* table);
};

class BagTopicTable : public LogTable {
 public:
  BagTopicTable(std::shared_ptr<BagCursor> cursor, int topic, std::unique_ptr<CdrFieldReader> reader)
      : cursor_(std::move(cursor)), topic_(topic), reader_(std::move(reader)) {}

  const fs::path& path() const override { return cursor_->bag->path(); }
  std::string name() const override { return path().filename().string() + ":" + topic_name(); }
  const std::string& topic_name() const { return cursor_->bag->topics()[static_cast<std::size_t>(topic_)].name; }

  std::vector<std::string> columns_present() const override {
    std::vector<std::string> out = {kHeaderStampColumn, kLogTimeColumn};
    for (const std::string& p : reader_->usable_paths()) out.push_back(topic_name() + "." + p);
    return out;
  }

  int column(const std::string& name) override {
    for (std::size_t i = 0; i < columns_.size(); ++i) {
      if (columns_[i].name == name) return static_cast<int>(i);
    }
    Column c;
    c.name = name;
    const std::string& topic = topic_name();
    if (name == kLogTimeColumn || (name == kHeaderStampColumn && !reader_->has_header_stamp())) {
      c.log_time = true;
    } else if (name == kHeaderStampColumn) {
      c.slot = reader_->add("header.stamp");
    } else if (name.size() > topic.size() && name.compare(0, topic.size(), topic) == 0 &&
               is_field_path(name.substr(topic.size()))) {
      const std::string path = name.substr(topic.size() + (name[topic.size()] == '.' ? 1 : 0));
      try {
        c.slot = reader_->add(path);
      } catch (const FieldPathError& e) {
        std::string usable;
        std::size_t listed = 0;
        for (const std::string& p : e.usable()) {
          if (++listed > 60) {
            usable += ", ...";
            break;
          }
          usable += (usable.empty() ? "" : ", ") + topic + "." + p;
        }
        throw error("no column '" + name + "': " + e.what() + ". Its columns: " + usable);
      }
      c.text = reader_->is_text(c.slot);
    } else {
      return -1;
    }
    columns_.push_back(c);
    return static_cast<int>(columns_.size()) - 1;
  }

  bool next_row() override {
    if (queue_rows_ == 0) {
      if (!error_ && !stopped_) cursor_->fill(this);
      if (queue_rows_ == 0) {
        if (error_) std::rethrow_exception(error_);
        if (cursor_->error) std::rethrow_exception(cursor_->error);
        return false;
      }
    }
    row_.resize(columns_.size());
    for (std::size_t i = 0; i < columns_.size(); ++i) {
      row_[i] = values_.front();
      values_.pop_front();
    }
    texts_row_.clear();
    for (std::size_t i = 0; i < text_columns_; ++i) {
      texts_row_.push_back(std::move(texts_.front()));
      texts_.pop_front();
    }
    row_log_time_ = log_times_.front();
    log_times_.pop_front();
    row_message_ = message_numbers_.front();
    message_numbers_.pop_front();
    --queue_rows_;
    return true;
  }

  Cell number(int column, double* value) const override {
    const Column& c = columns_[static_cast<std::size_t>(column)];
    if (c.text) {
      *value = kNaN;
      return Cell::kNotANumber;
    }
    *value = row_[static_cast<std::size_t>(column)];
    return std::isnan(*value) ? Cell::kMissing : Cell::kNumber;
  }

  std::string_view text(int column) const override {
    const Column& c = columns_[static_cast<std::size_t>(column)];
    if (c.text) return texts_row_[static_cast<std::size_t>(c.text_index)];
    // A number used as a label: its shortest text.
    const double v = row_[static_cast<std::size_t>(column)];
    number_text_.clear();
    if (!std::isnan(v)) {
      char buffer[32];
      number_text_.assign(buffer, static_cast<std::size_t>(CsvWriter::format(v, buffer, buffer + sizeof(buffer)) - buffer));
    }
    return number_text_;
  }

  LogError cell_error(int column, const std::string& expected) const override {
    const Column& c = columns_[static_cast<std::size_t>(column)];
    std::string got = c.text ? "the text '" + texts_row_[static_cast<std::size_t>(c.text_index)].substr(0, 80) + "'"
                             : "the number " + std::to_string(row_[static_cast<std::size_t>(column)]);
    return error_at_row("'" + c.name + "': expected " + expected + ", got " + got);
  }

  LogError error_at_row(const std::string& message) const override {
    return LogError(path().string(), 0,
                    "topic " + topic_name() + ", message " + std::to_string(row_message_) + " (log time " +
                        seconds_text(row_log_time_) + " s): " + message);
  }
  LogError error(const std::string& message) const override {
    return LogError(path().string(), 0, "topic " + topic_name() + ": " + message);
  }

  std::uintmax_t bytes_read() const override {
    return static_cast<std::uintmax_t>(cursor_->bag->progress() * static_cast<double>(size()));
  }
  std::uintmax_t size() const override {
    std::size_t used = 0;
    for (const BagTopicTable* t : cursor_->tables) used += t != nullptr ? 1 : 0;
    return used == 0 ? 0 : cursor_->size / used;
  }

  // A message of this topic, decoded into the queue. A message that does
  // not decode ends the topic: its error is thrown after the rows before it.
  void enqueue(const BagMessage& message) {
    if (error_ || stopped_) return;
    if (!finalized_) finalize();
    ++messages_;
    try {
      reader_->decode(message.data, message.size);
    } catch (const CdrError& e) {
      error_ = std::make_exception_ptr(LogError(path().string(), 0,
                                                "topic " + topic_name() + ", message " + std::to_string(messages_) +
                                                    " (log time " + seconds_text(message.log_time) + " s, " +
                                                    reader_->type_name() + "): cannot decode its CDR: " + e.what()));
      return;
    }
    // A message with none of the fields the bank reads from this topic (a
    // JointState of another publisher's joints, on a topic several
    // publishers share, each stamping on its own clock) is not a row of it:
    // as an empty row it would interleave its stamps with the wheels'.
    bool gives_a_field = false, reads_a_field = false;
    for (const Column& c : columns_) {
      if (c.log_time || c.name == kHeaderStampColumn) continue;
      reads_a_field = true;
      gives_a_field = gives_a_field || reader_->found(c.slot);
    }
    if (reads_a_field && !gives_a_field) {
      ++messages_without_fields_;
      return;
    }
    for (const Column& c : columns_) {
      if (c.log_time) {
        values_.push_back(seconds_from_nanoseconds(static_cast<std::int64_t>(message.log_time)));
      } else if (c.text) {
        values_.push_back(kNaN);
        texts_.emplace_back(reader_->text(c.slot));
      } else {
        values_.push_back(reader_->value(c.slot));
      }
    }
    log_times_.push_back(message.log_time);
    message_numbers_.push_back(messages_);
    ++queue_rows_;
  }
  std::size_t queued() const { return queue_rows_; }
  bool failed() const { return static_cast<bool>(error_); }
  long records_without_fields() const override { return messages_without_fields_; }

 private:
  struct Column {
    std::string name;
    bool log_time = false;
    bool text = false;
    int slot = -1;
    int text_index = -1;
  };

  void finalize() {
    finalized_ = true;
    for (Column& c : columns_) {
      if (c.text) c.text_index = static_cast<int>(text_columns_++);
    }
  }

  std::shared_ptr<BagCursor> cursor_;
  int topic_;
  std::unique_ptr<CdrFieldReader> reader_;
  std::vector<Column> columns_;
  bool finalized_ = false;
  std::size_t text_columns_ = 0;
  // Decoded rows not yet read: columns_.size() values each (texts apart).
  std::deque<double> values_;
  std::deque<std::string> texts_;
  std::deque<std::uint64_t> log_times_;
  std::size_t queue_rows_ = 0;
  std::exception_ptr error_;
  bool stopped_ = false;
  // The current row.
  std::vector<double> row_;
  std::vector<std::string> texts_row_;
  mutable std::string number_text_;
  std::uint64_t row_log_time_ = 0;
  long row_message_ = 0;              // the current row's message of the topic (1-based)
  long messages_ = 0;                 // messages of the topic decoded so far, rows or not
  std::deque<long> message_numbers_;  // each queued row's
  long messages_without_fields_ = 0;
};

void BagCursor::fill(BagTopicTable* table) {
  if (ended || error) return;
  BagMessage message;
  try {
    while (table->queued() == 0) {
      if (!bag->next(&message)) {
        ended = true;
        return;
      }
      BagTopicTable* owner = tables[static_cast<std::size_t>(message.topic)];
      if (owner != nullptr) owner->enqueue(message);
      if (owner == table && table->failed()) return;  // its message did not decode: the error is its
    }
  } catch (const Error&) {
    error = std::current_exception();
  }
}

}  // namespace

std::unique_ptr<CdrFieldReader> make_topic_reader(const BagReader& bag, int topic) {
  const BagTopic& t = bag.topics()[static_cast<std::size_t>(topic)];
  const std::string where = "topic " + t.name + " (" + (t.type.empty() ? "no type" : t.type) + ")";
  if (t.serialization_format != "cdr") {
    throw LogError(bag.path().string(), 0,
                   where + ": messages encoded as '" + t.serialization_format +
                       "'; skidimm reads ROS 2 messages in CDR (serialization format 'cdr')");
  }
  MessageDefinitions definitions;
  try {
    if (!t.definition.empty() && t.definition_encoding == "ros2msg") {
      definitions.add(t.type, t.definition);
      definitions.check_complete(t.type);
      return std::make_unique<CdrFieldReader>(definitions, t.type);
    }
    if (is_bundled_message_type(t.type)) {
      add_bundled_definitions(&definitions);
      return std::make_unique<CdrFieldReader>(definitions, t.type);
    }
  } catch (const DefinitionError& e) {
    throw LogError(bag.path().string(), 0, where + ": its message definition: " + e.what());
  }
  std::string stored = t.definition.empty() ? "the bag stores no definition of it"
                                            : "the bag stores its definition as '" + t.definition_encoding +
                                                  "', which skidimm does not read (it reads ros2msg)";
  std::string bundled;
  for (const std::string& b : bundled_message_types()) bundled += (bundled.empty() ? "" : ", ") + b;
  throw LogError(bag.path().string(), 0,
                 where + ": " + stored + ", and it is not one of the bundled types (" + bundled + ")");
}

namespace {

std::vector<int> find_topics(const BagReader& bag, const std::vector<std::string>& column_texts, bool required) {
  std::vector<int> out;
  for (const std::string& text : column_texts) {
    for (std::size_t i = 0; i < text.size(); ++i) {
      if (text[i] != '/') continue;
      // A topic starts an operand: at the start, or after an operator, '(' ',' or a blank.
      if (i > 0) {
        const char before = text[i - 1];
        if (std::isalnum(static_cast<unsigned char>(before)) || before == '_' || before == ')' || before == ']' ||
            before == '.' || before == '/') {
          continue;
        }
      }
      std::size_t end = i + 1;
      while (end < text.size() && is_topic_char(text[end])) ++end;
      if (end >= text.size() || (text[end] != '.' && text[end] != '[')) continue;
      if (end == i + 1 || !std::isalpha(static_cast<unsigned char>(text[i + 1]))) continue;
      const std::string topic = text.substr(i, end - i);
      const int index = bag.topic_index(topic);
      if (index < 0 && !required) continue;
      if (index < 0) {
        throw LogError(bag.path().string(), 0,
                       "the bank's column \"" + text + "\" names topic " + topic +
                           ", which this bag does not have; its topics: " + topic_list(bag));
      }
      if (std::find(out.begin(), out.end(), index) == out.end()) out.push_back(index);
      i = end;
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace

std::vector<int> topics_named(const BagReader& bag, const std::vector<std::string>& column_texts) {
  return find_topics(bag, column_texts, true);
}

std::vector<int> topics_named_if_present(const BagReader& bag, const std::vector<std::string>& texts) {
  return find_topics(bag, texts, false);
}

std::vector<std::unique_ptr<LogTable>> open_bag_tables(const fs::path& path,
                                                       const std::vector<std::string>& column_texts,
                                                       const std::vector<std::string>& optional_texts) {
  auto cursor = std::make_shared<BagCursor>();
  cursor->bag = BagReader::open(path);
  std::error_code ec;
  for (const fs::path& f : cursor->bag->files()) {
    const auto n = fs::file_size(f, ec);
    if (!ec) cursor->size += n;
  }
  std::vector<int> used = topics_named(*cursor->bag, column_texts);
  for (int topic : topics_named_if_present(*cursor->bag, optional_texts)) {
    if (std::find(used.begin(), used.end(), topic) == used.end()) used.push_back(topic);
  }
  std::sort(used.begin(), used.end());
  if (used.empty()) {
    throw LogError(path.string(), 0,
                   "no column of the bank names a topic of this bag. A bag's columns are written "
                   "\"/topic.field\" (\"/imu/data.angular_velocity.z\", \"/joint_states.velocity[left]\"), "
                   "with columns.time: header.stamp or log_time. Its topics: " +
                       topic_list(*cursor->bag) + " (`skidimm bag " + path.string() + "` lists their fields)");
  }
  cursor->tables.assign(cursor->bag->topics().size(), nullptr);
  std::vector<std::unique_ptr<LogTable>> tables;
  for (int topic : used) {
    auto table = std::make_unique<BagTopicTable>(cursor, topic, make_topic_reader(*cursor->bag, topic));
    cursor->tables[static_cast<std::size_t>(topic)] = table.get();
    tables.push_back(std::move(table));
  }
  return tables;
}

}  // namespace ros
}  // namespace skidimm
