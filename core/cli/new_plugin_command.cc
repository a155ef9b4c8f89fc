// skidimm new-plugin NAME [--dir DIR]: writes a buildable out-of-tree plugin
// project (docs/writing-a-model-plugin.md, "Start from a scaffold").
#include <cctype>
#include <fstream>
#include <iostream>
#include <string>

#include "commands.h"

namespace skidimm {
namespace cli {

namespace fs = std::filesystem;

namespace {

// The project's files; @NAME@ becomes the plugin's name.
constexpr const char* kCMakeLists =
    R"scaffold(# The skidimm motion-model plugin `@NAME@`, built against an installed skidimm:
#
#   cmake -S . -B build -DCMAKE_PREFIX_PATH=<skidimm install prefix>
#   cmake --build build
#   ctest --test-dir build                    # the conformance test
#   skidimm plugins --plugin-path build       # skidimm sees the plugin
#   skidimm validate @NAME@_bank.yaml --plugin-path build
cmake_minimum_required(VERSION 3.16)
project(@NAME@ VERSION 0.1.0 LANGUAGES CXX)

if(NOT CMAKE_BUILD_TYPE)
  set(CMAKE_BUILD_TYPE Release)
endif()

find_package(skidimm 0.1 REQUIRED)

# A MODULE library with hidden visibility: build/@NAME@.so
skidimm_add_motion_model(@NAME@ @NAME@_plugin.cc)
target_include_directories(@NAME@ PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})

option(@UPPER@_BUILD_TESTS "Build the conformance test (needs GoogleTest)" ON)
if(@UPPER@_BUILD_TESTS)
  find_package(GTest REQUIRED)
  add_executable(@NAME@_test @NAME@_test.cc)
  target_include_directories(@NAME@_test PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
  target_link_libraries(@NAME@_test PRIVATE skidimm::sdk GTest::gtest GTest::gtest_main)
  target_compile_definitions(@NAME@_test PRIVATE @UPPER@_PLUGIN_FILE="$<TARGET_FILE:@NAME@>")
  add_dependencies(@NAME@_test @NAME@)
  enable_testing()
  add_test(NAME @NAME@_test COMMAND @NAME@_test)
endif()
)scaffold";

constexpr const char* kModel = R"scaffold(// The motion model of the plugin `@NAME@`. Replace the equations in
// @NAME@_predict() and the parameter table with your own.
//
// State [V, omega]: forward speed (m/s) and yaw rate (rad/s); inputs
// [phi_dot_L, phi_dot_R]: wheel speeds (rad/s). Each follows the speed the
// wheels command, scaled by a per-mode efficiency, with a time constant:
//   dV/dt     = (k r (phi_L + phi_R) / 2 - V) / tau
//   domega/dt = (m r (phi_R - phi_L) / b - omega) / tau
// integrated exactly over dt (the input is held constant over the step).
#ifndef @UPPER@_MODEL_H_
#define @UPPER@_MODEL_H_

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "skidimm/sdk/sized_motion_model.h"

namespace @NAME@ {

enum : int { kV = 0, kOmega = 1 };                      // state indices
enum : int { kK = 0, kM = 1, kTau = 2, kR = 3, kB = 4 };  // parameter indices
constexpr int kNumParameters = 5;

// The equations, on any scalar type (double, or Ceres jets for fitting).
template <typename T>
void @NAME@_predict(const T* x, const double* u, double dt, const T* p, T* x_next) {
  using std::exp;
  const T decay = exp(-dt / p[kTau]);
  const T v_target = p[kK] * p[kR] * (u[0] + u[1]) / 2.0;
  const T omega_target = p[kM] * p[kR] * (u[1] - u[0]) / p[kB];
  x_next[kV] = v_target + (x[kV] - v_target) * decay;
  x_next[kOmega] = omega_target + (x[kOmega] - omega_target) * decay;
}

class Model final : public skidimm::sdk::SizedMotionModel<2, 2> {
 public:
  // Called by the factory SKIDIMM_EXPORT_MOTION_MODEL generates, with the
  // mode's params and the bank's shared: ones.
  static std::unique_ptr<Model> Create(const skidimm::sdk::ParameterSet& params, std::string* error) {
    auto model = std::make_unique<Model>();
    Eigen::VectorXd values(kNumParameters);
    if (!params.check_only({"k", "m", "tau", "r", "b"}, error)) return nullptr;
    for (int i = 0; i < kNumParameters; ++i) {
      if (!params.get_scalar(model->info_[static_cast<std::size_t>(i)].key, &values[i], error)) return nullptr;
    }
    if (!model->set_parameters(values, error)) return nullptr;
    return model;
  }

  const std::vector<std::string>& state_names() const noexcept override { return states_; }
  const std::vector<std::string>& input_names() const noexcept override { return inputs_; }
  const std::vector<skidimm::sdk::ParameterInfo>& parameter_info() const noexcept override { return info_; }
  void get_parameters(Eigen::Ref<Eigen::VectorXd> values) const noexcept override { values = p_; }
  bool set_parameters(const Eigen::Ref<const Eigen::VectorXd>& values, std::string* error) noexcept override {
    if (!skidimm::sdk::check_parameter_values(info_, values, error)) return false;
    p_ = values;
    return true;
  }

  // Not noexcept: the SDK catches what these throw and the engine rejects
  // the mode for the step, naming it and the exception.
  bool predict_fixed(const State& x, const Input& u, double dt, State* x_next) const override {
    @NAME@_predict(x.data(), u.data(), dt, p_.data(), x_next->data());
    return true;
  }
  // The exact Jacobian of @NAME@_predict with respect to x.
  bool jacobian_fixed(const State&, const Input&, double dt, Jacobian* jacobian) const override {
    const double decay = std::exp(-dt / p_[kTau]);
    *jacobian << decay, 0.0, 0.0, decay;
    return true;
  }
  bool has_analytic_jacobian() const noexcept override { return true; }

 private:
  Eigen::Matrix<double, kNumParameters, 1> p_ = Eigen::Matrix<double, kNumParameters, 1>::Zero();
  const std::vector<std::string> states_{"V", "omega"};
  const std::vector<std::string> inputs_{"phi_dot_L", "phi_dot_R"};
  // key, name, description, lower and upper bound, scope (per mode or one for the bank).
  const std::vector<skidimm::sdk::ParameterInfo> info_{
      {"k", "k", "longitudinal efficiency (-)", 0.0, 2.0},
      {"m", "m", "yaw efficiency (-)", 0.0, 2.0},
      {"tau", "tau", "time constant (s)", 1e-3, 10.0},
      {"r", "r", "wheel radius (m)", 1e-3, 10.0, skidimm::sdk::ParameterScope::kBank},
      {"b", "b", "track width (m)", 1e-3, 10.0, skidimm::sdk::ParameterScope::kBank}};
};

}  // namespace @NAME@

#endif  // @UPPER@_MODEL_H_
)scaffold";

constexpr const char* kPlugin = R"scaffold(// Exports @NAME@::Model as the skidimm plugin `@NAME@`.
#include "@NAME@_model.h"
#include "skidimm/sdk/export.h"

namespace {

// What `skidimm plugins` prints, and what banks may give under params: and shared:.
constexpr skidimm::sdk::ParameterDoc kParameters[] = {
    {"k", "scalar", "longitudinal efficiency in [0, 2] (-), per mode"},
    {"m", "scalar", "yaw efficiency in [0, 2] (-), per mode"},
    {"tau", "scalar", "time constant in [0.001, 10] (s), per mode"},
    {"r", "scalar", "wheel radius (m), bank-level (shared:)"},
    {"b", "scalar", "track width (m), bank-level (shared:)"},
};
constexpr skidimm::sdk::VariableDoc kStates[] = {
    {"V", "forward speed (m/s)", false},
    {"omega", "yaw rate (rad/s)", false},
};
constexpr skidimm::sdk::VariableDoc kInputs[] = {
    {"phi_dot_L", "left wheel speed (rad/s)", false},
    {"phi_dot_R", "right wheel speed (rad/s)", false},
};
constexpr skidimm::sdk::PluginInfo kInfo = {
    "@NAME@", "0.1.0", "First-order speed and yaw rate response to wheel speeds (scaffold of skidimm new-plugin)",
    kParameters, 5, kStates, 2, kInputs, 2};

}  // namespace

SKIDIMM_EXPORT_MOTION_MODEL(@NAME@::Model, kInfo)
)scaffold";

constexpr const char* kTest = R"scaffold(// The plugin's own tests, with skidimm's conformance kit.
#include <gtest/gtest.h>

#include "@NAME@_model.h"
#include "skidimm/sdk/testing/conformance.h"
#include "skidimm/sdk/testing/plugin_lifecycle.h"

namespace {

skidimm::sdk::ParameterSet params() {
  skidimm::sdk::ParameterSet p;
  p.set_scalar("k", 0.9);
  p.set_scalar("m", 0.7);
  p.set_scalar("tau", 0.05);
  p.set_scalar("r", 0.165);
  p.set_scalar("b", 0.555);
  return p;
}

TEST(@UPPER_CAMEL@, ConformsToTheMotionModelContractAtManyOperatingPoints) {
  std::string error;
  auto model = @NAME@::Model::Create(params(), &error);
  ASSERT_TRUE(model) << error;
  for (double v : {-1.0, 0.0, 0.4, 2.5}) {
    for (double dt : {0.001, 0.02, 0.5}) {
      EXPECT_MOTION_MODEL_CONFORMS(*model, Eigen::Vector2d(v, 0.3 * v), Eigen::Vector2d(4.0, 7.0), dt);
    }
  }
}

TEST(@UPPER_CAMEL@, ApproachesTheCommandedSpeed) {
  std::string error;
  auto model = @NAME@::Model::Create(params(), &error);
  ASSERT_TRUE(model) << error;
  Eigen::VectorXd next(2);
  ASSERT_TRUE(model->predict(Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(10.0, 10.0), 10.0, next));
  EXPECT_NEAR(next[0], 0.9 * 0.165 * 10.0, 1e-9);  // k r (phi_L + phi_R) / 2
  EXPECT_NEAR(next[1], 0.0, 1e-12);
}

TEST(@UPPER_CAMEL@, RejectsParametersOutOfBounds) {
  skidimm::sdk::ParameterSet p = params();
  p.set_scalar("tau", -1.0);
  std::string error;
  EXPECT_FALSE(@NAME@::Model::Create(p, &error));
  EXPECT_NE(error.find("tau"), std::string::npos) << error;
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

- `@NAME@_model.h`: the equations (`@NAME@_predict`), the Jacobian and the parameter table;
- `@NAME@_plugin.cc`: what `skidimm plugins` shows, and the export;
- `@NAME@_test.cc`: the conformance kit at several operating points, and load/unload;
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
  const std::pair<std::string, const char*> files[] = {{"CMakeLists.txt", kCMakeLists}, {name + "_model.h", kModel},
                                                       {name + "_plugin.cc", kPlugin},  {name + "_test.cc", kTest},
                                                       {name + "_bank.yaml", kBank},    {"README.md", kReadme}};
  for (const auto& [file, text] : files) {
    std::ofstream out(dir / file, std::ios::binary);
    out << fill(text, name);
    if (!out) {
      std::cerr << "skidimm new-plugin: cannot write " << (dir / file).string() << "\n";
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
