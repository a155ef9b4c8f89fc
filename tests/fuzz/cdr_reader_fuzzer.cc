// Fuzzes the CDR decoder and the message definition parser
// (ros/cdr_field_reader.h, ros/message_definition.h). The first byte picks
// what the rest is:
//   0-7:  a serialized message of a bundled type (Imu, JointState, Odometry,
//         TwistStamped, NavSatFix, Float64MultiArray, Empty, String),
//         decoded with every path the type offers, elements by index and by
//         name included;
//   else: a message definition text, parsed, checked and, when it is
//         complete, used to decode an empty and a short message.
// Bad input must end in a CdrError, DefinitionError or FieldPathError; any
// other exception, a crash, a sanitizer report or a hang is a finding.
#include <memory>
#include <string>
#include <vector>

#include "ros/bundled_message_definitions.h"
#include "ros/cdr_field_reader.h"

namespace {

using skidimm::ros::CdrFieldReader;

void add_every_path(CdrFieldReader* reader) {
  int added = 0;
  for (std::string path : reader->usable_paths()) {
    if (++added > 64) return;
    const auto range = path.find("[0..");
    if (range != std::string::npos) {
      const std::string head = path.substr(0, range), tail = path.substr(path.find(']', range) + 1);
      reader->add(head + "[0]" + tail);
      reader->add(head + "[2]" + tail);
      continue;
    }
    for (const char* index : {"[0]", "[3]"}) {
      std::string p = path;
      const auto i = p.find("[i]");
      if (i == std::string::npos) break;
      reader->add(p.replace(i, 3, index));
    }
    if (path.find("[i]") != std::string::npos) continue;
    const auto name = path.find("[NAME]");
    if (name != std::string::npos) {
      std::string p = path;
      reader->add(p.replace(name, 6, "[left]"));
      continue;
    }
    reader->add(path);
  }
}

struct Decoders {
  std::vector<std::unique_ptr<CdrFieldReader>> readers;
  Decoders() {
    skidimm::ros::MessageDefinitions definitions;
    skidimm::ros::add_bundled_definitions(&definitions);
    for (const char* type : {"sensor_msgs/msg/Imu", "sensor_msgs/msg/JointState", "nav_msgs/msg/Odometry",
                             "geometry_msgs/msg/TwistStamped", "sensor_msgs/msg/NavSatFix",
                             "std_msgs/msg/Float64MultiArray", "std_msgs/msg/Empty", "std_msgs/msg/String"}) {
      readers.push_back(std::make_unique<CdrFieldReader>(definitions, type));
      add_every_path(readers.back().get());
    }
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static Decoders decoders;
  if (size == 0) return 0;
  const std::uint8_t which = data[0];
  try {
    if (which < decoders.readers.size()) {
      decoders.readers[which]->decode(data + 1, size - 1);
      return 0;
    }
    skidimm::ros::MessageDefinitions definitions;
    const std::string text(reinterpret_cast<const char*>(data + 1), size - 1);
    definitions.add("fuzz/msg/Root", text);
    definitions.check_complete("fuzz/msg/Root");
    CdrFieldReader reader(definitions, "fuzz/msg/Root");
    add_every_path(&reader);
    const std::uint8_t message[] = {0, 1, 0, 0, 3, 0, 0, 0, 'a', 'b', 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0xf0, 0x3f};
    for (std::size_t n : {std::size_t{4}, sizeof(message)}) {
      try {
        reader.decode(message, n);
      } catch (const skidimm::ros::CdrError&) {
      }
    }
  } catch (const skidimm::ros::CdrError&) {
  } catch (const skidimm::ros::DefinitionError&) {
  } catch (const skidimm::ros::FieldPathError&) {
  }
  return 0;
}
