#include "skidimm/io/ros/bag_info.h"

#include <algorithm>
#include <cstdio>
#include <map>
#include <memory>

#include "bag_log.h"
#include "skidimm/errors.h"
#include "skidimm/io/ros/bag_reader.h"

namespace skidimm {
namespace ros {

namespace {

constexpr int kMaxNames = 32;  // names listed per sequence
// The messages of a topic whose names are gathered: a topic several
// publishers share (the wheels' and an arm's JointState) names different
// joints in different messages.
constexpr int kMessagesNamed = 100;

std::string seconds(std::uint64_t ns) {
  char buffer[40];
  std::snprintf(buffer, sizeof(buffer), "%llu.%09llu", static_cast<unsigned long long>(ns / 1000000000),
                static_cast<unsigned long long>(ns % 1000000000));
  return buffer;
}

std::string size_text(std::uintmax_t bytes) {
  char buffer[32];
  if (bytes < 1024) return std::to_string(bytes) + " B";
  if (bytes < 1024 * 1024) {
    std::snprintf(buffer, sizeof(buffer), "%.1f KiB", static_cast<double>(bytes) / 1024.0);
  } else {
    std::snprintf(buffer, sizeof(buffer), "%.1f MiB", static_cast<double>(bytes) / (1024.0 * 1024.0));
  }
  return buffer;
}

// The reader of a topic and, for a sequence selected by name, the slots of
// the names, and the distinct names of its first kMessagesNamed messages.
struct TopicDecoder {
  std::unique_ptr<CdrFieldReader> reader;
  std::vector<int> name_slots;
  int decoded = 0;
  std::vector<std::string> names;
};

}  // namespace

BagInfo describe_bag(const std::filesystem::path& path) {
  const auto bag = BagReader::open(path);
  BagInfo info;
  info.path = path;
  info.storage = bag->storage() + " (" + bag->storage_details() + ")";
  std::error_code ec;
  for (const auto& f : bag->files()) info.files.emplace_back(f, std::filesystem::file_size(f, ec));
  std::vector<TopicDecoder> decoders(bag->topics().size());
  for (std::size_t i = 0; i < bag->topics().size(); ++i) {
    const BagTopic& t = bag->topics()[i];
    BagTopicInfo topic;
    topic.name = t.name;
    topic.type = t.type;
    topic.serialization_format = t.serialization_format;
    try {
      decoders[i].reader = make_topic_reader(*bag, static_cast<int>(i));
      topic.definition = !t.definition.empty() && t.definition_encoding == "ros2msg" ? "stored in the bag" : "bundled";
      topic.has_header = decoders[i].reader->has_header_stamp();
      for (const std::string& p : decoders[i].reader->usable_paths()) topic.columns.push_back(t.name + "." + p);
      if (decoders[i].reader->has("name[0]")) {
        for (int k = 0; k < kMaxNames; ++k) {
          decoders[i].name_slots.push_back(decoders[i].reader->add("name[" + std::to_string(k) + "]"));
        }
      }
    } catch (const LogError& e) {
      // The message names the bag and topic already; keep what follows them.
      const std::string what = e.what();
      const auto colon = what.find("): ");
      topic.definition = "not readable: " + (colon == std::string::npos ? what : what.substr(colon + 3));
    }
    info.topics.push_back(std::move(topic));
  }
  std::vector<bool> seen(info.topics.size(), false);
  BagMessage m;
  try {
    while (bag->next(&m)) {
      BagTopicInfo& topic = info.topics[static_cast<std::size_t>(m.topic)];
      if (!seen[static_cast<std::size_t>(m.topic)]) {
        topic.first_log_time = m.log_time;
        seen[static_cast<std::size_t>(m.topic)] = true;
      }
      topic.first_log_time = std::min(topic.first_log_time, m.log_time);
      topic.last_log_time = std::max(topic.last_log_time, m.log_time);
      ++topic.messages;
      if (info.messages == 0 || m.log_time < info.start) info.start = m.log_time;
      if (info.messages == 0 || m.log_time > info.end) info.end = m.log_time;
      ++info.messages;
      TopicDecoder& d = decoders[static_cast<std::size_t>(m.topic)];
      if (d.reader && !d.name_slots.empty() && d.decoded < kMessagesNamed) {
        ++d.decoded;
        try {
          d.reader->decode(m.data, m.size);
          for (int slot : d.name_slots) {
            const std::string_view name = d.reader->text(slot);
            if (!name.empty() && static_cast<int>(d.names.size()) < kMaxNames &&
                std::find(d.names.begin(), d.names.end(), name) == d.names.end()) {
              d.names.emplace_back(name);
            }
          }
        } catch (const CdrError&) {
        }
      }
    }
  } catch (const LogError& e) {
    info.problem = e.what();
  }
  for (std::size_t i = 0; i < info.topics.size(); ++i) {
    BagTopicInfo& topic = info.topics[i];
    if (topic.messages > 1 && topic.last_log_time > topic.first_log_time) {
      topic.rate = static_cast<double>(topic.messages - 1) /
                   (static_cast<double>(topic.last_log_time - topic.first_log_time) / 1e9);
    }
    // "velocity[NAME]" -> the names the first messages have.
    std::vector<std::string> columns;
    for (const std::string& c : topic.columns) {
      const auto at = c.find("[NAME]");
      if (at == std::string::npos || decoders[i].names.empty()) {
        columns.push_back(c);
        continue;
      }
      for (const std::string& name : decoders[i].names) columns.push_back(c.substr(0, at) + "[" + name + "]" + c.substr(at + 6));
    }
    topic.columns = std::move(columns);
  }
  return info;
}

std::string format_bag_info(const BagInfo& info) {
  std::string out;
  out += "Bag:       " + info.path.string() + "\n";
  out += "Storage:   " + info.storage + "\n";
  for (const auto& [file, size] : info.files) out += "File:      " + file.filename().string() + " (" + size_text(size) + ")\n";
  if (info.messages > 0) {
    char duration[48];
    std::snprintf(duration, sizeof(duration), "%.3f s", static_cast<double>(info.end - info.start) / 1e9);
    out += "Duration:  " + std::string(duration) + "\n";
    out += "Start:     " + seconds(info.start) + " s (log time)\n";
    out += "End:       " + seconds(info.end) + " s\n";
  }
  out += "Messages:  " + std::to_string(info.messages) + "\n";
  std::size_t name_width = 5, type_width = 4;
  for (const BagTopicInfo& t : info.topics) {
    name_width = std::max(name_width, t.name.size());
    type_width = std::max(type_width, t.type.size());
  }
  out += "Topics:\n";
  for (const BagTopicInfo& t : info.topics) {
    char rate[32];
    std::snprintf(rate, sizeof(rate), "%9.2f Hz", t.rate);
    const std::string count = std::to_string(t.messages);
    out += "  " + t.name + std::string(name_width - t.name.size() + 2, ' ') + t.type +
           std::string(type_width - t.type.size() + 2, ' ') + std::string(count.size() < 8 ? 8 - count.size() : 0, ' ') +
           count + " msgs" + rate +
           "  " + (t.serialization_format == "cdr" ? "" : t.serialization_format + ", ") + "time " +
           (t.has_header ? "header.stamp" : "log_time") + ", definition " + t.definition + "\n";
  }
  out += "Columns a bank can name (columns.time: header.stamp, the log time for types without a header; or log_time):\n";
  for (const BagTopicInfo& t : info.topics) {
    if (t.columns.empty()) continue;
    std::string line = " ";
    for (const std::string& c : t.columns) {
      if (line.size() + c.size() + 1 > 100) {
        out += line + "\n";
        line = " ";
      }
      line += " " + c;
    }
    out += line + "\n";
  }
  if (!info.problem.empty()) out += "Problem:   " + info.problem + " (the counts above stop there)\n";
  return out;
}

}  // namespace ros
}  // namespace skidimm
