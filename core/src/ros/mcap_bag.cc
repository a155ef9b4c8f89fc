// A bag stored as MCAP: one file, or the split files of a bag directory read
// one after the other. Topics are matched across files by name.
#include <algorithm>
#include <map>

#include "bag_storage.h"
#include "mcap_reader.h"
#include "skidimm/errors.h"

namespace skidimm {
namespace ros {

namespace {

class McapBag : public BagReader {
 public:
  McapBag(const std::filesystem::path& path, const std::vector<std::filesystem::path>& files) {
    path_ = path;
    files_ = files;
    for (const auto& file : files) {
      readers_.push_back(std::make_unique<McapReader>(file));
      const McapReader& reader = *readers_.back();
      std::map<std::uint16_t, int> channel_topics;
      for (const auto& [id, channel] : reader.channels()) {
        int index = topic_index(channel.topic);
        if (index < 0) {
          BagTopic topic;
          topic.name = channel.topic;
          topic.serialization_format = channel.message_encoding;
          const auto schema = reader.schemas().find(channel.schema_id);
          if (schema != reader.schemas().end()) {
            topic.type = schema->second.name;
            topic.definition = schema->second.data;
            topic.definition_encoding = schema->second.encoding;
          }
          topics_.push_back(std::move(topic));
          index = static_cast<int>(topics_.size()) - 1;
        }
        channel_topics[id] = index;
        BagTopic& topic = topics_[static_cast<std::size_t>(index)];
        const auto count = reader.statistics().channel_message_counts.find(id);
        if (count != reader.statistics().channel_message_counts.end()) topic.message_count += count->second;
      }
      channel_topics_.push_back(std::move(channel_topics));
    }
    // First and last log times per topic: the statistics give them per file only.
    // They are filled in by a caller that reads the messages (bag_info).
    for (const auto& reader : readers_) {
      for (const std::string& c : reader->compressions()) {
        if (std::find(compressions_.begin(), compressions_.end(), c) == compressions_.end()) compressions_.push_back(c);
      }
    }
  }

  std::string storage() const override { return "mcap"; }

  std::string storage_details() const override {
    std::string chunks;
    for (const std::string& c : compressions_) chunks += (chunks.empty() ? "" : ", ") + (c.empty() ? "uncompressed" : c);
    std::string out = chunks.empty() ? "no chunks" : chunks + " chunks";
    bool indexed = true, summarized = true;
    for (const auto& reader : readers_) {
      indexed = indexed && reader->indexed();
      summarized = summarized && reader->has_summary();
    }
    std::string mended;
    for (const auto& reader : readers_) {
      if (!reader->mended().empty()) mended = reader->mended();
    }
    // A summary without a chunk to index (no message, or messages outside
    // chunks) is not a file cut short.
    out += !mended.empty() ? ", " + mended
           : indexed       ? ", indexed"
           : summarized    ? ", with a summary, read by a scan"
                           : ", no summary (read by a scan)";
    return out;
  }

  bool next(BagMessage* message) override {
    while (current_ < readers_.size()) {
      McapMessage m;
      if (readers_[current_]->next(&m)) {
        message->topic = channel_topics_[current_].at(m.channel_id);
        message->log_time = m.log_time;
        message->data = m.data;
        message->size = m.size;
        return true;
      }
      ++current_;
    }
    return false;
  }

  void rewind() override {
    for (auto& reader : readers_) reader->rewind();
    current_ = 0;
  }

  double progress() const override {
    if (readers_.empty()) return 1.0;
    if (current_ >= readers_.size()) return 1.0;
    return (static_cast<double>(current_) + readers_[current_]->progress()) / static_cast<double>(readers_.size());
  }

 private:
  std::vector<std::unique_ptr<McapReader>> readers_;
  std::vector<std::map<std::uint16_t, int>> channel_topics_;  // per file
  std::vector<std::string> compressions_;
  std::size_t current_ = 0;
};

}  // namespace

std::unique_ptr<BagReader> open_mcap_bag(const std::filesystem::path& path,
                                         const std::vector<std::filesystem::path>& files) {
  return std::make_unique<McapBag>(path, files);
}

}  // namespace ros
}  // namespace skidimm
