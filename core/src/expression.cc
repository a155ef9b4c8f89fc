#include "skidimm/expression.h"

#include <muParser.h>

#include <cctype>
#include <limits>
#include <utility>

namespace skidimm {

namespace {

bool is_path_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '/'; }

// A ROS 2 bag's columns are topic paths, "/imu/data.angular_velocity.z" or
// "/joint_states.velocity[left]" (ros/bag_log.h): a '/' where an operand is
// expected (never a division there) starts one, up to the end of its last
// field or ']'. Each is given to muparser as a name of its own.
std::string alias_topic_paths(const std::string& text, std::vector<std::string>* paths) {
  std::string out;
  bool operand_expected = true;
  for (std::size_t i = 0; i < text.size();) {
    const char c = text[i];
    if (c == '/' && operand_expected && i + 1 < text.size() && std::isalpha(static_cast<unsigned char>(text[i + 1]))) {
      std::size_t end = i + 1;
      while (end < text.size()) {
        if (is_path_char(text[end])) {
          ++end;
        } else if (text[end] == '.' && end + 1 < text.size() && (std::isalpha(static_cast<unsigned char>(text[end + 1])) || text[end + 1] == '_')) {
          ++end;
        } else if (text[end] == '[') {
          const auto close = text.find(']', end);
          if (close == std::string::npos) break;
          end = close + 1;
        } else {
          break;
        }
      }
      paths->push_back(text.substr(i, end - i));
      out += "skidimm_topic_path_" + std::to_string(paths->size() - 1) + "_";
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

}  // namespace

Expression::Expression(const std::string& text) : text_(text), parser_(std::make_unique<mu::Parser>()) {
  try {
    std::vector<std::string> paths;
    const std::string parsed = alias_topic_paths(text, &paths);
    parser_->SetExpr(parsed);
    // GetUsedVar parses the whole expression (syntax errors throw here) and
    // collects the identifiers that are neither functions nor constants.
    std::vector<std::string> names;
    for (const auto& entry : parser_->GetUsedVar()) names.push_back(entry.first);
    for (const std::string& name : names) {
      const std::string prefix = "skidimm_topic_path_";
      variables_.push_back(name.rfind(prefix, 0) == 0 ? paths[std::stoul(name.substr(prefix.size()))] : name);
    }
    // muparser lists them sorted; keep that order, it is as good as any and stable.
    slots_ = std::make_unique<double[]>(variables_.size() + 1);
    for (std::size_t i = 0; i < variables_.size(); ++i) {
      slots_[i] = 0.0;
      parser_->DefineVar(names[i], &slots_[i]);
    }
    parser_->SetExpr(parsed);
    parser_->Eval();  // compiles to bytecode now, so evaluate() never meets a parse error
  } catch (const mu::Parser::exception_type& e) {
    std::string message = e.GetMsg();
    if (!message.empty() && message.back() == '.') message.pop_back();
    throw ExpressionError("cannot parse \"" + text + "\": " + message);
  }
}

Expression::~Expression() = default;
Expression::Expression(Expression&&) noexcept = default;
Expression& Expression::operator=(Expression&&) noexcept = default;

double Expression::evaluate(const double* values) const {
  for (std::size_t i = 0; i < variables_.size(); ++i) slots_[i] = values[i];
  try {
    return parser_->Eval();
  } catch (const mu::Parser::exception_type&) {
    return std::numeric_limits<double>::quiet_NaN();
  }
}

bool Expression::is_identifier(const std::string& name) {
  if (name.empty() || std::isdigit(static_cast<unsigned char>(name[0]))) return false;
  for (unsigned char c : name) {
    if (!(std::isalnum(c) || c == '_')) return false;
  }
  return true;
}

}  // namespace skidimm
