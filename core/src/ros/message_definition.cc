#include "message_definition.h"

#include <cctype>
#include <set>
#include <sstream>

namespace skidimm {
namespace ros {

std::size_t primitive_size(Primitive p) {
  switch (p) {
    case Primitive::kBool:
    case Primitive::kByte:
    case Primitive::kChar:
    case Primitive::kInt8:
    case Primitive::kUint8:
      return 1;
    case Primitive::kInt16:
    case Primitive::kUint16:
      return 2;
    case Primitive::kInt32:
    case Primitive::kUint32:
    case Primitive::kFloat32:
      return 4;
    case Primitive::kInt64:
    case Primitive::kUint64:
    case Primitive::kFloat64:
      return 8;
    default:
      return 0;
  }
}

const char* primitive_name(Primitive p) {
  switch (p) {
    case Primitive::kBool:
      return "bool";
    case Primitive::kByte:
      return "byte";
    case Primitive::kChar:
      return "char";
    case Primitive::kInt8:
      return "int8";
    case Primitive::kUint8:
      return "uint8";
    case Primitive::kInt16:
      return "int16";
    case Primitive::kUint16:
      return "uint16";
    case Primitive::kInt32:
      return "int32";
    case Primitive::kUint32:
      return "uint32";
    case Primitive::kInt64:
      return "int64";
    case Primitive::kUint64:
      return "uint64";
    case Primitive::kFloat32:
      return "float32";
    case Primitive::kFloat64:
      return "float64";
    case Primitive::kString:
      return "string";
    case Primitive::kWstring:
      return "wstring";
    case Primitive::kNone:
      break;
  }
  return "message";
}

namespace {

Primitive primitive_of(const std::string& name) {
  static const std::map<std::string, Primitive> kPrimitives = {
      {"bool", Primitive::kBool},       {"byte", Primitive::kByte},       {"char", Primitive::kChar},
      {"int8", Primitive::kInt8},       {"uint8", Primitive::kUint8},     {"int16", Primitive::kInt16},
      {"uint16", Primitive::kUint16},   {"int32", Primitive::kInt32},     {"uint32", Primitive::kUint32},
      {"int64", Primitive::kInt64},     {"uint64", Primitive::kUint64},   {"float32", Primitive::kFloat32},
      {"float64", Primitive::kFloat64}, {"string", Primitive::kString},   {"wstring", Primitive::kWstring},
      {"float", Primitive::kFloat32},   {"double", Primitive::kFloat64},  {"octet", Primitive::kByte},
  };
  const auto it = kPrimitives.find(name);
  return it == kPrimitives.end() ? Primitive::kNone : it->second;
}

std::string package_of(const std::string& full_name) { return full_name.substr(0, full_name.find('/')); }

bool is_name_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }

std::size_t parse_size(const std::string& text, const std::string& where) {
  if (text.empty() || text.size() > 9) throw DefinitionError(where + ": '" + text + "' is not an array size");
  std::size_t n = 0;
  for (char c : text) {
    if (!std::isdigit(static_cast<unsigned char>(c))) throw DefinitionError(where + ": '" + text + "' is not an array size");
    n = n * 10 + static_cast<std::size_t>(c - '0');
  }
  return n;
}

}  // namespace

std::string MessageDefinitions::full_type_name(const std::string& name) {
  const auto first = name.find('/');
  if (first == std::string::npos) return name;
  if (name.find('/', first + 1) != std::string::npos) return name;
  return name.substr(0, first) + "/msg/" + name.substr(first + 1);
}

void MessageDefinitions::add(const std::string& type_name, const std::string& text) {
  // Split on the separator lines: a line of '=' (80 of them by the
  // convention; any run of at least three is accepted) followed by "MSG: name".
  std::istringstream in(text);
  std::string line;
  std::string current = full_type_name(type_name);
  std::string body;
  int line_number = 0, body_start = 1;
  bool expect_msg = false;
  std::set<std::string> seen;
  auto flush = [&]() {
    if (seen.insert(current).second) add_one(current, body, body_start);
    body.clear();
  };
  while (std::getline(in, line)) {
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.size() >= 3 && line.find_first_not_of('=') == std::string::npos) {
      flush();
      expect_msg = true;
      continue;
    }
    if (expect_msg) {
      if (line.find_first_not_of(" \t") == std::string::npos) continue;
      if (line.rfind("MSG:", 0) != 0) {
        throw DefinitionError("definition of " + full_type_name(type_name) + ", line " + std::to_string(line_number) +
                              ": expected 'MSG: package/msg/Type' after the '=' line, found '" + line.substr(0, 80) +
                              "'");
      }
      std::string name = line.substr(4);
      name.erase(0, name.find_first_not_of(" \t"));
      name.erase(name.find_last_not_of(" \t") + 1);
      current = full_type_name(name);
      body_start = line_number + 1;
      expect_msg = false;
      continue;
    }
    body += line;
    body += '\n';
  }
  flush();
}

void MessageDefinitions::add_one(const std::string& type_name, const std::string& text, int first_line) {
  MessageType type;
  type.name = type_name;
  const std::string package = package_of(type_name);
  std::istringstream in(text);
  std::string line;
  int line_number = first_line - 1;
  while (std::getline(in, line)) {
    ++line_number;
    const std::string where = "definition of " + type_name + ", line " + std::to_string(line_number);
    const auto comment = line.find('#');
    // A '#' inside a string constant's value is part of it; constants are dropped anyway.
    std::string code = comment == std::string::npos ? line : line.substr(0, comment);
    code.erase(0, code.find_first_not_of(" \t\r"));
    code.erase(code.find_last_not_of(" \t\r") + 1);
    if (code.empty()) continue;
    const auto space = code.find_first_of(" \t");
    if (space == std::string::npos) throw DefinitionError(where + ": expected 'type name', found '" + code + "'");
    std::string type_text = code.substr(0, space);
    std::string rest = code.substr(space);
    rest.erase(0, rest.find_first_not_of(" \t"));
    std::size_t name_end = 0;
    while (name_end < rest.size() && is_name_char(rest[name_end])) ++name_end;
    const std::string name = rest.substr(0, name_end);
    if (name.empty()) throw DefinitionError(where + ": expected a field name after '" + type_text + "'");
    std::string after = rest.substr(name_end);
    after.erase(0, after.find_first_not_of(" \t"));
    if (!after.empty() && after[0] == '=') continue;  // a constant: not in the encoding

    MessageField field;
    field.name = name;
    const auto bracket = type_text.find('[');
    if (bracket != std::string::npos) {
      if (type_text.back() != ']') throw DefinitionError(where + ": unbalanced '[' in '" + type_text + "'");
      const std::string inside = type_text.substr(bracket + 1, type_text.size() - bracket - 2);
      type_text = type_text.substr(0, bracket);
      if (inside.empty()) {
        field.array = MessageField::Array::kSequence;
      } else if (inside.rfind("<=", 0) == 0) {
        field.array = MessageField::Array::kSequence;
        field.array_size = parse_size(inside.substr(2), where);
      } else {
        field.array = MessageField::Array::kFixed;
        field.array_size = parse_size(inside, where);
      }
    }
    // Bounded strings: "string<=10".
    const auto bound = type_text.find("<=");
    if (bound != std::string::npos) {
      parse_size(type_text.substr(bound + 2), where);
      type_text = type_text.substr(0, bound);
    }
    field.primitive = primitive_of(type_text);
    if (field.primitive == Primitive::kNone) {
      if (type_text == "Header") {
        field.type_name = "std_msgs/msg/Header";
      } else if (type_text == "time") {
        field.type_name = "builtin_interfaces/msg/Time";
      } else if (type_text == "duration") {
        field.type_name = "builtin_interfaces/msg/Duration";
      } else if (type_text.find('/') == std::string::npos) {
        for (char c : type_text) {
          if (!is_name_char(c)) throw DefinitionError(where + ": '" + type_text + "' is not a type name");
        }
        field.type_name = package + "/msg/" + type_text;
      } else {
        field.type_name = full_type_name(type_text);
      }
    }
    type.fields.push_back(std::move(field));
  }
  types_[type_name] = std::move(type);
}

const MessageType& MessageDefinitions::get(const std::string& type_name) const {
  const auto it = types_.find(full_type_name(type_name));
  if (it == types_.end()) throw DefinitionError("no definition of " + full_type_name(type_name));
  return it->second;
}

void MessageDefinitions::check_complete(const std::string& type_name) const {
  std::set<std::string> done;
  std::vector<std::pair<std::string, std::string>> todo = {{full_type_name(type_name), ""}};
  while (!todo.empty()) {
    const auto [name, used_by] = todo.back();
    todo.pop_back();
    if (!done.insert(name).second) continue;
    const auto it = types_.find(name);
    if (it == types_.end()) {
      throw DefinitionError("no definition of " + name + (used_by.empty() ? "" : " (used by " + used_by + ")"));
    }
    for (const MessageField& f : it->second.fields) {
      if (f.primitive == Primitive::kNone) todo.emplace_back(f.type_name, name + "." + f.name);
    }
  }
}

}  // namespace ros
}  // namespace skidimm
