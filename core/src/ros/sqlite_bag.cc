// A bag stored in SQLite 3 (.db3), rosbag2's storage before Iron: the
// tables topics(id, name, type, serialization_format, ...), messages(id,
// topic_id, timestamp, data) and, from Iron on, message_definitions(topic_type,
// encoding, encoded_message_definition, ...). Messages compressed one by one
// (metadata.yaml's compression_mode: message) are zstd frames.
#include <sqlite3.h>
#include <zstd.h>

#include <algorithm>
#include <map>

#include "bag_storage.h"
#include "compression.h"
#include "skidimm/errors.h"

namespace skidimm {
namespace ros {

namespace {

class Statement {
 public:
  Statement(sqlite3* db, const std::string& sql, const std::filesystem::path& file) : file_(file) {
    if (sqlite3_prepare_v2(db, sql.c_str(), -1, &statement_, nullptr) != SQLITE_OK) {
      const std::string message = sqlite3_errmsg(db);
      sqlite3_finalize(statement_);
      throw LogError(file.string(), 0, "not a rosbag2 SQLite bag: " + message + " (in: " + sql + ")");
    }
  }
  ~Statement() { sqlite3_finalize(statement_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  bool step() {
    const int rc = sqlite3_step(statement_);
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    throw LogError(file_.string(), 0, std::string("cannot read: ") + sqlite3_errmsg(sqlite3_db_handle(statement_)));
  }
  void reset() { sqlite3_reset(statement_); }
  std::string text(int column) const {
    const unsigned char* t = sqlite3_column_text(statement_, column);
    return t == nullptr ? std::string() : std::string(reinterpret_cast<const char*>(t));
  }
  std::int64_t integer(int column) const { return sqlite3_column_int64(statement_, column); }
  const std::uint8_t* blob(int column, std::size_t* size) const {
    const void* data = sqlite3_column_blob(statement_, column);
    *size = static_cast<std::size_t>(sqlite3_column_bytes(statement_, column));
    return static_cast<const std::uint8_t*>(data);
  }

 private:
  sqlite3_stmt* statement_ = nullptr;
  std::filesystem::path file_;
};

struct Database {
  sqlite3* db = nullptr;
  std::filesystem::path file;
  std::map<std::int64_t, int> topic_of_id;  // topics.id -> topic index
  std::unique_ptr<Statement> messages;
  ~Database() { sqlite3_close(db); }
};

class SqliteBag : public BagReader {
 public:
  SqliteBag(const std::filesystem::path& path, const BagMetadata& metadata) {
    path_ = path;
    files_ = metadata.files;
    compressed_messages_ = metadata.compression_mode == "MESSAGE";
    if (compressed_messages_ && metadata.compression_format != "zstd") {
      throw LogError(metadata.file.string(), 0,
                     "messages compressed with '" + metadata.compression_format + "': skidimm reads zstd");
    }
    for (const auto& file : files_) open_file(file);
  }

  std::string storage() const override { return "sqlite3"; }
  std::string storage_details() const override {
    return std::string(compressed_messages_ ? "zstd compressed messages" : "uncompressed") +
           (has_definitions_ ? ", message definitions stored" : ", no message definitions (bundled ones used)");
  }

  bool next(BagMessage* message) override {
    while (current_ < databases_.size()) {
      Database& d = *databases_[current_];
      if (d.messages->step()) {
        const auto topic = d.topic_of_id.find(d.messages->integer(0));
        if (topic == d.topic_of_id.end()) {
          throw LogError(d.file.string(), 0,
                         "a message of topic id " + std::to_string(d.messages->integer(0)) + ", not in the topics table");
        }
        message->topic = topic->second;
        message->log_time = static_cast<std::uint64_t>(d.messages->integer(1));
        std::size_t size = 0;
        const std::uint8_t* data = d.messages->blob(2, &size);
        if (compressed_messages_) {
          const unsigned long long n = ZSTD_getFrameContentSize(data, size);
          if (n == ZSTD_CONTENTSIZE_ERROR || n == ZSTD_CONTENTSIZE_UNKNOWN || n > (std::uint64_t{1} << 30)) {
            throw LogError(d.file.string(), 0, "a message of " + topics_[static_cast<std::size_t>(topic->second)].name +
                                                   " at log time " + std::to_string(message->log_time) +
                                                   " ns is not a zstd frame of known size");
          }
          try {
            decompress("zstd", data, size, static_cast<std::size_t>(n), &buffer_);
          } catch (const CompressionError& e) {
            throw LogError(d.file.string(), 0, "a message of " + topics_[static_cast<std::size_t>(topic->second)].name +
                                                   " does not decompress: " + e.what());
          }
          data = buffer_.data();
          size = buffer_.size();
        }
        message->data = data;
        message->size = size;
        ++read_;
        return true;
      }
      ++current_;
    }
    return false;
  }

  void rewind() override {
    for (auto& d : databases_) d->messages->reset();
    current_ = 0;
    read_ = 0;
  }

  double progress() const override {
    return total_ == 0 ? 1.0 : std::min(1.0, static_cast<double>(read_) / static_cast<double>(total_));
  }

 private:
  void open_file(const std::filesystem::path& file) {
    auto d = std::make_unique<Database>();
    d->file = file;
    if (sqlite3_open_v2(file.c_str(), &d->db, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK) {
      throw LogError(file.string(), 0, std::string("cannot open as SQLite: ") + sqlite3_errmsg(d->db));
    }
    bool definitions_table = false;
    {
      Statement tables(d->db, "SELECT name FROM sqlite_master WHERE type = 'table'", file);
      bool topics = false, messages = false;
      while (tables.step()) {
        const std::string name = tables.text(0);
        topics = topics || name == "topics";
        messages = messages || name == "messages";
        definitions_table = definitions_table || name == "message_definitions";
      }
      if (!topics || !messages) {
        throw LogError(file.string(), 0, "not a rosbag2 SQLite bag: it has no topics and messages tables");
      }
    }
    std::map<std::string, std::pair<std::string, std::string>> definitions;  // type -> (encoding, text)
    if (definitions_table) {
      Statement s(d->db, "SELECT topic_type, encoding, encoded_message_definition FROM message_definitions", file);
      while (s.step()) {
        if (!s.text(2).empty()) definitions[s.text(0)] = {s.text(1), s.text(2)};
      }
      has_definitions_ = has_definitions_ || !definitions.empty();
    }
    Statement topics(d->db, "SELECT id, name, type, serialization_format FROM topics ORDER BY id", file);
    while (topics.step()) {
      const std::string name = topics.text(1);
      int index = topic_index(name);
      if (index < 0) {
        BagTopic t;
        t.name = name;
        t.type = topics.text(2);
        t.serialization_format = topics.text(3);
        const auto def = definitions.find(t.type);
        if (def != definitions.end()) {
          t.definition_encoding = def->second.first;
          t.definition = def->second.second;
        }
        topics_.push_back(std::move(t));
        index = static_cast<int>(topics_.size()) - 1;
      }
      d->topic_of_id[topics.integer(0)] = index;
    }
    Statement counts(d->db,
                     "SELECT topic_id, COUNT(*), MIN(timestamp), MAX(timestamp) FROM messages GROUP BY topic_id", file);
    while (counts.step()) {
      const auto topic = d->topic_of_id.find(counts.integer(0));
      if (topic == d->topic_of_id.end()) continue;
      BagTopic& t = topics_[static_cast<std::size_t>(topic->second)];
      const auto first = static_cast<std::uint64_t>(counts.integer(2));
      const auto last = static_cast<std::uint64_t>(counts.integer(3));
      if (t.message_count == 0 || first < t.first_log_time) t.first_log_time = first;
      if (t.message_count == 0 || last > t.last_log_time) t.last_log_time = last;
      t.message_count += static_cast<std::uint64_t>(counts.integer(1));
      total_ += static_cast<std::uint64_t>(counts.integer(1));
    }
    d->messages = std::make_unique<Statement>(
        d->db, "SELECT topic_id, timestamp, data FROM messages ORDER BY timestamp, id", file);
    databases_.push_back(std::move(d));
  }

  std::vector<std::unique_ptr<Database>> databases_;
  std::vector<std::uint8_t> buffer_;
  bool compressed_messages_ = false;
  bool has_definitions_ = false;
  std::size_t current_ = 0;
  std::uint64_t read_ = 0, total_ = 0;
};

}  // namespace

std::unique_ptr<BagReader> open_sqlite_bag(const std::filesystem::path& path, const BagMetadata& metadata) {
  return std::make_unique<SqliteBag>(path, metadata);
}

}  // namespace ros
}  // namespace skidimm
