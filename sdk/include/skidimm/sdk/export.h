// SKIDIMM_EXPORT_MOTION_MODEL: makes a shared library a skidimm plugin.
//
// Write it once, in one .cc file of the plugin, at global scope:
//
//   SKIDIMM_EXPORT_MOTION_MODEL(MyModel, kMyModelInfo)
//
// where `kMyModelInfo` is a skidimm::sdk::PluginInfo with static storage and
// MyModel has
//
//   static std::unique_ptr<MyModel> Create(const skidimm::sdk::ParameterSet& params,
//                                          std::string* error);
//
// returning nullptr (with *error set) when the parameters are invalid.
//
// The macro exports, through BOOST_DLL_ALIAS, the five symbols named in abi.h.
// The generated factory catches every exception: nothing is thrown across the
// boundary. One plugin library holds one model.
#ifndef SKIDIMM_SDK_EXPORT_H_
#define SKIDIMM_SDK_EXPORT_H_

#include <boost/dll/alias.hpp>
#include <exception>
#include <memory>
#include <string>

#include "skidimm/sdk/abi.h"
#include "skidimm/sdk/motion_model.h"
#include "skidimm/sdk/parameters.h"
#include "skidimm/sdk/plugin_info.h"

namespace skidimm {
namespace sdk {

// The factory's type, as the loader imports it. Returns an object the caller
// owns and deletes (the destructor is virtual, so it runs the plugin's code),
// or nullptr with *error explaining why.
using MotionModelFactory = MotionModel*(const ParameterSet& params, std::string* error);

namespace internal {

template <typename Model>
MotionModel* create_model(const ParameterSet& params, std::string* error) noexcept {
  try {
    std::string message;
    std::unique_ptr<Model> model = Model::Create(params, &message);
    if (!model) {
      if (error != nullptr) *error = message.empty() ? "the plugin rejected its parameters" : message;
      return nullptr;
    }
    return model.release();
  } catch (const std::exception& e) {
    if (error != nullptr) *error = std::string("the plugin's factory threw: ") + e.what();
  } catch (...) {
    if (error != nullptr) *error = "the plugin's factory threw an unknown exception";
  }
  return nullptr;
}

}  // namespace internal
}  // namespace sdk
}  // namespace skidimm

#define SKIDIMM_EXPORT_MOTION_MODEL(ModelClass, plugin_info)                                                     \
  namespace skidimm_plugin_exports {                                                                             \
  int abi_version() noexcept { return ::skidimm::sdk::kAbiVersion; }                                             \
  const char* plugin_name() noexcept { return (plugin_info).name; }                                              \
  const char* stdlib_abi() noexcept { return ::skidimm::sdk::kStdlibAbiTag; }                                    \
  const ::skidimm::sdk::PluginInfo* info() noexcept { return &(plugin_info); }                                   \
  ::skidimm::sdk::MotionModel* create(const ::skidimm::sdk::ParameterSet& params, std::string* error) noexcept { \
    return ::skidimm::sdk::internal::create_model<ModelClass>(params, error);                                    \
  }                                                                                                              \
  }                                                                                                              \
  BOOST_DLL_ALIAS(skidimm_plugin_exports::abi_version, skidimm_abi_version)                                      \
  BOOST_DLL_ALIAS(skidimm_plugin_exports::plugin_name, skidimm_plugin_name)                                      \
  BOOST_DLL_ALIAS(skidimm_plugin_exports::stdlib_abi, skidimm_stdlib_abi)                                        \
  BOOST_DLL_ALIAS(skidimm_plugin_exports::info, skidimm_plugin_info)                                             \
  BOOST_DLL_ALIAS(skidimm_plugin_exports::create, skidimm_create_motion_model)

#endif  // SKIDIMM_SDK_EXPORT_H_
