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
  const char* description;  // one line, with units; ends with kBankLevelDoc for a `shared:` parameter
};

// How a ParameterDoc's description ends when the parameter is one value for
// the whole bank (ParameterScope::kBank): the bank loader reads it to tell a
// user who wrote the parameter nowhere that it belongs under `shared:`, before
// any model exists to ask. Function models write it themselves.
constexpr const char* kBankLevelDoc = "bank-level (shared:)";

// Documents one state or input component of the model.
struct VariableDoc {
  const char* name;         // "theta": the name the bank's `states:` or `inputs:` must use
  const char* description;  // one line, with units
  bool is_angle;            // wraps at +-pi (MotionModel::is_angle); false for inputs
};

struct PluginInfo {
  const char* name;         // the `model:` a bank file uses; unique on the search path
  const char* version;      // the plugin's own version, e.g. "1.0.0"
  const char* description;  // one line
  const ParameterDoc* parameters;
  int num_parameters;
  // The states and inputs every model of the plugin has, in order. A plugin
  // whose models take the bank's own states or inputs (ParameterSet's bank
  // names) leaves them null with a count of 0. When given, the loader checks
  // that each created model reports exactly these.
  const VariableDoc* states;
  int num_states;
  const VariableDoc* inputs;
  int num_inputs;
  // The outputs every model of the plugin predicts (MotionModel::outputs()),
  // which a bank may measure; none by default. When given, the loader checks
  // that each created model reports exactly these.
  const VariableDoc* outputs = nullptr;
  int num_outputs = 0;
};

}  // namespace sdk
}  // namespace skidimm

#endif  // SKIDIMM_SDK_PLUGIN_INFO_H_
