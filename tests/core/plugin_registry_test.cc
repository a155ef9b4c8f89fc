#include "skidimm/engine/plugin_registry.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cstdlib>
#include <fstream>
#include <map>

#include "core/temp_files.h"
#include "skidimm/errors.h"
#include "skidimm/sdk/abi.h"

namespace skidimm {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

const fs::path kBundledPlugins = SKIDIMM_PLUGIN_DIR;
const fs::path kFixtures = SKIDIMM_TEST_PLUGIN_ROOT;

template <typename F>
std::string plugin_error(F&& f) {
  try {
    f();
  } catch (const PluginError& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected a PluginError";
  return "";
}

sdk::ParameterSet ltc_params() {
  sdk::ParameterSet p;
  p.set("A", Eigen::Matrix2d::Identity() * -2.0);
  p.set("B", Eigen::Matrix2d::Identity());
  return p;
}

TEST(PluginRegistry, FindsTheBundledPluginsWithTheirMetadata) {
  PluginRegistry registry({kBundledPlugins});
  std::vector<std::string> names;
  for (const PluginDescriptor& d : registry.plugins()) {
    EXPECT_TRUE(d.error.empty()) << d.path << ": " << d.error;
    names.push_back(d.name);
  }
  EXPECT_THAT(names, ::testing::UnorderedElementsAre("linear_features", "ltc_linear", "ltc_shared", "stc_kinematic",
                                                     "stc_sided", "stc_traction"));
  const PluginDescriptor& stc = registry.find("stc_kinematic");
  EXPECT_EQ(stc.version, "1.0.0");
  EXPECT_EQ(stc.parameter_keys, (std::vector<std::string>{"k", "m", "r", "b"}));
  EXPECT_EQ(stc.shared_parameter_keys, (std::vector<std::string>{"r", "b"})) << "documented bank-level (shared:)";
  EXPECT_TRUE(registry.find("ltc_linear").shared_parameter_keys.empty());
  EXPECT_THAT(stc.description, HasSubstr("eq. 3"));
  ASSERT_EQ(stc.outputs.size(), 1u);
  EXPECT_EQ(stc.outputs[0].name, "omega");
  const PluginDescriptor& traction = registry.find("stc_traction");
  ASSERT_EQ(traction.outputs.size(), 3u);
  EXPECT_EQ(traction.outputs[1].name, "i_L");
  EXPECT_TRUE(registry.find("ltc_linear").outputs.empty());
}

TEST(PluginRegistry, ModelOutlivesTheRegistryThatLoadedIt) {
  ModelHandle model;
  {
    PluginRegistry registry({kBundledPlugins});
    model = registry.create("ltc_linear", ltc_params());
  }
  // Built with -fno-gnu-unique: had the library been unloaded, this would crash.
  Eigen::VectorXd next(2);
  ASSERT_TRUE(model->predict(Eigen::Vector2d(1.0, 0.0), Eigen::Vector2d(0.0, 0.0), 0.5, next));
  EXPECT_DOUBLE_EQ(next[0], 0.0);  // 1 + (-2 * 1) * 0.5
  model.reset();
}

TEST(PluginRegistry, UnknownNameListsSearchPathAndFoundPlugins) {
  PluginRegistry registry({kBundledPlugins, "/nonexistent/dir"});
  const std::string e = plugin_error([&] { registry.find("icr_kinematic"); });
  EXPECT_THAT(e, HasSubstr("no plugin named 'icr_kinematic' on the search path"));
  EXPECT_THAT(e, HasSubstr("/nonexistent/dir (missing)"));
  EXPECT_THAT(e, HasSubstr("found: linear_features, ltc_linear, ltc_shared, stc_kinematic"));
}

TEST(PluginRegistry, MissingFileOnTheSearchPathMeansNothingFound) {
  PluginRegistry registry({"/nonexistent/plugin.so"});
  EXPECT_THAT(plugin_error([&] { registry.find("ltc_linear"); }), HasSubstr("no plugins were found there"));
}

TEST(PluginRegistry, CorruptLibraryIsListedAsUnusableNotFatal) {
  const fs::path dir = skidimm_test::test_directory();
  skidimm_test::write_file(dir / "garbage.so", "this is not an ELF file");
  PluginRegistry registry({dir, kBundledPlugins});
  ASSERT_GE(registry.plugins().size(), 4u);
  EXPECT_EQ(registry.plugins()[0].path.filename(), "garbage.so");
  EXPECT_THAT(registry.plugins()[0].error, HasSubstr("cannot load: "));
  EXPECT_THAT(registry.plugins()[0].error, HasSubstr("garbage.so"));
  EXPECT_NO_THROW(registry.find("ltc_linear"));  // the other plugins still load
}

TEST(PluginRegistry, OnlyRegularFilesAreOpenedAndHugeOnesAreNotRead) {
  const fs::path dir = skidimm_test::test_directory();
  // A FIFO would block open() until a writer came; it is never opened.
  ASSERT_EQ(::mkfifo((dir / "fifo.so").c_str(), 0600), 0);
  fs::create_symlink(dir / "loop.so", dir / "loop.so");
  fs::create_symlink("/dev/zero", dir / "zero.so");
  std::ofstream(dir / "huge.so").close();
  fs::resize_file(dir / "huge.so", std::uintmax_t{4} << 30);  // sparse: no disk used
  PluginRegistry registry({dir, dir / "fifo.so", kBundledPlugins});
  std::map<std::string, std::string> errors;
  for (const PluginDescriptor& d : registry.plugins()) errors[d.path.filename().string()] = d.error;
  EXPECT_THAT(errors["fifo.so"], HasSubstr("not a plugin file: a FIFO"));
  EXPECT_THAT(errors["loop.so"], HasSubstr("cannot read: Too many levels of symbolic links"));
  EXPECT_THAT(errors["zero.so"], HasSubstr("not a plugin file: a character device"));
  EXPECT_THAT(errors["huge.so"], HasSubstr("4294967296 bytes long, larger than a plugin can be (1073741824 bytes)"));
  EXPECT_NO_THROW(registry.find("ltc_linear"));  // the other plugins still load
}

TEST(PluginRegistry, LibraryWithoutTheAbiSymbolIsNotAPlugin) {
  PluginRegistry registry({kFixtures / "not_a_plugin"});
  ASSERT_EQ(registry.plugins().size(), 1u);
  EXPECT_THAT(registry.plugins()[0].error, HasSubstr("not a skidimm plugin: no 'skidimm_abi_version' symbol"));
}

TEST(PluginRegistry, WrongAbiIsRefusedNamingPluginAndVersions) {
  PluginRegistry registry({kFixtures / "wrong_abi"});
  const std::string e = plugin_error([&] { registry.find("stale_model"); });
  EXPECT_THAT(e, HasSubstr("plugin 'stale_model' at "));
  EXPECT_THAT(e, HasSubstr("wrong_abi_plugin.so"));
  EXPECT_THAT(e, HasSubstr("built for skidimm plugin ABI " + std::to_string(sdk::kAbiVersion + 1) +
                           ", but this skidimm uses ABI " + std::to_string(sdk::kAbiVersion)));
}

TEST(PluginRegistry, MissingFactoryIsNamed) {
  PluginRegistry registry({kFixtures / "no_factory"});
  EXPECT_THAT(plugin_error([&] { registry.find("no_factory_model"); }),
              HasSubstr("incomplete plugin: missing symbol 'skidimm_create_motion_model'"));
}

// A null where a name belongs is the plugin's bug: that file is refused,
// the other plugins still load.
TEST(PluginRegistry, ANullNameIsRefusedAndTheOthersStillLoad) {
  PluginRegistry registry({kFixtures / "null_name", kBundledPlugins});
  std::string error;
  for (const PluginDescriptor& d : registry.plugins()) {
    if (d.path.parent_path().filename() == "null_name") error = d.error;
  }
  EXPECT_THAT(error, HasSubstr("incomplete plugin: 'skidimm_plugin_name' returned no name (null)"));
  EXPECT_NO_THROW(registry.find("ltc_linear"));
}

TEST(PluginRegistry, ThrowingFactoryBecomesAnError) {
  PluginRegistry registry({kFixtures / "throwing"});
  const std::string e = plugin_error([&] { registry.create("throwing_model", {}); });
  EXPECT_THAT(e, HasSubstr("plugin 'throwing_model'"));
  EXPECT_THAT(e, HasSubstr("the plugin's factory threw: the sensor calibration file is missing"));
}

TEST(PluginRegistry, TwoFilesWithOneNameInOneDirectoryIsAnError) {
  PluginRegistry registry({kFixtures / "duplicates"});
  const std::string e = plugin_error([&] { registry.find("duplicate_model"); });
  EXPECT_THAT(e, HasSubstr("two plugins are named 'duplicate_model'"));
  EXPECT_THAT(e, HasSubstr("duplicate_a.so"));
  EXPECT_THAT(e, HasSubstr("duplicate_b.so"));
}

TEST(PluginRegistry, EarlierDirectoriesShadowLaterOnes) {
  PluginRegistry registry({kFixtures / "duplicates" / "duplicate_b.so", kFixtures / "duplicates"});
  EXPECT_EQ(registry.find("duplicate_model").path.filename(), "duplicate_b.so");
  int shadowed = 0;
  for (const PluginDescriptor& d : registry.plugins()) shadowed += d.shadowed;
  EXPECT_EQ(shadowed, 2);
}

TEST(PluginRegistry, RejectedParametersNameThePluginFile) {
  PluginRegistry registry({kBundledPlugins});
  sdk::ParameterSet params = ltc_params();
  params.set_scalar("C", 1.0);
  const std::string e = plugin_error([&] { registry.create("ltc_linear", params); });
  EXPECT_THAT(e, HasSubstr("skidimm_ltc_linear.so) rejected its parameters: unknown parameter 'C'"));
}

TEST(PluginRegistry, DescriptorsShowDeclaredStatesInputsAndAngles) {
  PluginRegistry registry({kBundledPlugins});
  const PluginDescriptor& stc = registry.find("stc_kinematic");
  ASSERT_EQ(stc.states.size(), 3u);
  EXPECT_EQ(stc.states[0].name, "X");
  EXPECT_FALSE(stc.states[0].is_angle);
  EXPECT_EQ(stc.states[2].name, "theta");
  EXPECT_TRUE(stc.states[2].is_angle);
  EXPECT_THAT(stc.states[2].description, HasSubstr("rad"));
  ASSERT_EQ(stc.inputs.size(), 2u);
  EXPECT_EQ(stc.inputs[1].name, "phi_dot_R");
  // A plugin over the bank's own states declares none.
  EXPECT_TRUE(registry.find("linear_features").states.empty());
}

TEST(PluginRegistry, DuplicatesInOneDirectoryAreFlaggedInTheListing) {
  PluginRegistry registry({kFixtures / "duplicates"});
  ASSERT_EQ(registry.plugins().size(), 2u);
  EXPECT_EQ(registry.plugins()[0].duplicate_of.filename(), "duplicate_b.so");
  EXPECT_EQ(registry.plugins()[1].duplicate_of.filename(), "duplicate_a.so");
  PluginRegistry single({kFixtures / "duplicates" / "duplicate_a.so", kBundledPlugins});
  for (const PluginDescriptor& d : single.plugins()) EXPECT_TRUE(d.duplicate_of.empty()) << d.path;
}

// The same fixture built with -D_GLIBCXX_USE_CXX11_ABI=0 or -D_GLIBCXX_DEBUG:
// std::string and std::vector in ParameterSet have another layout there.
TEST(PluginRegistry, PluginBuiltWithTheOldStringAbiIsRefusedBeforeAnythingCrosses) {
  PluginRegistry registry({kFixtures / "old_string_abi"});
  ASSERT_EQ(registry.plugins().size(), 1u);
  const std::string& error = registry.plugins()[0].error;
  EXPECT_THAT(error, HasSubstr("built with another C++ standard library configuration "
                               "(libstdc++ _GLIBCXX_USE_CXX11_ABI=0 _GLIBCXX_DEBUG=0)"));
  EXPECT_THAT(error, HasSubstr("than this skidimm (libstdc++ _GLIBCXX_USE_CXX11_ABI=1 _GLIBCXX_DEBUG=0)"));
  const std::string e = plugin_error([&] { registry.create("duplicate_model", {}); });
  EXPECT_THAT(e, HasSubstr("old_string_abi_plugin.so is unusable"));
  EXPECT_THAT(e, HasSubstr("Rebuild the plugin with the same standard library settings"));
}

TEST(PluginRegistry, PluginBuiltWithTheDebugStandardLibraryIsRefused) {
  PluginRegistry registry({kFixtures / "debug_stdlib"});
  ASSERT_EQ(registry.plugins().size(), 1u);
  EXPECT_THAT(registry.plugins()[0].error, HasSubstr("(libstdc++ _GLIBCXX_USE_CXX11_ABI=1 _GLIBCXX_DEBUG=1)"));
  EXPECT_THAT(plugin_error([&] { registry.create("duplicate_model", {}); }), HasSubstr("debug_stdlib_plugin.so"));
}

sdk::ParameterSet faulty(const std::string& failure, double above = -1.0) {
  sdk::ParameterSet p;
  p.set_text("failure", {failure});
  p.set_scalar("above", above);
  return p;
}

// predict/jacobian/process_noise are noexcept: SizedMotionModel catches what
// model code throws and reports it by return value and failure_reason().
TEST(PluginRegistry, ExceptionsInModelCodeBecomeFailuresWithTheirReason) {
  PluginRegistry registry({kFixtures / "faulty"});
  const Eigen::Vector2d x(1.0, 0.5), u(2.0, 3.0);
  Eigen::VectorXd next(2);
  Eigen::MatrixXd matrix(2, 2);
  const Eigen::MatrixXd intensity = Eigen::Matrix2d::Identity();

  ModelHandle model = registry.create("faulty_model", faulty("predict_throws"));
  EXPECT_FALSE(model->predict(x, u, 0.1, next));
  EXPECT_THAT(model->failure_reason(), HasSubstr("predict_fixed() threw: vector::_M_range_check"));
  EXPECT_STREQ(model->failure_reason(), "");  // read once
  // The numeric fallback calls predict_fixed() too; this model has an analytic Jacobian.
  EXPECT_TRUE(model->jacobian(x, u, 0.1, matrix));

  model = registry.create("faulty_model", faulty("jacobian_throws"));
  EXPECT_TRUE(model->predict(x, u, 0.1, next));
  EXPECT_FALSE(model->jacobian(x, u, 0.1, matrix));
  EXPECT_STREQ(model->failure_reason(), "jacobian_fixed() threw: no Jacobian here");

  model = registry.create("faulty_model", faulty("noise_throws"));
  EXPECT_FALSE(model->process_noise(intensity, x, u, 0.1, matrix));
  EXPECT_STREQ(model->failure_reason(), "process_noise_fixed() threw: noise table missing");

  model = registry.create("faulty_model", faulty("false"));
  EXPECT_FALSE(model->predict(x, u, 0.1, next));
  EXPECT_STREQ(model->failure_reason(), "the slip ratio is undefined at this speed");

  // Below the threshold nothing fails and the default noise is Q dt.
  model = registry.create("faulty_model", faulty("noise_throws", 2.0));
  ASSERT_TRUE(model->process_noise(intensity, x, u, 0.1, matrix));
  EXPECT_TRUE(matrix.isApprox(0.1 * intensity));
}

TEST(PluginRegistry, ModelsMustHaveTheStatesTheirPluginDeclares) {
  PluginRegistry registry({kFixtures / "faulty"});
  EXPECT_NO_THROW(registry.create("faulty_model", faulty("nan")));
  const std::string e = plugin_error([&] { registry.create("faulty_model", faulty("wrong_states")); });
  EXPECT_THAT(e,
              HasSubstr("faulty_plugin.so) declares states [V, omega] in its PluginInfo, but its model has [V, yaw]"));
}

TEST(PluginRegistry, StandardSearchPathOrder) {
  setenv("SKIDIMM_PLUGIN_PATH", "/env/one:/env/two", 1);
  const std::vector<fs::path> path = PluginRegistry::standard_search_path({"/explicit"}, {"/bank"});
  unsetenv("SKIDIMM_PLUGIN_PATH");
  ASSERT_GE(path.size(), 5u);
  EXPECT_EQ(path[0], "/explicit");
  EXPECT_EQ(path[1], "/bank");
  EXPECT_EQ(path[2], "/env/one");
  EXPECT_EQ(path[3], "/env/two");
  EXPECT_EQ(path[4].filename(), "plugins");  // next to the executable: <bin>/../lib/skidimm/plugins
}

// A plugin file truncated on disk (a copy still in progress, a full disk):
// its segments run past the file's end. Mapping it would be SIGBUS at the
// first touch of a missing page; it is refused with the reason instead.
TEST(PluginRegistry, TruncatedLibraryIsRefusedNotMapped) {
  const fs::path dir = skidimm_test::test_directory();
  const std::string whole = skidimm_test::read_file(kBundledPlugins / "skidimm_ltc_linear.so");
  ASSERT_GT(whole.size(), 8192u);
  skidimm_test::write_file(dir / "ltc_linear.so", whole.substr(0, whole.size() / 2));
  PluginRegistry registry({dir});
  ASSERT_EQ(registry.plugins().size(), 1u);
  const std::string error = registry.plugins()[0].error;
  EXPECT_THAT(error, HasSubstr("cannot load: " + (dir / "ltc_linear.so").string() + ": truncated: its ELF segment"));
  EXPECT_THAT(error, HasSubstr("but the file has " + std::to_string(whole.size() / 2)));
  EXPECT_THAT(error, HasSubstr("replace plugin files with mv or install, not cp"));
  EXPECT_THAT(plugin_error([&] { registry.find("ltc_linear"); }), HasSubstr("no plugin named 'ltc_linear'"));
}

TEST(PluginRegistry, EmptyLibraryIsRefused) {
  const fs::path dir = skidimm_test::test_directory();
  skidimm_test::write_file(dir / "empty.so", "");
  PluginRegistry registry({dir});
  ASSERT_EQ(registry.plugins().size(), 1u);
  EXPECT_THAT(registry.plugins()[0].error, HasSubstr("empty.so: the file is empty"));
}

// `cp other.so plugin.so` while a run uses plugin.so truncates and rewrites
// the loaded file in place. The model was loaded from a private copy, so it
// keeps stepping with its own code.
TEST(PluginRegistry, RewritingTheFileInPlaceDoesNotReachALoadedModel) {
  const fs::path dir = skidimm_test::test_directory();
  const fs::path file = dir / "ltc_linear.so";
  fs::copy_file(kBundledPlugins / "skidimm_ltc_linear.so", file);
  PluginRegistry registry({dir});
  ModelHandle model = registry.create("ltc_linear", ltc_params());
  EXPECT_EQ(registry.plugins()[0].path, file);  // the original is what is reported

  // Same inode, new bytes: first a few bytes (every page of the old file
  // gone), then another plugin's bytes.
  skidimm_test::write_file(file, "rewritten");
  Eigen::VectorXd next(2);
  ASSERT_TRUE(model->predict(Eigen::Vector2d(1.0, 0.0), Eigen::Vector2d(0.0, 0.0), 0.5, next));
  EXPECT_DOUBLE_EQ(next[0], 0.0);  // 1 + (-2 * 1) * 0.5
  skidimm_test::write_file(file, skidimm_test::read_file(kBundledPlugins / "skidimm_stc_kinematic.so"));
  ASSERT_TRUE(model->predict(Eigen::Vector2d(2.0, 1.0), Eigen::Vector2d(1.0, 0.0), 0.25, next));
  EXPECT_DOUBLE_EQ(next[0], 2.0 + (-2.0 * 2.0 + 1.0) * 0.25);
  EXPECT_DOUBLE_EQ(next[1], 1.0 + (-2.0 * 1.0) * 0.25);
  model.reset();  // the destructor's code is still there too

  // A new registry sees the new file.
  PluginRegistry again({dir});
  ASSERT_EQ(again.plugins().size(), 1u);
  EXPECT_EQ(again.plugins()[0].name, "stc_kinematic");
}

// Many loads and unloads: a descriptor number freed by one library is not
// mistaken for it when the next library is loaded from the same number.
TEST(PluginRegistry, SuccessiveRegistriesLoadTheFilesTheyAreGiven) {
  for (int i = 0; i < 3; ++i) {
    for (const char* file : {"skidimm_ltc_linear.so", "skidimm_stc_kinematic.so"}) {
      PluginRegistry registry({kBundledPlugins / file});
      ASSERT_EQ(registry.plugins().size(), 1u);
      EXPECT_EQ(registry.plugins()[0].name, std::string(file).substr(8, std::string(file).size() - 11));
    }
  }
}

}  // namespace
}  // namespace skidimm
