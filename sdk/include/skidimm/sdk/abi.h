// The binary contract between skidimm and its motion-model plugins.
//
// Boost.DLL promises no ABI stability, and a plugin compiled against one
// layout of MotionModel, ParameterSet or PluginInfo must never be called
// through another. Every plugin therefore exports the ABI version it was built
// with, and the loader compares it with its own before touching any other
// symbol. Bump kAbiVersion whenever a class or struct that crosses the
// boundary changes layout or gains, loses or reorders a virtual function.
//
// The same version compiled with another standard library configuration is
// another ABI too: std::string, std::vector and friends (inside ParameterSet,
// ParameterInfo, the names a model returns) change layout with libstdc++'s
// _GLIBCXX_USE_CXX11_ABI and _GLIBCXX_DEBUG, or with libc++. Every plugin
// therefore also exports kStdlibAbiTag as it saw it, and the loader refuses a
// plugin whose tag differs from its own, before any std:: type crosses.
// (_GLIBCXX_ASSERTIONS alone changes no layout and is not part of the tag.)
#ifndef SKIDIMM_SDK_ABI_H_
#define SKIDIMM_SDK_ABI_H_

#include <cstddef>  // defines the standard library's configuration macros

namespace skidimm {
namespace sdk {

// 2: MotionModel::parameter_jacobian() added.
// 3: ParameterSet carries text parameters and the bank's state/input names.
// 4: MotionModel::failure_reason(); PluginInfo names states and inputs;
//    plugins export their standard library configuration (kStdlibAbiTagSymbol).
// 5: MotionModel::output_names(), outputs() and output_parameter_jacobian().
// 6: MotionModel::jacobian_and_noise_depend_only_on_dt().
// 7: MotionModel::parameter_jacobian_rows() and parameter_jacobian_entries().
inline constexpr int kAbiVersion = 7;

#define SKIDIMM_SDK_STRINGIFY_(x) #x
#define SKIDIMM_SDK_STRINGIFY(x) SKIDIMM_SDK_STRINGIFY_(x)
#if defined(_LIBCPP_VERSION)
#define SKIDIMM_SDK_STDLIB_TAG "libc++ _LIBCPP_ABI_VERSION=" SKIDIMM_SDK_STRINGIFY(_LIBCPP_ABI_VERSION)
#elif defined(__GLIBCXX__)
#if defined(_GLIBCXX_DEBUG)
#define SKIDIMM_SDK_STDLIB_DEBUG_TAG " _GLIBCXX_DEBUG=1"
#else
#define SKIDIMM_SDK_STDLIB_DEBUG_TAG " _GLIBCXX_DEBUG=0"
#endif
#define SKIDIMM_SDK_STDLIB_TAG \
  "libstdc++ _GLIBCXX_USE_CXX11_ABI=" SKIDIMM_SDK_STRINGIFY(_GLIBCXX_USE_CXX11_ABI) SKIDIMM_SDK_STDLIB_DEBUG_TAG
#else
#define SKIDIMM_SDK_STDLIB_TAG "unknown standard library"
#endif

// The standard library configuration this translation unit is compiled with,
// e.g. "libstdc++ _GLIBCXX_USE_CXX11_ABI=1 _GLIBCXX_DEBUG=0".
inline constexpr char kStdlibAbiTag[] = SKIDIMM_SDK_STDLIB_TAG;

// Names of the symbols SKIDIMM_EXPORT_MOTION_MODEL exports.
// The ABI version and the plugin name are plain C types, readable even from a
// plugin built against another ABI, so the loader can say which plugin is stale.
inline constexpr char kAbiVersionSymbol[] = "skidimm_abi_version";       // int()
inline constexpr char kPluginNameSymbol[] = "skidimm_plugin_name";       // const char*()
inline constexpr char kPluginInfoSymbol[] = "skidimm_plugin_info";       // const PluginInfo*()
inline constexpr char kFactorySymbol[] = "skidimm_create_motion_model";  // MotionModelFactory
inline constexpr char kStdlibAbiTagSymbol[] = "skidimm_stdlib_abi";      // const char*(), kStdlibAbiTag

}  // namespace sdk
}  // namespace skidimm

#endif  // SKIDIMM_SDK_ABI_H_
