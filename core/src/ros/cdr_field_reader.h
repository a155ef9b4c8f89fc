// CdrFieldReader: chosen fields of ROS 2 messages in CDR (the "cdr" message
// encoding of rosbag2: an encapsulation header, then the fields in order,
// each aligned to its size, little- or big-endian), decoded generically from
// the message definition (message_definition.h), without generated code.
//
// A field is named by a path from the message, as a bank names it after the
// topic (docs/ros2.md):
//   angular_velocity.z          a nested field
//   header.stamp                a builtin_interfaces Time or Duration: its seconds
//   orientation_covariance[4]   an element of an array, by index
//   velocity[left_wheel]        an element of a sequence by the `name` entry
//                               of its message: JointState's velocity[i] where
//                               name[i] == "left_wheel"
//   dim[0].label                a field of an element of a sequence of messages
// Numbers of every primitive type are read as doubles (bool as 0 or 1);
// string fields as text. A message whose sequence is too short for an index,
// or has no such name, has that field missing (NaN), as an empty CSV cell.
//
// decode() reads only what the paths need and steps over the rest; it
// allocates nothing once the reader's buffers have grown. Malformed data
// (a sequence longer than the message, a cut string, an unknown
// encapsulation) throws CdrError; a path that the type does not have
// throws FieldPathError listing the paths it does have.
#ifndef SKIDIMM_CORE_SRC_ROS_CDR_FIELD_READER_H_
#define SKIDIMM_CORE_SRC_ROS_CDR_FIELD_READER_H_

#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "message_definition.h"

namespace skidimm {
namespace ros {

class CdrError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class FieldPathError : public std::runtime_error {
 public:
  FieldPathError(const std::string& message, std::vector<std::string> usable)
      : std::runtime_error(message), usable_(std::move(usable)) {}
  // What the type has (usable_paths()).
  const std::vector<std::string>& usable() const { return usable_; }

 private:
  std::vector<std::string> usable_;
};

class CdrFieldReader {
 public:
  // Throws DefinitionError if `type_name` or a type it uses is not in
  // `definitions`, or uses something CDR decoding here does not support
  // (wstring, a type that contains itself).
  CdrFieldReader(const MessageDefinitions& definitions, const std::string& type_name);
  ~CdrFieldReader();
  CdrFieldReader(const CdrFieldReader&) = delete;
  CdrFieldReader& operator=(const CdrFieldReader&) = delete;

  const std::string& type_name() const { return type_name_; }

  // The slot that will hold `path`'s value (the same slot for the same path).
  // Throws FieldPathError.
  int add(const std::string& path);
  int slots() const { return static_cast<int>(slot_is_text_.size()); }
  bool is_text(int slot) const { return slot_is_text_[static_cast<std::size_t>(slot)]; }
  // Whether `path` names a field of the type (add() would succeed).
  bool has(const std::string& path) const;

  // Decodes one serialized message (encapsulation header included).
  void decode(const std::uint8_t* data, std::size_t size);
  double value(int slot) const { return values_[static_cast<std::size_t>(slot)]; }
  std::string_view text(int slot) const { return texts_[static_cast<std::size_t>(slot)]; }
  // Whether the last message had the slot's field: false for an element by
  // index past its sequence's end or by a name its `name` sequence lacks
  // (another publisher's joints), whose value() is then NaN.
  bool found(int slot) const { return found_[static_cast<std::size_t>(slot)] != 0; }

  // Every path a bank can name, in definition order, arrays written with
  // their index range: "orientation_covariance[0..8]", "velocity[i]" and,
  // where the message has a `name` sequence, "velocity[NAME]".
  std::vector<std::string> usable_paths() const;
  // Whether the type has a field header.stamp (a std_msgs/Header header).
  bool has_header_stamp() const;

 private:
  struct Type;
  struct Field;
  struct Target;
  struct FieldPlan;
  struct StructPlan;
  struct Cursor;
  struct Deferred;

  void set_value(int slot, double value) {
    values_[static_cast<std::size_t>(slot)] = value;
    found_[static_cast<std::size_t>(slot)] = 1;
  }
  void set_text(int slot, std::string_view text) {
    texts_[static_cast<std::size_t>(slot)].assign(text);
    found_[static_cast<std::size_t>(slot)] = 1;
  }
  int resolve(const MessageDefinitions& definitions, const std::string& name, std::vector<std::string>* stack);
  int add_path(const std::string& path, bool dry_run);
  void walk(int type, const StructPlan* plan, Cursor& c, int depth);
  void list_paths(int type, const std::string& prefix, int depth, std::vector<std::string>* out) const;

  std::string type_name_;
  std::vector<Type> types_;
  std::unique_ptr<StructPlan> plan_;
  std::vector<std::string> paths_;  // per slot
  std::vector<bool> slot_is_text_;
  std::vector<double> values_;
  std::vector<std::string> texts_;
  std::vector<char> found_;  // per slot, found()
  std::vector<std::string_view> names_scratch_;
  std::vector<Deferred> deferred_scratch_;
};

}  // namespace ros
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_ROS_CDR_FIELD_READER_H_
