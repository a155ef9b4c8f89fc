// Definitions of the message types robots publish most, for bags that do
// not store their own (rosbag2 before Iron writes none in .db3 files; a
// ROS 2 MCAP always has them): builtin_interfaces Time and Duration,
// std_msgs Header, the std_msgs scalars (Bool, Float32, Float64, Int8 to
// UInt64, String, Empty) and their MultiArrays, geometry_msgs Vector3,
// Point, Quaternion, Pose, Twist, Accel, Wrench and their Stamped and
// WithCovariance forms, sensor_msgs Imu, JointState, NavSatFix, and
// nav_msgs Odometry. Written from the ROS 2 interface definitions (fields
// only, without constants and comments), which have not changed since Foxy.
#ifndef SKIDIMM_CORE_SRC_ROS_BUNDLED_MESSAGE_DEFINITIONS_H_
#define SKIDIMM_CORE_SRC_ROS_BUNDLED_MESSAGE_DEFINITIONS_H_

#include <string>
#include <vector>

#include "message_definition.h"

namespace skidimm {
namespace ros {

// The bundled types' full names, sorted.
std::vector<std::string> bundled_message_types();
// Adds every bundled type to *definitions.
void add_bundled_definitions(MessageDefinitions* definitions);
// Whether `type_name` ("pkg/msg/Type" or "pkg/Type") is bundled.
bool is_bundled_message_type(const std::string& type_name);
// The complete ros2msg definition of a bundled type, as rosbag2 stores one
// (its dependencies after '=' lines and "MSG: package/Type"), for copying a
// bag's messages into an MCAP file that describes them.
std::string bundled_complete_definition(const std::string& type_name);

}  // namespace ros
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_ROS_BUNDLED_MESSAGE_DEFINITIONS_H_
