// `skidimm plugins` and `skidimm new-plugin`: the bundled plugins with their
// metadata, duplicates flagged, plugins built against another standard
// library or cut short refused without a crash, and a new plugin's project.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>
#include <utility>

#include "cli/cli_test_support.h"
#include "core/sanitizer.h"

namespace skidimm_test {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

TEST(Cli, PluginsListsTheBundledPluginsWithMetadata) {
  const Result r = run_skidimm("plugins");  // found next to the executable, no --plugin-path
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("ltc_linear 1.0.0"));
  EXPECT_THAT(r.out, HasSubstr("ltc_shared 1.0.0"));
  EXPECT_THAT(r.out, HasSubstr("stc_kinematic 1.0.0"));
  EXPECT_THAT(r.out, HasSubstr("k (scalar): longitudinal efficiency"));
}

TEST(Cli, PluginsShowsStatesInputsAnglesAndFlagsDuplicates) {
  const Result r = run_skidimm("plugins --plugin-path " + kFixturePlugins + "/duplicates");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("duplicate_a.so\n    DUPLICATE: " + kFixturePlugins +
                               "/duplicates/duplicate_b.so in the same directory is also named 'duplicate_model'"));
  EXPECT_THAT(r.out, HasSubstr("DUPLICATE: " + kFixturePlugins + "/duplicates/duplicate_a.so"));
  EXPECT_THAT(r.out, HasSubstr("    states:\n      X: position in the world frame (m)\n"));
  EXPECT_THAT(r.out, HasSubstr("      theta (angle, wrapped to [-pi, pi)): heading (rad)\n"));
  EXPECT_THAT(r.out, HasSubstr("    inputs:\n      phi_dot_L: left wheel speed (rad/s)\n"));
  EXPECT_THAT(r.out, HasSubstr("    states: the bank's own (not declared by the plugin)"));  // linear_features
}

TEST(Cli, PluginsAndValidateRefuseAPluginOfAnotherStandardLibraryWithoutCrashing) {
  const std::string dir = kFixturePlugins + "/old_string_abi";
  const Result listed = run_skidimm("plugins --plugin-path " + dir);
  ASSERT_EQ(listed.exit_code, 0) << listed.err;
  EXPECT_THAT(listed.out, HasSubstr("duplicate_model  UNUSABLE  " + dir +
                                    "/old_string_abi_plugin.so\n"
                                    "    built with another C++ standard library configuration"));
  const fs::path bank = write_file(test_directory() / "bank.yaml", R"(
name: stale
states: [x]
inputs: []
measurement: {observe: [x], R: {std: [1]}}
transition: {mean_dwell_time: 1.0}
initial: {covariance: {std: [1]}}
modes:
  - {name: only, model: duplicate_model, Q: {diagonal: [1]}}
)");
  const Result validated =
      run_skidimm("validate " + bank.string() + " --plugin-path " + kFixturePlugins + "/debug_stdlib");
  EXPECT_EQ(validated.exit_code, 1) << validated.out;
  EXPECT_THAT(validated.err, HasSubstr("_GLIBCXX_DEBUG=1"));
  EXPECT_THAT(validated.err, HasSubstr("debug_stdlib_plugin.so is unusable"));
}

// A plugin file cut short (a copy in progress, a full disk): today's loader
// mapped it and died of SIGBUS (exit 135) even when only listing plugins.
TEST(Cli, PluginsAndValidateRefuseATruncatedPluginFileWithoutCrashing) {
  const fs::path dir = test_directory();
  const std::string whole = read_file(kPlugins + "/skidimm_ltc_linear.so");
  write_file(dir / "ltc_linear.so", whole.substr(0, whole.size() / 2));
  const Result listed = run_skidimm("plugins --plugin-path " + dir.string());
  ASSERT_EQ(listed.exit_code, 0) << listed.err;
  EXPECT_THAT(listed.out, HasSubstr("?  UNUSABLE  " + (dir / "ltc_linear.so").string() + "\n    cannot load: " +
                                    (dir / "ltc_linear.so").string() + ": truncated: its ELF segment"));
  EXPECT_THAT(listed.out, HasSubstr("replace plugin files with mv or install, not cp"));

  // A bank whose plugin's only file is truncated: refused, the file named.
  const std::string slip = read_file(kFixturePlugins + "/slip_ratio/slip_ratio_plugin.so");
  fs::create_directories(dir / "slip");
  // The first 16 KiB: the ELF and program headers, not the segments. (Two
  // thirds of the file cut only debug information in a sanitizer build.)
  ASSERT_GT(slip.size(), 65536u);
  write_file(dir / "slip" / "slip_ratio.so", slip.substr(0, 16384));
  const fs::path bank = write_file(dir / "bank.yaml", R"(
name: truncated
states: [V, omega, s]
inputs: [phi_dot_L, phi_dot_R]
measurement: {observe: [V, omega], R: {std: [0.1, 0.1]}}
transition: {mean_dwell_time: 1.0}
initial: {covariance: {std: [1, 1, 1]}}
shared: {r: 0.165, b: 0.555}
modes:
  - {name: only, model: slip_ratio, params: {s_ss: 0.1, m: 0.8, tau: 0.05, tau_s: 0.5}, Q: {diagonal: [1, 1, 1]}}
)");
  const Result validated = run_skidimm("validate " + bank.string() + " --plugin-path " + (dir / "slip").string());
  EXPECT_EQ(validated.exit_code, 1) << validated.out << validated.err;
  EXPECT_THAT(validated.err, HasSubstr("no plugin named 'slip_ratio'"));
  EXPECT_THAT(validated.err, HasSubstr("skipped " + (dir / "slip" / "slip_ratio.so").string() + ": cannot load: "));
  EXPECT_THAT(validated.err, HasSubstr("truncated: its ELF segment"));
}

// A plugin library's load-time code (a static constructor) runs in
// skidimm's process when the library is loaded: a crash or an exit() there
// ended every command that searched its directory without a word, and an
// exit(0) as if it had succeeded. The library is named; an exit() ends the
// command with status 1; a signal still ends it as the signal does.
TEST(Cli, APluginLibraryThatCrashesOrExitsWhileLoadedIsNamed) {
  const fs::path dir = test_directory();
  const std::string library = kFixturePlugins + "/load_fault/load_fault_plugin.so";
  const auto plugins_with = [&](const std::string& fault) {
    const Result r =
        run_shell("SKIDIMM_TEST_LOAD_FAULT=" + fault + " " + kSkidimm + " plugins --plugin-path " + kFixturePlugins +
                  "/load_fault >" + (dir / "out").string() + " 2>" + (dir / "err").string() + "; echo \"status $?\"");
    return std::make_pair(r.out, read_file(dir / "err"));
  };
  const auto [exit_status, exit_err] = plugins_with("exit");
  EXPECT_EQ(exit_status, "status 1\n");
  EXPECT_THAT(exit_err, HasSubstr("skidimm plugins: the plugin library " + library +
                                  " called exit() while it was being loaded (in its load-time code"));
  const auto [abort_status, abort_err] = plugins_with("abort");
  EXPECT_EQ(abort_status, "status 134\n");
  EXPECT_THAT(abort_err,
              HasSubstr("skidimm plugins: SIGABRT (abort) while loading the plugin library " + library + ": "));
  if (!SKIDIMM_SANITIZED) {  // AddressSanitizer reports a segmentation fault itself
    const auto [segv_status, segv_err] = plugins_with("segv");
    EXPECT_EQ(segv_status, "status 139\n");
    EXPECT_THAT(segv_err, HasSubstr("skidimm plugins: SIGSEGV"));
    EXPECT_THAT(segv_err, HasSubstr(" while loading the plugin library " + library + ": "));
  }
  // Without a fault the same library is a plugin like any other.
  const auto [clean_status, clean_err] = plugins_with("none");
  EXPECT_EQ(clean_status, "status 0\n") << clean_err;
  EXPECT_THAT(read_file(dir / "out"), HasSubstr("load_fault_model 0.0.1"));
}

TEST(Cli, NewPluginWritesAProjectAndRefusesBadNames) {
  const fs::path dir = test_directory();
  const Result bad = run_skidimm("new-plugin 9Lives --dir " + dir.string());
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_THAT(bad.err, HasSubstr("'9Lives' is not a plugin name: use lowercase letters, digits and '_'"));
  EXPECT_TRUE(fs::is_empty(dir));
  const Result ok = run_skidimm("new-plugin wet_grass --dir " + dir.string());
  ASSERT_EQ(ok.exit_code, 0) << ok.err;
  EXPECT_THAT(read_file(dir / "wet_grass" / "wet_grass_plugin.cc"),
              HasSubstr("SKIDIMM_EXPORT_FUNCTION_MODEL(WetGrass)"));
  EXPECT_THAT(read_file(dir / "wet_grass" / "wet_grass_test.cc"),
              HasSubstr("TEST(WetGrass, ConformsOverItsOperatingRegion"));
  const std::string cmake = read_file(dir / "wet_grass" / "CMakeLists.txt");
  EXPECT_THAT(cmake, HasSubstr("find_package(skidimm 0.1 REQUIRED COMPONENTS sdk)"));
  EXPECT_THAT(cmake, HasSubstr("skidimm_add_motion_model(wet_grass wet_grass_plugin.cc INSTALL)"));
  EXPECT_THAT(read_file(dir / "wet_grass" / "wet_grass_bank.yaml"), HasSubstr("model: wet_grass"));
  EXPECT_EQ(run_skidimm("new-plugin wet_grass --dir " + dir.string()).exit_code, 1);  // exists
  // A bundled plugin's name: installed beside it, every bank naming it would fail.
  const Result taken = run_skidimm("new-plugin ltc_linear --dir " + dir.string());
  EXPECT_EQ(taken.exit_code, 2);
  EXPECT_THAT(taken.err, HasSubstr("'ltc_linear' is the name of a plugin skidimm already finds ("));
  EXPECT_THAT(taken.err, HasSubstr("skidimm_ltc_linear.so): choose another name; nothing was written"));
  EXPECT_FALSE(fs::exists(dir / "ltc_linear"));
}

}  // namespace
}  // namespace skidimm_test
