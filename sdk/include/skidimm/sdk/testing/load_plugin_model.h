// Loads a built plugin file and creates a model from it, as skidimm does.
//
// For a plugin author's tests, which then hold the model as skidimm would:
//
//   #include "skidimm/sdk/testing/load_plugin_model.h"
//   auto model = skidimm::sdk::testing::load_plugin_model(MY_PLUGIN_FILE, params);
//   EXPECT_MOTION_MODEL_CONFORMS_OVER(*model, region);
//
// It loads from a private copy (private_library.h), checks the plugin ABI,
// the standard library configuration and every exported symbol, and creates
// the model through the plugin's own factory, so a test exercises exactly the
// code skidimm will run, not a class compiled into the test. The returned
// model keeps its library loaded until the model is gone.
//
// Throws std::runtime_error naming the file and what is wrong (a missing
// file, a missing symbol, another ABI, parameters the plugin rejects).
#ifndef SKIDIMM_SDK_TESTING_LOAD_PLUGIN_MODEL_H_
#define SKIDIMM_SDK_TESTING_LOAD_PLUGIN_MODEL_H_

#include <memory>
#include <stdexcept>
#include <string>

#include "skidimm/sdk/abi.h"
#include "skidimm/sdk/export.h"
#include "skidimm/sdk/motion_model.h"
#include "skidimm/sdk/parameters.h"
#include "skidimm/sdk/plugin_info.h"
#include "skidimm/sdk/private_library.h"

namespace skidimm {
namespace sdk {
namespace testing {

inline std::shared_ptr<MotionModel> load_plugin_model(const std::string& path, const ParameterSet& params) {
  auto refuse = [&path](const std::string& why) { return std::runtime_error("plugin " + path + ": " + why); };
  std::string error;
  std::shared_ptr<boost::dll::shared_library> library = load_private_copy(path, &error);
  if (library == nullptr) throw refuse("cannot load: " + error);
  auto require = [&](const char* symbol) {
    if (!library->has(symbol)) {
      throw refuse(std::string("does not export '") + symbol + "' (was it built with SKIDIMM_EXPORT_MOTION_MODEL?)");
    }
  };
  // The version first: a plugin of another ABI may lack the newer symbols.
  require(kAbiVersionSymbol);
  const int abi = library->get_alias<int()>(kAbiVersionSymbol)();
  if (abi != kAbiVersion) {
    throw refuse("built for plugin ABI " + std::to_string(abi) + ", this SDK is ABI " + std::to_string(kAbiVersion) +
                 ": rebuild it against this SDK");
  }
  for (const char* symbol : {kStdlibAbiTagSymbol, kPluginNameSymbol, kPluginInfoSymbol, kFactorySymbol}) require(symbol);
  const char* tag = library->get_alias<const char*()>(kStdlibAbiTagSymbol)();
  if (tag == nullptr || std::string(tag) != kStdlibAbiTag) {
    throw refuse(std::string("built with the standard library configuration ") + (tag ? tag : "(none)") +
                 ", this test with " + kStdlibAbiTag);
  }
  const PluginInfo* info = library->get_alias<const PluginInfo*()>(kPluginInfoSymbol)();
  if (info == nullptr || info->name == nullptr || info->name[0] == '\0') throw refuse("its PluginInfo has no name");
  MotionModel* raw = library->get_alias<MotionModelFactory>(kFactorySymbol)(params, &error);
  if (raw == nullptr) throw refuse(std::string("'") + info->name + "' rejected its parameters: " + error);
  // The deleter holds the library: the destructor's code stays mapped until it has run.
  return std::shared_ptr<MotionModel>(raw, [library](MotionModel* model) { delete model; });
}

}  // namespace testing
}  // namespace sdk
}  // namespace skidimm

#endif  // SKIDIMM_SDK_TESTING_LOAD_PLUGIN_MODEL_H_
