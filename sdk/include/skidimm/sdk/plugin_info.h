// PluginInfo: what a plugin says about itself, shown by `skidimm plugins`.
//
// Plain C strings and arrays with static storage in the plugin, so reading
// them allocates nothing and needs no cleanup across the boundary.
#ifndef SKIDIMM_SDK_PLUGIN_INFO_H_
#define SKIDIMM_SDK_PLUGIN_INFO_H_

namespace skidimm {
namespace sdk {

// Documents one key a mode's `params:` (or the bank's `shared:`) may hold.
struct ParameterDoc {
  const char* key;          // "A"
  const char* shape;        // "2x2", "scalar"
  const char* description;  // one line, with units
};

struct PluginInfo {
  const char* name;         // the `model:` a bank file uses; unique on the search path
  const char* version;      // the plugin's own version, e.g. "1.0.0"
  const char* description;  // one line
  const ParameterDoc* parameters;
  int num_parameters;
};

}  // namespace sdk
}  // namespace skidimm

#endif  // SKIDIMM_SDK_PLUGIN_INFO_H_
