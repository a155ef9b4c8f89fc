// Plugin lifecycle check: load the plugin file, create a model, predict,
// destroy it, unload the library, and do it again.
//
//   EXPECT_PLUGIN_SURVIVES_RELOAD("build/my_model.so", params, x, u, dt);
//
// It catches what only shows across a real dlopen/dlclose: a missing or stale
// export, a factory that fails, static state that does not survive a reload,
// and (with -fno-gnu-unique, which skidimm_add_motion_model sets) destructors
// or deleters that run after their code is unmapped, which crash here instead
// of in a user's robot. Each cycle must predict the same x_next.
#ifndef SKIDIMM_SDK_TESTING_PLUGIN_LIFECYCLE_H_
#define SKIDIMM_SDK_TESTING_PLUGIN_LIFECYCLE_H_

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <boost/dll/shared_library.hpp>
#include <exception>
#include <string>

#include "skidimm/sdk/abi.h"
#include "skidimm/sdk/export.h"
#include "skidimm/sdk/plugin_info.h"

namespace skidimm {
namespace sdk {
namespace testing {

inline ::testing::AssertionResult PluginSurvivesReload(const std::string& path, const ParameterSet& params,
                                                       const Eigen::VectorXd& x, const Eigen::VectorXd& u, double dt,
                                                       int cycles = 3) {
  Eigen::VectorXd first;
  for (int cycle = 0; cycle < cycles; ++cycle) {
    boost::dll::shared_library library;
    try {
      library.load(path, boost::dll::load_mode::rtld_now | boost::dll::load_mode::rtld_local);
    } catch (const std::exception& e) {
      return ::testing::AssertionFailure() << "cannot load " << path << ": " << e.what();
    }
    for (const char* symbol :
         {kAbiVersionSymbol, kStdlibAbiTagSymbol, kPluginNameSymbol, kPluginInfoSymbol, kFactorySymbol}) {
      if (!library.has(symbol)) return ::testing::AssertionFailure() << path << " does not export " << symbol;
    }
    const int abi = library.get_alias<int()>(kAbiVersionSymbol)();
    if (abi != kAbiVersion) {
      return ::testing::AssertionFailure()
             << path << " was built for ABI " << abi << ", the SDK is ABI " << kAbiVersion;
    }
    const char* tag = library.get_alias<const char*()>(kStdlibAbiTagSymbol)();
    if (tag == nullptr || std::string(tag) != kStdlibAbiTag) {
      return ::testing::AssertionFailure() << path << " was built with the standard library configuration "
                                           << (tag == nullptr ? "(none)" : tag) << ", the test with " << kStdlibAbiTag;
    }
    const PluginInfo* info = library.get_alias<const PluginInfo*()>(kPluginInfoSymbol)();
    if (info == nullptr || info->name == nullptr || std::string(info->name).empty()) {
      return ::testing::AssertionFailure() << path << ": PluginInfo has no name";
    }
    std::string error;
    MotionModel* model = library.get_alias<MotionModelFactory>(kFactorySymbol)(params, &error);
    if (model == nullptr) return ::testing::AssertionFailure() << path << ": the factory failed: " << error;
    Eigen::VectorXd next(model->state_dim());
    const bool ok = x.size() == model->state_dim() && u.size() == model->input_dim() && model->predict(x, u, dt, next);
    delete model;  // runs the plugin's destructor while its code is still mapped
    library.unload();
    if (!ok) return ::testing::AssertionFailure() << path << ": predict failed in cycle " << cycle;
    if (cycle == 0) {
      first = next;
    } else if (next != first) {
      return ::testing::AssertionFailure() << path << ": cycle " << cycle << " predicted " << next.transpose()
                                           << " but the first cycle " << first.transpose();
    }
  }
  return ::testing::AssertionSuccess();
}

}  // namespace testing
}  // namespace sdk
}  // namespace skidimm

#define EXPECT_PLUGIN_SURVIVES_RELOAD(path, params, x, u, dt) \
  EXPECT_TRUE(::skidimm::sdk::testing::PluginSurvivesReload((path), (params), (x), (u), (dt)))

#endif  // SKIDIMM_SDK_TESTING_PLUGIN_LIFECYCLE_H_
