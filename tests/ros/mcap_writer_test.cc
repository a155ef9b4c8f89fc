// McapWriter checked by readers nobody here wrote: @mcap/core's indexed
// reader (summary, chunk and message indexes, every CRC) and stream reader
// must both read back exactly the messages written, for every chunk
// compression; and skidimm's own reader agrees.
#include "ros/mcap_writer.h"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cstdio>
#include <cstdlib>
#include <random>

#include "core/temp_files.h"
#include "ros/mcap_reader.h"
#include "skidimm/errors.h"

namespace skidimm {
namespace ros {
namespace {

using skidimm_test::read_file;
using skidimm_test::test_directory;

std::string base64(const std::string& bytes) {
  static const char* const kTable = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  std::size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const unsigned v = (static_cast<unsigned char>(bytes[i]) << 16) | (static_cast<unsigned char>(bytes[i + 1]) << 8) |
                       static_cast<unsigned char>(bytes[i + 2]);
    out += {kTable[v >> 18], kTable[(v >> 12) & 63], kTable[(v >> 6) & 63], kTable[v & 63]};
  }
  if (i + 1 == bytes.size()) {
    const unsigned v = static_cast<unsigned char>(bytes[i]) << 16;
    out += {kTable[v >> 18], kTable[(v >> 12) & 63], '=', '='};
  } else if (i + 2 == bytes.size()) {
    const unsigned v = (static_cast<unsigned char>(bytes[i]) << 16) | (static_cast<unsigned char>(bytes[i + 1]) << 8);
    out += {kTable[v >> 18], kTable[(v >> 12) & 63], kTable[(v >> 6) & 63], '='};
  }
  return out;
}

// What @mcap/core reads in `file` (tests/ros/read_mcap.cjs), as YAML (JSON).
YAML::Node read_with_mcap_core(const std::filesystem::path& file) {
  const std::filesystem::path out = file.string() + ".json";
  const std::string command = "NODE_PATH='" SKIDIMM_NODE_MODULES "' '" SKIDIMM_NODE "' '" SKIDIMM_SOURCE_DIR
                              "/tests/ros/read_mcap.cjs' '" + file.string() + "' > '" + out.string() + "'";
  const int status = std::system(command.c_str());
  EXPECT_EQ(status, 0) << command;
  return YAML::LoadFile(out.string());
}

struct Written {
  std::string topic;
  std::uint64_t log_time;
  std::uint64_t publish_time;
  std::string data;
};

TEST(McapWriter, WhatItWritesIsReadBackExactlyByMcapCoreInEveryCompression) {
  const auto dir = test_directory();
  for (const std::string compression : {"zstd", "lz4", ""}) {
    SCOPED_TRACE("compression '" + compression + "'");
    const auto file = dir / ("out_" + (compression.empty() ? std::string("none") : compression) + ".mcap");
    McapWriter::Options options;
    options.profile = "ros2";
    options.compression = compression;
    options.chunk_size = 4096;  // many chunks
    std::vector<Written> written;
    {
      McapWriter writer(file, options);
      const auto json_schema = writer.add_schema("test.Json", "jsonschema", "{\"type\":\"object\"}");
      const auto msg_schema = writer.add_schema("std_msgs/msg/String", "ros2msg", "string data\n");
      const std::vector<std::pair<std::string, std::uint16_t>> channels = {
          {"/json", writer.add_channel("/json", "json", json_schema, {{"key", "value"}})},
          {"/cdr", writer.add_channel("/cdr", "cdr", msg_schema)},
          {"/raw", writer.add_channel("/raw", "application/octet-stream", 0)}};
      std::mt19937 random(27);
      for (int k = 0; k < 600; ++k) {
        const auto& [topic, id] = channels[static_cast<std::size_t>(random() % 3)];
        std::string data;
        if (topic == "/json") {
          data = "{\"k\":" + std::to_string(k) + ",\"x\":" + std::to_string(random() % 1000) + "}";
        } else {
          data.resize(random() % 300);  // an empty message too, sometimes
          for (char& c : data) c = static_cast<char>(random() & 0xFF);
        }
        const std::uint64_t t = 1000000000ull * 1700000000ull + 1000000ull * static_cast<std::uint64_t>(k);
        writer.write(id, t, t + 5, data.data(), data.size());
        written.push_back({topic, t, t + 5, data});
      }
      writer.commit();
    }
    ASSERT_FALSE(std::filesystem::exists(file.string() + ".partial"));
    const YAML::Node read = read_with_mcap_core(file);
    EXPECT_EQ(read["profile"].as<std::string>(), "ros2");
    EXPECT_EQ(read["library"].as<std::string>(), "skidimm");
    EXPECT_GT(read["chunks"].as<int>(), 10);
    ASSERT_EQ(read["messages"].size(), written.size());
    EXPECT_EQ(read["statistics"]["messageCount"].as<std::string>(), "600");
    for (std::size_t i = 0; i < written.size(); ++i) {
      const YAML::Node m = read["messages"][i];
      EXPECT_EQ(m["topic"].as<std::string>(), written[i].topic) << i;
      EXPECT_EQ(m["logTime"].as<std::string>(), std::to_string(written[i].log_time)) << i;
      EXPECT_EQ(m["publishTime"].as<std::string>(), std::to_string(written[i].publish_time)) << i;
      if (written[i].topic == "/json") {
        EXPECT_EQ("{\"k\":" + std::to_string(m["json"]["k"].as<long>()) + ",\"x\":" +
                      std::to_string(m["json"]["x"].as<long>()) + "}",
                  written[i].data);
      } else {
        EXPECT_EQ(m["base64"].as<std::string>(), base64(written[i].data)) << i;
      }
    }
    // skidimm's reader, by the index.
    McapReader reader(file);
    EXPECT_TRUE(reader.indexed());
    McapMessage m;
    std::size_t n = 0;
    while (reader.next(&m)) {
      ASSERT_LT(n, written.size());
      EXPECT_EQ(std::string(reinterpret_cast<const char*>(m.data), m.size), written[n].data);
      ++n;
    }
    EXPECT_EQ(n, written.size());
  }
}

TEST(McapWriter, AWriterDestroyedWithoutCommitLeavesAReadablePartialFile) {
  const auto dir = test_directory();
  const auto file = dir / "estimates.mcap";
  {
    McapWriter writer(file);
    const auto channel = writer.add_channel("/x", "json", writer.add_schema("x", "jsonschema", "{}"));
    for (int k = 0; k < 10; ++k) {
      const std::string data = "{\"k\":" + std::to_string(k) + "}";
      writer.write(channel, static_cast<std::uint64_t>(k), static_cast<std::uint64_t>(k), data.data(), data.size());
    }
  }  // an error upstream: no commit()
  EXPECT_FALSE(std::filesystem::exists(file));
  const std::filesystem::path partial = file.string() + ".partial";
  ASSERT_TRUE(std::filesystem::exists(partial));
  const YAML::Node read = read_with_mcap_core(partial);
  ASSERT_EQ(read["messages"].size(), 10u);
  EXPECT_EQ(read["messages"][9]["json"]["k"].as<int>(), 9);
}

}  // namespace
}  // namespace ros
}  // namespace skidimm
