// ROS 2 message definitions (.msg, the "ros2msg" encoding) as rosbag2 stores
// them: the top-level type's definition first, then each type it uses after a
// line of 80 '=' and a line "MSG: package/msg/Type" (docs/ros2.md). What the
// CDR reader (cdr_field_reader.h) needs of them: each type's fields in order,
// with their types, array kinds and bounds. Constants are read and dropped;
// defaults are ignored (they do not change the encoding).
//
// Type names are kept in their full form "package/msg/Type"; "package/Type",
// a type of the same package written without it, and "Header" (std_msgs)
// are resolved to it, as rosidl does.
#ifndef SKIDIMM_CORE_SRC_ROS_MESSAGE_DEFINITION_H_
#define SKIDIMM_CORE_SRC_ROS_MESSAGE_DEFINITION_H_

#include <cstddef>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

namespace skidimm {
namespace ros {

// A definition that cannot be parsed, or a type that is used but not defined.
class DefinitionError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class Primitive {
  kNone,  // a message type (MessageField::type_name)
  kBool,
  kByte,
  kChar,
  kInt8,
  kUint8,
  kInt16,
  kUint16,
  kInt32,
  kUint32,
  kInt64,
  kUint64,
  kFloat32,
  kFloat64,
  kString,
  kWstring,
};

// Size in bytes of a fixed-size primitive in CDR (0 for strings and kNone).
std::size_t primitive_size(Primitive p);
const char* primitive_name(Primitive p);

struct MessageField {
  std::string name;
  Primitive primitive = Primitive::kNone;
  std::string type_name;  // "geometry_msgs/msg/Vector3" when primitive is kNone
  enum class Array { kNone, kFixed, kSequence } array = Array::kNone;
  std::size_t array_size = 0;  // kFixed: the length; kSequence: the bound (0: unbounded)
};

struct MessageType {
  std::string name;  // "sensor_msgs/msg/Imu"
  std::vector<MessageField> fields;
};

// The types of one or more definitions, by full name.
class MessageDefinitions {
 public:
  // Parses a complete definition of `type_name` (its text and its
  // dependencies' after '=' lines) and adds every type in it. Throws
  // DefinitionError naming the type, the line and what was expected.
  void add(const std::string& type_name, const std::string& text);
  bool has(const std::string& type_name) const { return types_.count(full_type_name(type_name)) > 0; }
  // Throws DefinitionError if `type_name` or a type it uses is missing.
  const MessageType& get(const std::string& type_name) const;
  // Throws DefinitionError naming the first type that `type_name` uses,
  // directly or not, and that is not defined.
  void check_complete(const std::string& type_name) const;

  // "pkg/Type" and "pkg/msg/Type" -> "pkg/msg/Type".
  static std::string full_type_name(const std::string& name);

 private:
  void add_one(const std::string& type_name, const std::string& text, int first_line);
  std::map<std::string, MessageType> types_;
};

}  // namespace ros
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_ROS_MESSAGE_DEFINITION_H_
