#include "cdr_field_reader.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "not_a_number.h"
#include "ros_time.h"

namespace skidimm {
namespace ros {

namespace {

using ::skidimm::internal::kNaN;
constexpr int kMaxDepth = 64;  // nesting of message types: real ones stay under 10

bool is_time_type(const std::string& name) {
  return name == "builtin_interfaces/msg/Time" || name == "builtin_interfaces/msg/Duration";
}

bool parse_index(const std::string& text, std::size_t* index) {
  if (text.empty() || text.size() > 9) return false;
  std::size_t n = 0;
  for (char c : text) {
    if (c < '0' || c > '9') return false;
    n = n * 10 + static_cast<std::size_t>(c - '0');
  }
  *index = n;
  return true;
}

}  // namespace

struct CdrFieldReader::Field {
  std::string name;
  Primitive primitive = Primitive::kNone;
  int type = -1;  // index into types_ when primitive is kNone
  MessageField::Array array = MessageField::Array::kNone;
  std::size_t array_size = 0;
};

struct CdrFieldReader::Type {
  std::string name;
  std::vector<Field> fields;
  bool is_time = false;
  int name_field = -1;  // a `string[] name` field, for velocity[NAME]
};

// What one path asks of an element or a field: a value, or fields below it.
struct CdrFieldReader::Target {
  int slot = -1;
  std::unique_ptr<StructPlan> child;
};

struct CdrFieldReader::FieldPlan {
  Target whole;  // the field itself (not an element of it)
  std::vector<std::pair<std::size_t, Target>> by_index;
  std::vector<std::pair<std::string, Target>> by_key;
};

struct CdrFieldReader::Deferred {
  const FieldPlan* plan;
  Primitive primitive;
  std::size_t start;
  std::size_t count;
};

struct CdrFieldReader::StructPlan {
  std::vector<std::unique_ptr<FieldPlan>> fields;  // per field of the type; null: skipped
  bool needs_names = false;
};

// Reads CDR from a message: alignment relative to the end of the
// encapsulation header, byte order from it.
struct CdrFieldReader::Cursor {
  const std::uint8_t* data;
  std::size_t size;
  std::size_t position = 4;
  bool swap = false;

  [[noreturn]] void short_of(std::size_t n, const char* what) const {
    throw CdrError("the message ends at byte " + std::to_string(size) + ", but " + what + " needs " +
                   std::to_string(n) + " more from byte " + std::to_string(position));
  }
  void align(std::size_t n) {
    const std::size_t offset = position - 4;
    const std::size_t pad = (n - offset % n) % n;
    if (pad > size - position) short_of(pad, "alignment");
    position += pad;
  }
  void need(std::size_t n, const char* what) const {
    if (n > size - position) short_of(n, what);
  }
  std::uint32_t u32(const char* what) {
    align(4);
    need(4, what);
    std::uint32_t v;
    std::memcpy(&v, data + position, 4);
    if (swap) v = __builtin_bswap32(v);
    position += 4;
    return v;
  }
  double number(Primitive p, const std::uint8_t* at) const {
    switch (p) {
      case Primitive::kBool:
        return at[0] != 0 ? 1.0 : 0.0;
      case Primitive::kByte:
      case Primitive::kUint8:
      case Primitive::kChar:
        return static_cast<double>(at[0]);
      case Primitive::kInt8:
        return static_cast<double>(static_cast<std::int8_t>(at[0]));
      case Primitive::kInt16:
      case Primitive::kUint16: {
        std::uint16_t v;
        std::memcpy(&v, at, 2);
        if (swap) v = __builtin_bswap16(v);
        return p == Primitive::kInt16 ? static_cast<double>(static_cast<std::int16_t>(v)) : static_cast<double>(v);
      }
      case Primitive::kInt32:
      case Primitive::kUint32:
      case Primitive::kFloat32: {
        std::uint32_t v;
        std::memcpy(&v, at, 4);
        if (swap) v = __builtin_bswap32(v);
        if (p == Primitive::kFloat32) {
          float f;
          std::memcpy(&f, &v, 4);
          return static_cast<double>(f);
        }
        return p == Primitive::kInt32 ? static_cast<double>(static_cast<std::int32_t>(v)) : static_cast<double>(v);
      }
      case Primitive::kInt64:
      case Primitive::kUint64:
      case Primitive::kFloat64: {
        std::uint64_t v;
        std::memcpy(&v, at, 8);
        if (swap) v = __builtin_bswap64(v);
        if (p == Primitive::kFloat64) {
          double d;
          std::memcpy(&d, &v, 8);
          return d;
        }
        return p == Primitive::kInt64 ? static_cast<double>(static_cast<std::int64_t>(v)) : static_cast<double>(v);
      }
      default:
        return kNaN;
    }
  }
  // A primitive's bytes, aligned, as a pointer into the message.
  const std::uint8_t* primitive(Primitive p) {
    const std::size_t n = primitive_size(p);
    align(n);
    need(n, primitive_name(p));
    const std::uint8_t* at = data + position;
    position += n;
    return at;
  }
  std::string_view string() {
    const std::uint32_t length = u32("a string's length");
    need(length, "a string");
    const char* begin = reinterpret_cast<const char*>(data + position);
    position += length;
    // The length counts a terminating NUL.
    return std::string_view(begin, length > 0 && begin[length - 1] == '\0' ? length - 1 : length);
  }
};

CdrFieldReader::CdrFieldReader(const MessageDefinitions& definitions, const std::string& type_name)
    : type_name_(MessageDefinitions::full_type_name(type_name)), plan_(std::make_unique<StructPlan>()) {
  std::vector<std::string> stack;
  resolve(definitions, type_name_, &stack);
  plan_->fields.resize(types_[0].fields.size());
}

CdrFieldReader::~CdrFieldReader() = default;

int CdrFieldReader::resolve(const MessageDefinitions& definitions, const std::string& name,
                            std::vector<std::string>* stack) {
  for (std::size_t i = 0; i < types_.size(); ++i) {
    if (types_[i].name == name) return static_cast<int>(i);
  }
  if (std::find(stack->begin(), stack->end(), name) != stack->end()) {
    throw DefinitionError(name + " contains itself (through " + stack->back() + "), which CDR cannot encode");
  }
  if (static_cast<int>(stack->size()) > kMaxDepth) {
    throw DefinitionError(name + ": message types nested more than " + std::to_string(kMaxDepth) + " deep");
  }
  const MessageType& definition = definitions.get(name);  // throws for an undefined type
  stack->push_back(name);
  Type type;
  type.name = name;
  type.is_time = is_time_type(name);
  for (const MessageField& f : definition.fields) {
    Field field;
    field.name = f.name;
    field.primitive = f.primitive;
    field.array = f.array;
    field.array_size = f.array_size;
    if (f.primitive == Primitive::kWstring) {
      throw DefinitionError(name + "." + f.name + " is a wstring, which skidimm does not read");
    }
    if (f.primitive == Primitive::kNone) {
      // A sequence may hold its own type (a tree); a plain field may not.
      if (f.array == MessageField::Array::kSequence && f.type_name == name) {
        throw DefinitionError(name + "." + f.name + ": a sequence of its own type is not supported");
      }
      field.type = resolve(definitions, f.type_name, stack);
    }
    if (f.name == "name" && f.primitive == Primitive::kString && f.array == MessageField::Array::kSequence) {
      type.name_field = static_cast<int>(type.fields.size());
    }
    type.fields.push_back(std::move(field));
  }
  // An empty message is one uint8 in CDR (rosidl's structure_needs_at_least_one_member).
  if (type.fields.empty()) {
    Field dummy;
    dummy.name = "structure_needs_at_least_one_member";
    dummy.primitive = Primitive::kUint8;
    type.fields.push_back(dummy);
  }
  stack->pop_back();
  // Children were resolved first; this type goes after them, except the root at 0.
  if (stack->empty()) {
    types_.insert(types_.begin(), std::move(type));
    // Indices of the others moved by one.
    for (std::size_t i = 1; i < types_.size(); ++i) {
      for (Field& f : types_[i].fields) {
        if (f.type >= 0) ++f.type;
      }
    }
    for (Field& f : types_[0].fields) {
      if (f.type >= 0) ++f.type;
    }
    return 0;
  }
  types_.push_back(std::move(type));
  return static_cast<int>(types_.size()) - 1;
}

bool CdrFieldReader::has(const std::string& path) const {
  try {
    return const_cast<CdrFieldReader*>(this)->add_path(path, /*dry_run=*/true) >= 0;
  } catch (const FieldPathError&) {
    return false;
  }
}

int CdrFieldReader::add(const std::string& path) {
  for (std::size_t i = 0; i < paths_.size(); ++i) {
    if (paths_[i] == path) return static_cast<int>(i);
  }
  return add_path(path, /*dry_run=*/false);
}

int CdrFieldReader::add_path(const std::string& path, bool dry_run) {
  auto fail = [&](const std::string& why) -> int {
    throw FieldPathError(type_name_ + " has no field '" + path + "': " + why, usable_paths());
  };
  int type = 0;
  StructPlan* plan = plan_.get();
  std::size_t i = 0;
  bool text = false;
  Target* target = nullptr;
  std::vector<std::unique_ptr<FieldPlan>> scratch;  // a dry run's plans, kept until it ends
  while (true) {
    // One segment: name, then an optional [index or key].
    std::size_t end = i;
    while (end < path.size() && path[end] != '.' && path[end] != '[') ++end;
    const std::string name = path.substr(i, end - i);
    if (name.empty()) return fail("an empty field name at character " + std::to_string(i + 1));
    const Type& t = types_[static_cast<std::size_t>(type)];
    int field_index = -1;
    for (std::size_t k = 0; k < t.fields.size(); ++k) {
      if (t.fields[k].name == name) field_index = static_cast<int>(k);
    }
    if (field_index < 0) {
      // At the top, the type fail() names already: its own words would say it twice.
      return fail(type == 0 ? "no field '" + name + "'" : t.name + " has no field '" + name + "'");
    }
    const Field& field = t.fields[static_cast<std::size_t>(field_index)];
    FieldPlan* field_plan = nullptr;
    if (dry_run) {
      scratch.push_back(std::make_unique<FieldPlan>());
      field_plan = scratch.back().get();
    } else {
      auto& slot = plan->fields[static_cast<std::size_t>(field_index)];
      if (!slot) slot = std::make_unique<FieldPlan>();
      field_plan = slot.get();
    }
    i = end;
    if (i < path.size() && path[i] == '[') {
      const auto close = path.find(']', i);
      if (close == std::string::npos) return fail("'[' without ']'");
      const std::string inside = path.substr(i + 1, close - i - 1);
      i = close + 1;
      if (field.array == MessageField::Array::kNone) return fail(t.name + "." + name + " is not an array");
      std::size_t index = 0;
      if (parse_index(inside, &index)) {
        if (field.array == MessageField::Array::kFixed && index >= field.array_size) {
          return fail(t.name + "." + name + " has " + std::to_string(field.array_size) + " elements");
        }
        auto it = std::find_if(field_plan->by_index.begin(), field_plan->by_index.end(),
                               [&](const auto& e) { return e.first == index; });
        if (it == field_plan->by_index.end()) {
          field_plan->by_index.emplace_back(index, Target{});
          it = field_plan->by_index.end() - 1;
        }
        target = &it->second;
      } else {
        if (inside.empty()) return fail("an empty [] (an index or a name is needed)");
        if (t.name_field < 0 || field.primitive == Primitive::kNone) {
          return fail("[" + inside + "] selects by name, which needs a sequence of numbers beside a `string[] name` "
                      "field in the same message (as in sensor_msgs/msg/JointState); " + t.name + "." + name +
                      " is not one: use an index");
        }
        auto it = std::find_if(field_plan->by_key.begin(), field_plan->by_key.end(),
                               [&](const auto& e) { return e.first == inside; });
        if (it == field_plan->by_key.end()) {
          field_plan->by_key.emplace_back(inside, Target{});
          it = field_plan->by_key.end() - 1;
        }
        target = &it->second;
        if (!dry_run) plan->needs_names = true;
      }
    } else {
      if (field.array != MessageField::Array::kNone) {
        return fail(t.name + "." + name + " is an array: name an element, " + name + "[0] or " + name +
                    (t.name_field >= 0 && field.primitive != Primitive::kNone ? "[NAME]" : "[i]"));
      }
      target = &field_plan->whole;
    }
    if (i >= path.size()) {
      // The end of the path: a value.
      if (field.primitive == Primitive::kNone) {
        const Type& child = types_[static_cast<std::size_t>(field.type)];
        if (!child.is_time) {
          return fail(path + " is a " + child.name + "; name one of its fields (" + path + "." +
                      child.fields.front().name + ", ...)");
        }
      }
      text = field.primitive == Primitive::kString;
      break;
    }
    if (path[i] != '.') return fail("expected '.' after ']' at character " + std::to_string(i + 1));
    ++i;
    if (field.primitive != Primitive::kNone) return fail(t.name + "." + name + " is a " + primitive_name(field.primitive) + ", it has no fields");
    type = field.type;
    if (!target->child) {
      target->child = std::make_unique<StructPlan>();
      target->child->fields.resize(types_[static_cast<std::size_t>(type)].fields.size());
    }
    plan = target->child.get();
  }
  if (dry_run) return 0;
  if (target->slot < 0) {
    target->slot = static_cast<int>(paths_.size());
    paths_.push_back(path);
    slot_is_text_.push_back(text);
    values_.push_back(kNaN);
    texts_.emplace_back();
    found_.push_back(0);
  }
  return target->slot;
}

void CdrFieldReader::decode(const std::uint8_t* data, std::size_t size) {
  std::fill(values_.begin(), values_.end(), kNaN);
  std::fill(found_.begin(), found_.end(), 0);
  for (std::string& t : texts_) t.clear();
  if (size < 4) throw CdrError("a message of " + std::to_string(size) + " bytes, shorter than CDR's 4-byte header");
  // Encapsulation: representation identifier (big-endian 16 bits), options.
  const unsigned representation = (static_cast<unsigned>(data[0]) << 8) | data[1];
  Cursor c{data, size};
  if (representation == 0x0001) {
    c.swap = false;
  } else if (representation == 0x0000) {
    c.swap = true;
  } else {
    throw CdrError("CDR encapsulation 0x" + std::string(1, "0123456789abcdef"[(representation >> 12) & 15]) +
                   std::string(1, "0123456789abcdef"[(representation >> 8) & 15]) +
                   std::string(1, "0123456789abcdef"[(representation >> 4) & 15]) +
                   std::string(1, "0123456789abcdef"[representation & 15]) +
                   ", not plain CDR (0x0000 big-endian or 0x0001 little-endian, what ROS 2 writes)");
  }
  walk(0, plan_.get(), c, 0);
}

void CdrFieldReader::walk(int type_index, const StructPlan* plan, Cursor& c, int depth) {
  if (depth > kMaxDepth) throw CdrError("message types nested more than " + std::to_string(kMaxDepth) + " deep");
  const Type& type = types_[static_cast<std::size_t>(type_index)];
  // Sequences selected by name wait for the names, which may come later.
  const std::size_t deferred_begin = deferred_scratch_.size();
  const std::size_t names_begin = names_scratch_.size();
  std::size_t names_count = 0;
  const bool capture_names = plan != nullptr && plan->needs_names;

  for (std::size_t f = 0; f < type.fields.size(); ++f) {
    const Field& field = type.fields[f];
    const FieldPlan* fp = plan != nullptr ? plan->fields[f].get() : nullptr;
    if (field.array == MessageField::Array::kNone) {
      if (field.primitive == Primitive::kString) {
        const std::string_view s = c.string();
        if (fp && fp->whole.slot >= 0) set_text(fp->whole.slot, s);
      } else if (field.primitive != Primitive::kNone) {
        const std::uint8_t* at = c.primitive(field.primitive);
        if (fp && fp->whole.slot >= 0) set_value(fp->whole.slot, c.number(field.primitive, at));
      } else {
        const Type& child = types_[static_cast<std::size_t>(field.type)];
        if (child.is_time && fp && fp->whole.slot >= 0) {
          const std::int32_t sec = static_cast<std::int32_t>(c.u32("a time's seconds"));
          const std::uint32_t nanosec = c.u32("a time's nanoseconds");
          set_value(fp->whole.slot, seconds_from_stamp(sec, nanosec));
        } else {
          walk(field.type, fp ? fp->whole.child.get() : nullptr, c, depth + 1);
        }
      }
      continue;
    }
    const std::size_t count =
        field.array == MessageField::Array::kFixed ? field.array_size : c.u32("a sequence's length");
    if (field.primitive != Primitive::kNone && field.primitive != Primitive::kString) {
      const std::size_t size = primitive_size(field.primitive);
      if (count > 0) c.align(size);
      if (count > (c.size - c.position) / size) c.short_of(count * size, "an array");
      const std::size_t start = c.position;
      if (fp) {
        for (const auto& [index, target] : fp->by_index) {
          if (index < count && target.slot >= 0) {
            set_value(target.slot, c.number(field.primitive, c.data + start + index * size));
          }
        }
        if (!fp->by_key.empty()) deferred_scratch_.push_back(Deferred{fp, field.primitive, start, count});
      }
      c.position += count * size;
      continue;
    }
    // Strings and messages: one at a time. Each takes at least one byte.
    if (count > c.size - c.position) c.short_of(count, "a sequence");
    const bool names_here = capture_names && static_cast<int>(f) == type.name_field;
    for (std::size_t k = 0; k < count; ++k) {
      const Target* target = nullptr;
      if (fp) {
        for (const auto& [index, t] : fp->by_index) {
          if (index == k) target = &t;
        }
      }
      if (field.primitive == Primitive::kString) {
        const std::string_view s = c.string();
        if (target && target->slot >= 0) set_text(target->slot, s);
        if (names_here) {
          names_scratch_.push_back(s);
          ++names_count;
        }
      } else {
        const Type& child = types_[static_cast<std::size_t>(field.type)];
        if (child.is_time && target && target->slot >= 0) {
          const std::int32_t sec = static_cast<std::int32_t>(c.u32("a time's seconds"));
          const std::uint32_t nanosec = c.u32("a time's nanoseconds");
          set_value(target->slot, seconds_from_stamp(sec, nanosec));
        } else {
          walk(field.type, target ? target->child.get() : nullptr, c, depth + 1);
        }
      }
    }
  }
  for (std::size_t d = deferred_begin; d < deferred_scratch_.size(); ++d) {
    const Deferred& e = deferred_scratch_[d];
    const std::size_t size = primitive_size(e.primitive);
    for (const auto& [key, target] : e.plan->by_key) {
      for (std::size_t k = 0; k < names_count && k < e.count; ++k) {
        if (names_scratch_[names_begin + k] == key) {
          set_value(target.slot, c.number(e.primitive, c.data + e.start + k * size));
          break;
        }
      }
    }
  }
  names_scratch_.resize(names_begin);
  deferred_scratch_.resize(deferred_begin);
}

void CdrFieldReader::list_paths(int type_index, const std::string& prefix, int depth,
                                std::vector<std::string>* out) const {
  if (depth > 8 || out->size() > 400) return;
  const Type& type = types_[static_cast<std::size_t>(type_index)];
  for (const Field& f : type.fields) {
    if (f.name == "structure_needs_at_least_one_member") continue;
    const std::string path = prefix + f.name;
    std::string element;
    if (f.array == MessageField::Array::kFixed) {
      element = path + "[0.." + std::to_string(f.array_size == 0 ? 0 : f.array_size - 1) + "]";
    } else if (f.array == MessageField::Array::kSequence) {
      element = path + "[i]";
    }
    if (f.primitive != Primitive::kNone) {
      if (f.array == MessageField::Array::kNone) {
        out->push_back(path);
      } else {
        out->push_back(element);
        if (f.array == MessageField::Array::kSequence && type.name_field >= 0 && f.primitive != Primitive::kString) {
          out->push_back(path + "[NAME]");
        }
      }
      continue;
    }
    const Type& child = types_[static_cast<std::size_t>(f.type)];
    if (child.is_time) {
      out->push_back(f.array == MessageField::Array::kNone ? path : element);
      continue;
    }
    list_paths(f.type, (f.array == MessageField::Array::kNone ? path : element) + ".", depth + 1, out);
  }
}

std::vector<std::string> CdrFieldReader::usable_paths() const {
  std::vector<std::string> out;
  list_paths(0, "", 0, &out);
  return out;
}

bool CdrFieldReader::has_header_stamp() const { return has("header.stamp"); }

}  // namespace ros
}  // namespace skidimm
