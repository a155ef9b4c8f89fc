// The binary contract between skidimm and its motion-model plugins.
//
// Boost.DLL promises no ABI stability, and a plugin compiled against one
// layout of MotionModel, ParameterSet or PluginInfo must never be called
// through another. Every plugin therefore exports the ABI version it was built
// with, and the loader compares it with its own before touching any other
// symbol. Bump kAbiVersion whenever a class or struct that crosses the
// boundary changes layout or gains, loses or reorders a virtual function.
#ifndef SKIDIMM_SDK_ABI_H_
#define SKIDIMM_SDK_ABI_H_

namespace skidimm {
namespace sdk {

// 2: MotionModel::parameter_jacobian() added.
// 3: ParameterSet carries text parameters and the bank's state/input names.
inline constexpr int kAbiVersion = 3;

// Names of the symbols SKIDIMM_EXPORT_MOTION_MODEL exports.
// The ABI version and the plugin name are plain C types, readable even from a
// plugin built against another ABI, so the loader can say which plugin is stale.
inline constexpr char kAbiVersionSymbol[] = "skidimm_abi_version";       // int()
inline constexpr char kPluginNameSymbol[] = "skidimm_plugin_name";       // const char*()
inline constexpr char kPluginInfoSymbol[] = "skidimm_plugin_info";       // const PluginInfo*()
inline constexpr char kFactorySymbol[] = "skidimm_create_motion_model";  // MotionModelFactory

}  // namespace sdk
}  // namespace skidimm

#endif  // SKIDIMM_SDK_ABI_H_
