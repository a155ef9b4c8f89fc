// CdrFieldReader against messages serialized by @foxglove/rosmsg2-serialization
// (and, big-endian, by @foxglove/cdr): every primitive type, strings, fixed
// arrays, sequences, sequences of messages, elements by index and by name,
// checked bit for bit against the values the writer was given.
#include "ros/cdr_field_reader.h"

#include <gtest/gtest.h>

#include "ros/bundled_message_definitions.h"
#include "ros/mcap_reader.h"
#include "ros/ros_fixtures.h"

namespace skidimm {
namespace ros {
namespace {

using skidimm_test::ExpectedValue;
using skidimm_test::read_expected;
using skidimm_test::ros_fixture;
using skidimm_test::same_double;

// Decodes every message of the file's first channel and checks each path of
// the expected file; returns the number of values checked.
long check_file(const std::string& mcap, const std::string& expected_file, const std::string& topic = "") {
  const auto expected = read_expected(ros_fixture(expected_file));
  McapReader reader(ros_fixture(mcap));
  std::uint16_t channel_id = 0;
  for (const auto& [id, channel] : reader.channels()) {
    if (topic.empty() || channel.topic == topic) {
      channel_id = id;
      break;
    }
  }
  const McapChannel& channel = reader.channels().at(channel_id);
  MessageDefinitions definitions;
  std::string type;
  const McapSchema& schema = reader.schemas().at(channel.schema_id);
  type = schema.name;
  if (!schema.data.empty()) {
    definitions.add(schema.name, schema.data);
  } else {
    add_bundled_definitions(&definitions);
  }
  CdrFieldReader cdr(definitions, type);
  std::map<std::string, int> slots;
  for (const auto& [path, value] : expected.begin()->second) slots[path] = cdr.add(path);
  long checked = 0, message_number = 0;
  McapMessage m;
  while (reader.next(&m)) {
    if (m.channel_id != channel_id) continue;
    ++message_number;
    cdr.decode(m.data, m.size);
    for (const auto& [path, want] : expected.at(message_number)) {
      const int slot = slots.at(path);
      if (want.is_text) {
        EXPECT_TRUE(cdr.is_text(slot)) << path;
        EXPECT_EQ(cdr.text(slot), want.text) << "message " << message_number << ", " << path;
      } else {
        EXPECT_TRUE(same_double(cdr.value(slot), want.number))
            << "message " << message_number << ", " << path << ": " << cdr.value(slot) << " != " << want.number;
      }
      ++checked;
    }
  }
  EXPECT_EQ(message_number, static_cast<long>(expected.size()));
  return checked;
}

TEST(CdrFieldReader, ReadsEveryKindOfFieldAsTheIndependentWriterWroteIt) {
  EXPECT_EQ(check_file("all_types.mcap", "all_types.expected"), 120 * 32);
}

TEST(CdrFieldReader, ReadsBigEndianCdr) { EXPECT_EQ(check_file("big_endian.mcap", "big_endian.expected"), 5 * 5); }

TEST(CdrFieldReader, ReadsAMessageWithTheBundledDefinitionWhenTheBagHasNone) {
  EXPECT_EQ(check_file("mixed.mcap", "mixed_imu.expected", "/imu/data"), 4 * 3);
}

MessageDefinitions imu_and_joints() {
  MessageDefinitions d;
  add_bundled_definitions(&d);
  return d;
}

TEST(CdrFieldReader, ListsThePathsABankCanUse) {
  const MessageDefinitions d = imu_and_joints();
  CdrFieldReader joints(d, "sensor_msgs/JointState");
  EXPECT_EQ(joints.usable_paths(),
            (std::vector<std::string>{"header.stamp", "header.frame_id", "name[i]", "position[i]", "position[NAME]",
                                      "velocity[i]", "velocity[NAME]", "effort[i]", "effort[NAME]"}));
  EXPECT_TRUE(joints.has_header_stamp());
  CdrFieldReader twist(d, "geometry_msgs/msg/Twist");
  EXPECT_FALSE(twist.has_header_stamp());
  EXPECT_EQ(twist.usable_paths().front(), "linear.x");
  CdrFieldReader odometry(d, "nav_msgs/msg/Odometry");
  const auto paths = odometry.usable_paths();
  EXPECT_NE(std::find(paths.begin(), paths.end(), "twist.twist.angular.z"), paths.end());
  EXPECT_NE(std::find(paths.begin(), paths.end(), "pose.covariance[0..35]"), paths.end());
}

TEST(CdrFieldReader, APathTheTypeLacksSaysWhyAndListsThePathsItHas) {
  const MessageDefinitions d = imu_and_joints();
  CdrFieldReader imu(d, "sensor_msgs/msg/Imu");
  const auto message_of = [&](const std::string& path) -> std::string {
    try {
      imu.add(path);
    } catch (const FieldPathError& e) {
      EXPECT_FALSE(e.usable().empty());
      return e.what();
    }
    return "";
  };
  EXPECT_NE(message_of("angular_velocity.w").find("geometry_msgs/msg/Vector3 has no field 'w'"), std::string::npos);
  EXPECT_EQ(message_of("angular_velocty.z")
                .rfind("sensor_msgs/msg/Imu has no field 'angular_velocty.z': no field "
                       "'angular_velocty'",
                       0),
            0u)
      << message_of("angular_velocty.z");
  EXPECT_NE(message_of("angular_velocity").find("name one of its fields (angular_velocity.x"), std::string::npos);
  EXPECT_NE(message_of("orientation_covariance").find("is an array"), std::string::npos);
  EXPECT_NE(message_of("orientation_covariance[9]").find("has 9 elements"), std::string::npos);
  EXPECT_NE(message_of("angular_velocity.x.y").find("has no fields"), std::string::npos);
  EXPECT_NE(message_of("orientation_covariance[left]").find("selects by name"), std::string::npos);
  EXPECT_NE(message_of("").find("empty field name"), std::string::npos);
  EXPECT_FALSE(imu.has("angular_velocity.w"));
  EXPECT_TRUE(imu.has("angular_velocity.z"));
  EXPECT_EQ(imu.slots(), 0) << "failed paths take no slot";
  EXPECT_EQ(imu.add("angular_velocity.z"), 0);
  EXPECT_EQ(imu.add("header.stamp"), 1);
  EXPECT_EQ(imu.add("angular_velocity.z"), 0) << "the same path, the same slot";
}

TEST(CdrFieldReader, MalformedDataIsAnErrorNotACrash) {
  const MessageDefinitions d = imu_and_joints();
  CdrFieldReader joints(d, "sensor_msgs/msg/JointState");
  joints.add("velocity[left]");
  const auto error_of = [&](const std::vector<std::uint8_t>& bytes) -> std::string {
    try {
      joints.decode(bytes.data(), bytes.size());
    } catch (const CdrError& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(error_of({0, 1}).find("shorter than CDR's 4-byte header"), std::string::npos);
  EXPECT_NE(error_of({0, 7, 0, 0, 0, 0, 0, 0}).find("not plain CDR"), std::string::npos);
  // A stamp, then a frame_id whose length runs past the end.
  EXPECT_NE(error_of({0, 1, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0, 0xFF, 0xFF, 0, 0, 'a'}).find("a string needs"),
            std::string::npos);
  // A sequence of four billion names.
  EXPECT_NE(error_of({0, 1, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0xFF, 0xFF, 0xFF, 0xFF})
                .find("a sequence needs"),
            std::string::npos);
}

TEST(MessageDefinitions, ParsesRosbag2sFormatWithEitherNamingOfDependencies) {
  MessageDefinitions d;
  d.add("my_msgs/msg/Outer",
        "# comment\nInner inner  # same package\nstd_msgs/Header header\nint32 LIMIT = 5\nstring<=4 s\n"
        "float32[<=3] bounded\nuint8[16] fixed\n" + std::string(80, '=') + "\nMSG: my_msgs/Inner\nfloat64 x 2.5\n" +
            std::string(80, '=') + "\nMSG: std_msgs/msg/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n" +
            std::string(80, '=') + "\nMSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n");
  const MessageType& outer = d.get("my_msgs/Outer");
  ASSERT_EQ(outer.fields.size(), 5u);
  EXPECT_EQ(outer.fields[0].type_name, "my_msgs/msg/Inner");
  EXPECT_EQ(outer.fields[1].type_name, "std_msgs/msg/Header");
  EXPECT_EQ(outer.fields[2].primitive, Primitive::kString);
  EXPECT_EQ(outer.fields[3].array, MessageField::Array::kSequence);
  EXPECT_EQ(outer.fields[3].array_size, 3u);
  EXPECT_EQ(outer.fields[4].array, MessageField::Array::kFixed);
  EXPECT_EQ(outer.fields[4].array_size, 16u);
  d.check_complete("my_msgs/msg/Outer");
  MessageDefinitions missing;
  missing.add("a/msg/B", "c/D field\n");
  try {
    missing.check_complete("a/B");
    ADD_FAILURE() << "an undefined type must be reported";
  } catch (const DefinitionError& e) {
    EXPECT_NE(std::string(e.what()).find("no definition of c/msg/D (used by a/msg/B.field)"), std::string::npos)
        << e.what();
  }
  MessageDefinitions bad;
  EXPECT_THROW(bad.add("a/msg/B", "float64[x] values\n"), DefinitionError);
  EXPECT_THROW(bad.add("a/msg/B", "float64\n"), DefinitionError);
  MessageDefinitions self;
  self.add("a/msg/Node", "Node next\n");
  EXPECT_THROW(CdrFieldReader(self, "a/msg/Node"), DefinitionError);
}

}  // namespace
}  // namespace ros
}  // namespace skidimm
