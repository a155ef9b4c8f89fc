// Topic paths in expressions of log columns: a ROS 2 bag's columns are
// "/imu/data.angular_velocity.z" or "/joint_states.velocity[left]"
// (ros/bag_log.h), which no expression grammar takes as a name. A '/' where
// an operand is expected (never a division there) starts one, up to the end
// of its last field or ']'. Private to core (expression.cc): the language's
// check reads each path as one name, and muparser is given a name of its own
// for it, starting with '_' as no name of the language may.
#ifndef SKIDIMM_CORE_SRC_TOPIC_PATH_NAMES_H_
#define SKIDIMM_CORE_SRC_TOPIC_PATH_NAMES_H_

#include <cctype>
#include <string>

namespace skidimm {
namespace topic_path_names {

// Where the topic path starting at text[i] ends, or i when none starts
// there (the caller knows whether an operand is expected).
inline std::size_t path_end(const std::string& text, std::size_t i) {
  const auto alpha = [](char c) { return std::isalpha(static_cast<unsigned char>(c)) != 0; };
  const auto path_char = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '/'; };
  if (i + 1 >= text.size() || text[i] != '/' || !alpha(text[i + 1])) return i;
  std::size_t end = i + 1;
  while (end < text.size()) {
    if (path_char(text[end])) {
      ++end;
    } else if (text[end] == '.' && end + 1 < text.size() && (alpha(text[end + 1]) || text[end + 1] == '_')) {
      ++end;
    } else if (text[end] == '[' && text.find(']', end) != std::string::npos) {
      end = text.find(']', end) + 1;
    } else {
      break;
    }
  }
  return end;
}

// Whether a variable of an expression is a topic path.
inline bool is_path(const std::string& name) { return !name.empty() && name[0] == '/'; }

// The name muparser is given for the k-th topic path of an expression (in
// order of first use).
inline std::string parser_name(std::size_t k) { return "_path" + std::to_string(k); }

}  // namespace topic_path_names
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_TOPIC_PATH_NAMES_H_
