// Topic paths in expressions of log columns: a ROS 2 bag's columns are
// "/imu/data.angular_velocity.z" or "/joint_states.velocity[left]"
// (ros/bag_log.h), which no expression grammar takes as a name. A '/' where
// an operand is expected (never a division there) starts one, up to the end
// of its last field or ']'. Private to core (expression.cc): each path is
// replaced by a plain name before parsing, and the name mapped back after.
#ifndef SKIDIMM_CORE_SRC_TOPIC_PATH_NAMES_H_
#define SKIDIMM_CORE_SRC_TOPIC_PATH_NAMES_H_

#include <cctype>
#include <string>
#include <vector>

namespace skidimm {
namespace topic_path_names {

constexpr const char* kPrefix = "skidimm_topic_path_";

// `text` with each topic path replaced by kPrefix<i>_ (paths[i] the path).
inline std::string replace(const std::string& text, std::vector<std::string>* paths) {
  const auto alpha = [](char c) { return std::isalpha(static_cast<unsigned char>(c)) != 0; };
  const auto path_char = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '/'; };
  std::string out;
  bool operand_expected = true;
  for (std::size_t i = 0; i < text.size();) {
    const char c = text[i];
    if (c == '/' && operand_expected && i + 1 < text.size() && alpha(text[i + 1])) {
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
      paths->push_back(text.substr(i, end - i));
      out += kPrefix + std::to_string(paths->size() - 1) + "_";
      i = end;
      operand_expected = false;
      continue;
    }
    if (c != ' ' && c != '\t') {
      operand_expected = !(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == ')' || c == '.');
    }
    out += c;
    ++i;
  }
  return out;
}

// The column a name of the replaced text stands for: its path, or itself.
inline std::string original(const std::string& name, const std::vector<std::string>& paths) {
  const std::string prefix = kPrefix;
  if (name.rfind(prefix, 0) != 0) return name;
  std::size_t i = 0;
  for (std::size_t k = prefix.size(); k < name.size() && std::isdigit(static_cast<unsigned char>(name[k])); ++k) {
    i = i * 10 + static_cast<std::size_t>(name[k] - '0');
  }
  return i < paths.size() ? paths[i] : name;
}

}  // namespace topic_path_names
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_TOPIC_PATH_NAMES_H_
