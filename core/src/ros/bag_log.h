// A ROS 2 bag as a log: each topic a bank's columns name becomes a table
// (log_table.h) whose rows are the topic's messages, so LogReader merges a
// bag's topics by time as it merges the CSV files of a multi-rate log.
//
// Columns name a topic and a field path of its messages (cdr_field_reader.h):
//   "/imu/data.angular_velocity.z", "/joint_states.velocity[left_wheel]",
// and expressions of them as of CSV columns ("mean(/imu/data.angular_velocity.z)").
// The time column (the bank's columns.time) is, for every topic:
//   header.stamp  the message's header stamp where its type has a
//                 std_msgs/Header, the log time (when the recorder received
//                 it) for types without one;
//   log_time      the log time, for every topic.
//
// Only the topics the bank uses are decoded; the others are stepped over.
// The bag is read once, front to back: each topic's table pulls messages
// until one of its own arrives and keeps the other used topics' decoded rows
// for them (a few, for a bag recorded in time order).
#ifndef SKIDIMM_CORE_SRC_ROS_BAG_LOG_H_
#define SKIDIMM_CORE_SRC_ROS_BAG_LOG_H_

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "cdr_field_reader.h"
#include "log_table.h"
#include "skidimm/io/ros/bag_reader.h"

namespace skidimm {
namespace ros {

// The time columns a bank may name for a bag.
constexpr const char* kHeaderStampColumn = "header.stamp";
constexpr const char* kLogTimeColumn = "log_time";

// A reader of `topic`'s messages: from the bag's definition when it stores
// one in ros2msg, else from the bundled definitions
// (bundled_message_definitions.h). Throws LogError naming the bag and topic
// for messages not in CDR, or a type whose definition is neither stored in a
// form skidimm reads nor bundled.
std::unique_ptr<CdrFieldReader> make_topic_reader(const BagReader& bag, int topic);

// The topics of `bag` that `column_texts` name ("/topic.field" or
// "/topic[...]", alone or in expressions), in the bag's order. Throws
// LogError when a text names a topic the bag does not have (listing those it
// has).
std::vector<int> topics_named(const BagReader& bag, const std::vector<std::string>& column_texts);

// The topics of `bag` that `texts` name, without an error for those it does
// not have (a truth topic a bag may lack).
std::vector<int> topics_named_if_present(const BagReader& bag, const std::vector<std::string>& texts);

// Opens `path` (bag_reader.h) and makes a table of every topic that
// `column_texts` name. Throws LogError; when no text names a topic, the
// message says how bag columns are written and lists the topics.
// `optional_texts` (the truth column) add their topics when the bag has them.
std::vector<std::unique_ptr<LogTable>> open_bag_tables(const std::filesystem::path& path,
                                                       const std::vector<std::string>& column_texts,
                                                       const std::vector<std::string>& optional_texts = {});

}  // namespace ros
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_ROS_BAG_LOG_H_
