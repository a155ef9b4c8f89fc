// Fuzzes the MCAP reader (ros/mcap_reader.h): opens the input as a .mcap
// file, reads every message, and decodes each message of a channel whose
// schema is a ros2msg definition with every path the definition offers
// (ros/cdr_field_reader.h), as `skidimm run` on a bag would. Bad input must
// end in a skidimm::Error (a LogError naming the file and record) or one of
// the definition/CDR errors the bag reader turns into one; any other
// exception, a crash, a sanitizer report or a hang is a finding.
#include <cstdio>
#include <map>
#include <memory>

#include "fuzz_input_file.h"
#include "ros/cdr_field_reader.h"
#include "ros/mcap_reader.h"
#include "skidimm/errors.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::filesystem::path file = skidimm_fuzz::input_file(".mcap");
  skidimm_fuzz::write_input(file, data, size);
  try {
    skidimm::ros::McapReader reader(file);
    std::map<std::uint16_t, std::unique_ptr<skidimm::ros::CdrFieldReader>> decoders;
    skidimm::ros::McapMessage message;
    long messages = 0;
    while (reader.next(&message) && ++messages < 100000) {
      auto it = decoders.find(message.channel_id);
      if (it == decoders.end()) {
        std::unique_ptr<skidimm::ros::CdrFieldReader> decoder;
        const auto& channel = reader.channels().at(message.channel_id);
        const auto schema = reader.schemas().find(channel.schema_id);
        if (schema != reader.schemas().end() && schema->second.encoding == "ros2msg") {
          try {
            skidimm::ros::MessageDefinitions definitions;
            definitions.add(schema->second.name, schema->second.data);
            decoder = std::make_unique<skidimm::ros::CdrFieldReader>(definitions, schema->second.name);
            int added = 0;
            for (std::string path : decoder->usable_paths()) {
              const auto range = path.find("[0..");
              if (range != std::string::npos) path = path.substr(0, range) + "[0" + path.substr(path.find(']', range));
              const auto i = path.find("[i]");
              if (i != std::string::npos) path.replace(i, 3, "[1]");
              const auto name = path.find("[NAME]");
              if (name != std::string::npos) path.replace(name, 6, "[left]");
              if (++added > 64) break;
              decoder->add(path);
            }
          } catch (const skidimm::ros::DefinitionError&) {
            decoder.reset();
          } catch (const skidimm::ros::FieldPathError&) {
            decoder.reset();
          }
        }
        it = decoders.emplace(message.channel_id, std::move(decoder)).first;
      }
      if (it->second) {
        try {
          it->second->decode(message.data, message.size);
        } catch (const skidimm::ros::CdrError&) {
        }
      }
    }
  } catch (const skidimm::Error&) {
  }
  return 0;
}
