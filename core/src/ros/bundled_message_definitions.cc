#include "bundled_message_definitions.h"

#include <algorithm>
#include <map>

namespace skidimm {
namespace ros {

namespace {

const std::map<std::string, std::string>& bundled() {
  static const std::map<std::string, std::string> kDefinitions = {
      {"builtin_interfaces/msg/Time", "int32 sec\nuint32 nanosec\n"},
      {"builtin_interfaces/msg/Duration", "int32 sec\nuint32 nanosec\n"},
      {"std_msgs/msg/Header", "builtin_interfaces/Time stamp\nstring frame_id\n"},
      {"std_msgs/msg/Bool", "bool data\n"},
      {"std_msgs/msg/Byte", "byte data\n"},
      {"std_msgs/msg/Char", "char data\n"},
      {"std_msgs/msg/Empty", ""},
      {"std_msgs/msg/Float32", "float32 data\n"},
      {"std_msgs/msg/Float64", "float64 data\n"},
      {"std_msgs/msg/Int8", "int8 data\n"},
      {"std_msgs/msg/Int16", "int16 data\n"},
      {"std_msgs/msg/Int32", "int32 data\n"},
      {"std_msgs/msg/Int64", "int64 data\n"},
      {"std_msgs/msg/UInt8", "uint8 data\n"},
      {"std_msgs/msg/UInt16", "uint16 data\n"},
      {"std_msgs/msg/UInt32", "uint32 data\n"},
      {"std_msgs/msg/UInt64", "uint64 data\n"},
      {"std_msgs/msg/String", "string data\n"},
      {"std_msgs/msg/MultiArrayDimension", "string label\nuint32 size\nuint32 stride\n"},
      {"std_msgs/msg/MultiArrayLayout", "MultiArrayDimension[] dim\nuint32 data_offset\n"},
      {"std_msgs/msg/Float32MultiArray", "MultiArrayLayout layout\nfloat32[] data\n"},
      {"std_msgs/msg/Float64MultiArray", "MultiArrayLayout layout\nfloat64[] data\n"},
      {"std_msgs/msg/Int32MultiArray", "MultiArrayLayout layout\nint32[] data\n"},
      {"std_msgs/msg/Int64MultiArray", "MultiArrayLayout layout\nint64[] data\n"},
      {"std_msgs/msg/UInt8MultiArray", "MultiArrayLayout layout\nuint8[] data\n"},
      {"geometry_msgs/msg/Vector3", "float64 x\nfloat64 y\nfloat64 z\n"},
      {"geometry_msgs/msg/Point", "float64 x\nfloat64 y\nfloat64 z\n"},
      {"geometry_msgs/msg/Quaternion", "float64 x\nfloat64 y\nfloat64 z\nfloat64 w\n"},
      {"geometry_msgs/msg/Pose", "Point position\nQuaternion orientation\n"},
      {"geometry_msgs/msg/PoseStamped", "std_msgs/Header header\nPose pose\n"},
      {"geometry_msgs/msg/PoseWithCovariance", "Pose pose\nfloat64[36] covariance\n"},
      {"geometry_msgs/msg/PoseWithCovarianceStamped", "std_msgs/Header header\nPoseWithCovariance pose\n"},
      {"geometry_msgs/msg/Twist", "Vector3 linear\nVector3 angular\n"},
      {"geometry_msgs/msg/TwistStamped", "std_msgs/Header header\nTwist twist\n"},
      {"geometry_msgs/msg/TwistWithCovariance", "Twist twist\nfloat64[36] covariance\n"},
      {"geometry_msgs/msg/TwistWithCovarianceStamped", "std_msgs/Header header\nTwistWithCovariance twist\n"},
      {"geometry_msgs/msg/Accel", "Vector3 linear\nVector3 angular\n"},
      {"geometry_msgs/msg/AccelStamped", "std_msgs/Header header\nAccel accel\n"},
      {"geometry_msgs/msg/Wrench", "Vector3 force\nVector3 torque\n"},
      {"geometry_msgs/msg/WrenchStamped", "std_msgs/Header header\nWrench wrench\n"},
      {"geometry_msgs/msg/Vector3Stamped", "std_msgs/Header header\nVector3 vector\n"},
      {"sensor_msgs/msg/Imu",
       "std_msgs/Header header\ngeometry_msgs/Quaternion orientation\nfloat64[9] orientation_covariance\n"
       "geometry_msgs/Vector3 angular_velocity\nfloat64[9] angular_velocity_covariance\n"
       "geometry_msgs/Vector3 linear_acceleration\nfloat64[9] linear_acceleration_covariance\n"},
      {"sensor_msgs/msg/JointState",
       "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort\n"},
      {"sensor_msgs/msg/NavSatStatus", "int8 status\nuint16 service\n"},
      {"sensor_msgs/msg/NavSatFix",
       "std_msgs/Header header\nNavSatStatus status\nfloat64 latitude\nfloat64 longitude\nfloat64 altitude\n"
       "float64[9] position_covariance\nuint8 position_covariance_type\n"},
      {"nav_msgs/msg/Odometry",
       "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/PoseWithCovariance pose\n"
       "geometry_msgs/TwistWithCovariance twist\n"},
  };
  return kDefinitions;
}

}  // namespace

std::vector<std::string> bundled_message_types() {
  std::vector<std::string> out;
  for (const auto& entry : bundled()) out.push_back(entry.first);
  return out;
}

void add_bundled_definitions(MessageDefinitions* definitions) {
  for (const auto& [name, text] : bundled()) definitions->add(name, text);
}

std::string bundled_complete_definition(const std::string& type_name) {
  MessageDefinitions definitions;
  add_bundled_definitions(&definitions);
  const std::string root = MessageDefinitions::full_type_name(type_name);
  std::string out = bundled().at(root);
  std::vector<std::string> done = {root}, todo = {root};
  while (!todo.empty()) {
    const std::string name = todo.back();
    todo.pop_back();
    for (const MessageField& f : definitions.get(name).fields) {
      if (f.primitive != Primitive::kNone || std::find(done.begin(), done.end(), f.type_name) != done.end()) continue;
      done.push_back(f.type_name);
      todo.push_back(f.type_name);
      std::string short_name = f.type_name;
      short_name.replace(short_name.find("/msg/"), 5, "/");
      out += std::string(80, '=') + "\nMSG: " + short_name + "\n" + bundled().at(f.type_name);
    }
  }
  return out;
}

bool is_bundled_message_type(const std::string& type_name) {
  return bundled().count(MessageDefinitions::full_type_name(type_name)) > 0;
}

}  // namespace ros
}  // namespace skidimm
