// skidimm new-plugin NAME [--dir DIR]: writes a buildable out-of-tree plugin
// project (docs/writing-a-model-plugin.md, "Start from a scaffold").
#include <cctype>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <iostream>
#include <string>

#include "commands.h"
#include "skidimm/engine/plugin_registry.h"

namespace skidimm {
namespace cli {

namespace fs = std::filesystem;

namespace {

// The project's files; @NAME@ becomes the plugin's name.
constexpr const char* kCMakeLists = R"scaffold(# The skidimm motion-model plugin `@NAME@`, built against an installed skidimm:
#
#   cmake -S . -B build -DCMAKE_PREFIX_PATH=<skidimm install prefix>
#   cmake --build build
#   ctest --test-dir build                    # the conformance test
#   skidimm plugins --plugin-path build       # skidimm sees the plugin
#   skidimm validate @NAME@_bank.yaml --plugin-path build
#   cmake --install build --prefix P          # P/lib/skidimm/plugins/@NAME@.so, replaced by rename
cmake_minimum_required(VERSION 3.16)
project(@NAME@ VERSION 0.1.0 LANGUAGES CXX)

if(NOT CMAKE_BUILD_TYPE)
  set(CMAKE_BUILD_TYPE Release)
endif()

# The plugin contract only (Eigen, Boost's headers, Ceres' header-only jets),
# without the engine's own dependencies.
find_package(skidimm 0.1 REQUIRED COMPONENTS sdk)

# A MODULE library with hidden visibility: build/@NAME@.so
skidimm_add_motion_model(@NAME@ @NAME@_plugin.cc INSTALL)

option(@UPPER@_BUILD_TESTS "Build the conformance test (needs GoogleTest)" ON)
if(@UPPER@_BUILD_TESTS)
  find_package(GTest REQUIRED)
  add_executable(@NAME@_test @NAME@_test.cc)
  target_link_libraries(@NAME@_test PRIVATE skidimm::sdk GTest::gtest GTest::gtest_main)
  target_compile_definitions(@NAME@_test PRIVATE @UPPER@_PLUGIN_FILE="$<TARGET_FILE:@NAME@>")
  add_dependencies(@NAME@_test @NAME@)
  enable_testing()
  add_test(NAME @NAME@_test COMMAND @NAME@_test)
endif()
)scaffold";

constexpr const char* kPlugin = R"scaffold(// The skidimm plugin `@NAME@`, written as one function and a parameter table
// (skidimm/sdk/function_model.h): the SDK writes the plugin class, checks the
// parameters, and differentiates predict() for the filter and for fitting.
// Replace the equations and the table with your own.
#include "skidimm/sdk/function_model.h"

struct @UPPER_CAMEL@ {
  static constexpr const char* kName = "@NAME@";
  static constexpr const char* kVersion = "0.1.0";
  static constexpr const char* kDescription =
      "First-order speed and yaw rate response to wheel speeds (scaffold of skidimm new-plugin)";
  static constexpr skidimm::sdk::VariableDoc kStates[] = {{"V", "forward speed (m/s)", false},
                                                          {"omega", "yaw rate (rad/s)", false}};
  static constexpr skidimm::sdk::VariableDoc kInputs[] = {{"phi_dot_L", "left wheel speed (rad/s)", false},
                                                          {"phi_dot_R", "right wheel speed (rad/s)", false}};
  // key, description with units, lower and upper bound, scope (per mode, or one for the bank under shared:).
  static constexpr skidimm::sdk::ParameterSpec kParameters[] = {
      {"k", "longitudinal efficiency (-)", 0.0, 2.0},
      {"m", "yaw efficiency (-)", 0.0, 2.0},
      {"tau", "time constant (s)", 1e-3, 10.0},
      {"r", "wheel radius (m)", 1e-3, 10.0, skidimm::sdk::ParameterScope::kBank},
      {"b", "track width (m)", 1e-3, 10.0, skidimm::sdk::ParameterScope::kBank}};
  enum { kK, kM, kTau, kR, kB };  // parameter indices, in kParameters' order
  enum { kV, kOmega };            // state indices

  // Each state follows the speed the wheels command, scaled by a per-mode
  // efficiency, with a time constant, integrated exactly over dt (inputs
  // held over the step):
  //   dV/dt     = (k r (phi_L + phi_R) / 2 - V) / tau
  //   domega/dt = (m r (phi_R - phi_L) / b - omega) / tau
  // T is double or a Ceres jet: write it as plain arithmetic.
  template <typename T>
  static void predict(const T* x, const double* u, const T* p, double dt, T* x_next) {
    using std::exp;
    const T decay = exp(-dt / p[kTau]);
    const T v_target = p[kK] * p[kR] * (u[0] + u[1]) / 2.0;
    const T omega_target = p[kM] * p[kR] * (u[1] - u[0]) / p[kB];
    x_next[kV] = v_target + (x[kV] - v_target) * decay;
    x_next[kOmega] = omega_target + (x[kOmega] - omega_target) * decay;
  }
};

SKIDIMM_EXPORT_FUNCTION_MODEL(@UPPER_CAMEL@)
)scaffold";

constexpr const char* kTest = R"scaffold(// The plugin's own tests: the built plugin file, loaded as skidimm loads it,
// checked with skidimm's conformance kit over the region where it is used.
#include <gtest/gtest.h>

#include "skidimm/sdk/testing/conformance.h"
#include "skidimm/sdk/testing/load_plugin_model.h"
#include "skidimm/sdk/testing/plugin_lifecycle.h"

namespace {

using skidimm::sdk::testing::load_plugin_model;

skidimm::sdk::ParameterSet params() {
  skidimm::sdk::ParameterSet p;
  p.set_scalar("k", 0.9);
  p.set_scalar("m", 0.7);
  p.set_scalar("tau", 0.05);
  p.set_scalar("r", 0.165);
  p.set_scalar("b", 0.555);
  return p;
}

TEST(@UPPER_CAMEL@, ConformsOverItsOperatingRegion) {
  auto model = load_plugin_model(@UPPER@_PLUGIN_FILE, params());
  skidimm::sdk::testing::OperatingRegion region;
  region.x_min = Eigen::Vector2d(-2.0, -1.5);  // V (m/s), omega (rad/s)
  region.x_max = Eigen::Vector2d(2.0, 1.5);
  region.u_min = Eigen::Vector2d(-15.0, -15.0);  // wheel speeds (rad/s)
  region.u_max = Eigen::Vector2d(15.0, 15.0);
  region.dt_min = 0.001;
  region.dt_max = 0.5;
  EXPECT_MOTION_MODEL_CONFORMS_OVER(*model, region);
}

TEST(@UPPER_CAMEL@, ApproachesTheCommandedSpeed) {
  auto model = load_plugin_model(@UPPER@_PLUGIN_FILE, params());
  Eigen::VectorXd next(2);
  ASSERT_TRUE(model->predict(Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(10.0, 10.0), 10.0, next));
  EXPECT_NEAR(next[0], 0.9 * 0.165 * 10.0, 1e-9);  // k r (phi_L + phi_R) / 2
  EXPECT_NEAR(next[1], 0.0, 1e-12);
}

TEST(@UPPER_CAMEL@, RefusesAParameterOutOfBoundsNamingIt) {
  skidimm::sdk::ParameterSet p = params();
  p.set_scalar("tau", -1.0);
  try {
    load_plugin_model(@UPPER@_PLUGIN_FILE, p);
    ADD_FAILURE() << "tau = -1 was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("tau"), std::string::npos) << e.what();
  }
}

TEST(@UPPER_CAMEL@, SurvivesRepeatedLoadAndUnload) {
  EXPECT_PLUGIN_SURVIVES_RELOAD(@UPPER@_PLUGIN_FILE, params(), Eigen::Vector2d(1.0, 0.2), Eigen::Vector2d(3.0, 5.0),
                                0.02);
}

}  // namespace
)scaffold";

constexpr const char* kBank = R"scaffold(# A bank of two modes of the plugin `@NAME@`, over the columns of skidimm's
# example log share/skidimm/configs/examples/ltc_switching.csv:
#   skidimm run --bank @NAME@_bank.yaml --plugin-path build \
#       --input <prefix>/share/skidimm/configs/examples/ltc_switching.csv --output estimates.csv
name: @NAME@_example
states: [V, omega]
inputs: [phi_dot_L, phi_dot_R]
columns: {time: t}
measurement:
  observe: [V, omega]
  R: {std: [0.05, 0.02]}
transition:
  mean_dwell_time: 10.0
initial:
  covariance: {std: [0.5, 0.5]}
shared: {r: 0.165, b: 0.555}
modes:
  - name: grip
    model: @NAME@
    params: {k: 0.95, m: 0.8, tau: 0.03}
    Q: {diagonal: [0.01, 0.01]}
  - name: slip
    model: @NAME@
    params: {k: 0.7, m: 0.4, tau: 0.05}
    Q: {diagonal: [0.02, 0.02]}
)scaffold";

constexpr const char* kReadme = R"scaffold(# @NAME@: a skidimm motion-model plugin

Written by `skidimm new-plugin @NAME@`. Build and test it against an installed
skidimm:

```sh
cmake -S . -B build -DCMAKE_PREFIX_PATH=<skidimm install prefix>
cmake --build build
ctest --test-dir build
skidimm plugins --plugin-path build
skidimm validate @NAME@_bank.yaml --plugin-path build
```

- `@NAME@_plugin.cc`: the model as one function (`predict`) and its parameter table; the SDK
  writes the rest, Jacobians included (automatic differentiation);
- `@NAME@_test.cc`: the built plugin loaded as skidimm loads it, the conformance kit over an
  operating region, a step checked by hand, a bad parameter refused, load/unload;
- `@NAME@_bank.yaml`: a bank of two modes of the plugin.

See skidimm's docs/writing-a-model-plugin.md.
)scaffold";

std::string fill(std::string text, const std::string& name) {
  std::string upper, camel;
  bool start = true;
  for (char c : name) {
    upper += static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    if (c == '_') {
      start = true;
      continue;
    }
    camel += start ? static_cast<char>(std::toupper(static_cast<unsigned char>(c))) : c;
    start = false;
  }
  for (const auto& [key, value] :
       {std::pair<std::string, std::string>{"@UPPER_CAMEL@", camel}, {"@UPPER@", upper}, {"@NAME@", name}}) {
    for (std::size_t at = text.find(key); at != std::string::npos; at = text.find(key, at + value.size())) {
      text.replace(at, key.size(), value);
    }
  }
  return text;
}

}  // namespace

int new_plugin(const std::string& name, const fs::path& parent) {
  bool valid = !name.empty() && name.size() <= 64 && std::islower(static_cast<unsigned char>(name[0]));
  for (char c : name) {
    valid = valid &&
            (std::islower(static_cast<unsigned char>(c)) || std::isdigit(static_cast<unsigned char>(c)) || c == '_');
  }
  if (!valid) {
    std::cerr << "skidimm new-plugin: '" << name
              << "' is not a plugin name: use lowercase letters, digits and '_', starting with a letter "
                 "(it names the plugin, its C++ namespace and its files)\n";
    return kExitUsage;
  }
  // Installed beside a plugin of the same name, it would make every bank that
  // names either fail with "two plugins are named ...".
  PluginRegistry registry(PluginRegistry::standard_search_path({}));
  for (const PluginDescriptor& found : registry.plugins()) {
    if (found.name == name) {
      std::cerr << "skidimm new-plugin: '" << name << "' is the name of a plugin skidimm already finds ("
                << found.path.string() << "): choose another name; nothing was written\n";
      return kExitUsage;
    }
  }
  const fs::path dir = parent / name;
  std::error_code ec;
  if (fs::exists(dir, ec)) {
    std::cerr << "skidimm new-plugin: " << dir.string() << " already exists; nothing was written\n";
    return kExitFailure;
  }
  fs::create_directories(dir, ec);
  if (ec) {
    std::cerr << "skidimm new-plugin: cannot create " << dir.string() << ": " << ec.message() << "\n";
    return kExitFailure;
  }
  const std::pair<std::string, const char*> files[] = {{"CMakeLists.txt", kCMakeLists},
                                                       {name + "_plugin.cc", kPlugin},
                                                       {name + "_test.cc", kTest},
                                                       {name + "_bank.yaml", kBank},    {"README.md", kReadme}};
  for (const auto& [file, text] : files) {
    std::ofstream out(dir / file, std::ios::binary);
    out << fill(text, name);
    out.close();  // a full disk shows at the close, not at the write
    if (!out) {
      std::cerr << "skidimm new-plugin: cannot write " << (dir / file).string() << ": " << std::strerror(errno) << "\n";
      return kExitFailure;
    }
    std::cout << "wrote " << (dir / file).string() << "\n";
  }
  std::cout << "next: cmake -S " << dir.string() << " -B " << (dir / "build").string()
            << " -DCMAKE_PREFIX_PATH=<skidimm install prefix> && cmake --build " << (dir / "build").string()
            << " && ctest --test-dir " << (dir / "build").string() << "\n";
  return kExitOk;
}

}  // namespace cli
}  // namespace skidimm
