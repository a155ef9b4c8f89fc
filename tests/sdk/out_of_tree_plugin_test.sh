#!/usr/bin/env bash
# Installs skidimm into a temporary prefix, builds the third-party example
# plugin (sdk/examples/icr_kinematic) out of tree with only that prefix on
# CMAKE_PREFIX_PATH, runs its conformance tests, and has the installed,
# unmodified skidimm load it from a YAML bank and run it.
#   out_of_tree_plugin_test.sh <skidimm build dir> <skidimm source dir> <work dir>
set -euo pipefail
build=$1
source=$2
work=$3
prefix="$work/prefix"
example_build="$work/icr_kinematic-build"

fail() { echo "FAIL: $*" >&2; exit 1; }
step() { echo "== $*"; }

rm -rf "$work"
mkdir -p "$work"

step "install skidimm into $prefix"
cmake --install "$build" --prefix "$prefix" >"$work/install.log"
for f in bin/skidimm include/skidimm/engine/imm.h include/skidimm/sdk/export.h include/skidimm/sdk/testing/conformance.h \
         share/skidimm/configs/ltc_terrains.yaml share/skidimm/examples/icr_kinematic/CMakeLists.txt; do
  [ -e "$prefix/$f" ] || fail "not installed: $f"
done
# The installed headers are whole: what each includes is installed too (none
# reaches for a header private to the build, under core/src).
while IFS=: read -r header included; do
  [ -e "$prefix/include/$included" ] || fail "${header#"$prefix/include/"} includes \"$included\", which is not installed"
done < <(grep -r -o '^#include "[^"]*"' "$prefix/include/skidimm" | sed 's/:#include "\(.*\)"$/:\1/')
config=$(find "$prefix" -name skidimmConfig.cmake -print -quit)
[ -n "$config" ] || fail "no skidimmConfig.cmake installed"
[ -e "$(dirname "$config")/skidimmConfigVersion.cmake" ] || fail "no package version file"

step "the installed skidimm finds its bundled plugins without being told where"
"$prefix/bin/skidimm" plugins >"$work/plugins.txt"
grep -q "^ltc_linear 1.0.0" "$work/plugins.txt" || fail "installed skidimm does not list ltc_linear: $(cat "$work/plugins.txt")"
grep -q "$prefix" "$work/plugins.txt" || fail "bundled plugins not found under the prefix"

step "the build tree given as the prefix is refused, naming the install to give instead"
if cmake -S "$source/sdk/examples/icr_kinematic" -B "$work/against-build-tree" -DCMAKE_PREFIX_PATH="$build" \
  >"$work/against-build-tree.log" 2>&1; then
  fail "configuring against the build tree succeeded"
fi
grep -q "is skidimm's build tree, which is not a package" "$work/against-build-tree.log" ||
  fail "configuring against the build tree did not say what to give: $(cat "$work/against-build-tree.log")"
grep -q "cmake --install" "$work/against-build-tree.log" || fail "no install command named"

step "build the example plugin against the installed SDK only (COMPONENTS sdk)"
cmake -S "$source/sdk/examples/icr_kinematic" -B "$example_build" -DCMAKE_PREFIX_PATH="$prefix" \
  -DCMAKE_BUILD_TYPE=Release >"$work/configure.log" 2>&1 || { cat "$work/configure.log"; fail "configure"; }
cmake --build "$example_build" -j 2 >"$work/build.log" 2>&1 || { cat "$work/build.log"; fail "build"; }
# COMPONENTS sdk: the engine's dependencies' package files are not loaded.
for dep in Ceres glog gflags yaml-cpp muparser; do
  if grep -q "^${dep}_DIR:" "$example_build/CMakeCache.txt"; then fail "COMPONENTS sdk looked up $dep"; fi
done
plugin="$example_build/icr_kinematic.so"
[ -f "$plugin" ] || fail "no $plugin"
# Hidden visibility: only the five plugin symbols (and Boost.DLL's section) are exported.
exported=$(nm -D --defined-only "$plugin" | awk '{print $3}' | grep -c '^skidimm_' || true)
[ "$exported" -eq 5 ] || fail "expected 5 exported skidimm_ symbols, found $exported"
# grep without -q reads to the end: with pipefail, nm's SIGPIPE would hide a match.
if nm -DC --defined-only "$plugin" | grep "IcrKinematicModel::" >/dev/null; then fail "model internals are exported"; fi

step "the example's own conformance and reload tests"
"$example_build/icr_kinematic_test" --gtest_brief=1 >"$work/example_test.log" 2>&1 || {
  cat "$work/example_test.log"
  fail "example tests"
}

step "the installed skidimm lists and validates the new plugin"
"$prefix/bin/skidimm" plugins --plugin-path "$example_build" >"$work/plugins2.txt"
grep -q "^icr_kinematic 0.1.0" "$work/plugins2.txt" || fail "plugin not listed: $(cat "$work/plugins2.txt")"
grep -q "y_icr_l (scalar)" "$work/plugins2.txt" || fail "parameter docs not shown"
bank="$prefix/share/skidimm/examples/icr_kinematic/icr_mixed_bank.yaml"
"$prefix/bin/skidimm" validate "$bank" --plugin-path "$example_build" >"$work/validate.txt"
grep -q "icr_grip .*icr_kinematic" "$work/validate.txt" || fail "validate: $(cat "$work/validate.txt")"

step "run the mixed bank over the installed example log"
"$prefix/bin/skidimm" run --bank "$bank" --plugin-path "$example_build" \
  --input "$prefix/share/skidimm/configs/examples/stc_switching.csv" --output "$work/out.csv" 2>"$work/run.txt"
head -n 1 "$work/out.csv" | grep -q "^t,mu_icr_grip,mu_slip_FR_RR,mu_slip_FL_FR_RL_RR,X,Y,theta" ||
  fail "unexpected output header: $(head -n 1 "$work/out.csv")"
rows=$(($(wc -l <"$work/out.csv") - 1))
inputs=$(($(wc -l <"$prefix/share/skidimm/configs/examples/stc_switching.csv") - 1))
[ "$rows" -eq "$inputs" ] || fail "$rows output rows for $inputs input rows"
tail -n 1 "$work/out.csv" | grep -q ",slip_FL_FR_RL_RR,slip_FL_FR_RL_RR," || fail "final mode: $(tail -n 1 "$work/out.csv")"

step "without the plugin's directory the bank fails with a clear error"
if "$prefix/bin/skidimm" validate "$bank" 2>"$work/missing.txt"; then fail "validate passed without the plugin"; fi
grep -q "no plugin named 'icr_kinematic'" "$work/missing.txt" || fail "message: $(cat "$work/missing.txt")"

step "the slip_ratio example (one function): builds, conforms over its region, installs by rename, runs"
slip_build="$work/slip_ratio-build"
slip_prefix="$work/slip_prefix"
cmake -S "$source/sdk/examples/slip_ratio" -B "$slip_build" -DCMAKE_PREFIX_PATH="$prefix" \
  -DCMAKE_BUILD_TYPE=Release >"$work/slip_configure.log" 2>&1 || { cat "$work/slip_configure.log"; fail "configure slip_ratio"; }
if grep -q "^Ceres_DIR:" "$slip_build/CMakeCache.txt"; then fail "slip_ratio: COMPONENTS sdk looked up Ceres"; fi
cmake --build "$slip_build" -j 2 >"$work/slip_build.log" 2>&1 || { cat "$work/slip_build.log"; fail "build slip_ratio"; }
"$slip_build/slip_ratio_test" --gtest_brief=1 >"$work/slip_test.log" 2>&1 || { cat "$work/slip_test.log"; fail "slip_ratio tests"; }
cmake --install "$slip_build" --prefix "$slip_prefix" >"$work/slip_install.log"
installed="$slip_prefix/lib/skidimm/plugins/slip_ratio.so"
[ -f "$installed" ] || fail "not installed: $installed ($(cat "$work/slip_install.log"))"
grep -q "Installing (by rename): $installed" "$work/slip_install.log" || fail "install: $(cat "$work/slip_install.log")"
cmp -s "$installed" "$slip_build/slip_ratio.so" || fail "installed file differs from the built one"
first_inode=$(stat -c %i "$installed")
cmake --install "$slip_build" --prefix "$slip_prefix" >"$work/slip_install2.log"
[ "$(stat -c %i "$installed")" != "$first_inode" ] || fail "reinstalling wrote the plugin file in place (same inode)"
ls -A "$slip_prefix/lib/skidimm/plugins" | grep -q installing && fail "a temporary file was left behind"
grep -q "$installed" "$slip_build/install_manifest.txt" || fail "not in install_manifest.txt"
slip_bank="$source/sdk/examples/slip_ratio/slip_ratio_bank.yaml"
"$prefix/bin/skidimm" validate "$slip_bank" --plugin-path "$slip_prefix/lib/skidimm/plugins" >"$work/slip_validate.txt"
grep -q "slip_ratio" "$work/slip_validate.txt" || fail "validate slip_ratio: $(cat "$work/slip_validate.txt")"
"$prefix/bin/skidimm" run --bank "$slip_bank" --plugin-path "$slip_prefix/lib/skidimm/plugins" \
  --input "$prefix/share/skidimm/configs/examples/ltc_switching.csv" --output "$work/slip_out.csv" 2>"$work/slip_run.txt" ||
  { cat "$work/slip_run.txt"; fail "run slip_ratio"; }
head -n 1 "$work/slip_out.csv" | grep -q "^t,mu_grip,mu_slip,V,omega,s," || fail "slip_ratio header: $(head -n 1 "$work/slip_out.csv")"

step "a program of the user's links skidimm::core from the install and runs the IMM on messages pushed live"
cmake -S "$source/sdk/examples/online_imm" -B "$work/online_imm-build" -DCMAKE_PREFIX_PATH="$prefix" \
  -DCMAKE_BUILD_TYPE=Release >"$work/online_configure.log" 2>&1 || { cat "$work/online_configure.log"; fail "configure online_imm"; }
cmake --build "$work/online_imm-build" -j 2 >"$work/online_build.log" 2>&1 || { cat "$work/online_build.log"; fail "build online_imm"; }
"$work/online_imm-build/online_imm" "$prefix/share/skidimm/configs/ltc_terrains.yaml" \
  "$prefix/share/skidimm/configs/examples/ltc_switching.csv" >"$work/online.txt"
grep -q "now on crushed_concrete" "$work/online.txt" || fail "online_imm: $(cat "$work/online.txt")"
grep -q "now on asphalt" "$work/online.txt" || fail "online_imm: $(cat "$work/online.txt")"
# Its messages pushed into a LiveLog make a step of every row, as skidimm run reads the file.
grep -q "^1487 steps$" "$work/online.txt" || fail "online_imm: $(cat "$work/online.txt")"
# Restarted after 700 messages, from the checkpoint the first node saved: the rest of the drive's steps,
# and the last step's probabilities those of the node never restarted, to the last digit.
head -n 701 "$prefix/share/skidimm/configs/examples/ltc_switching.csv" >"$work/first_700.csv"
"$work/online_imm-build/online_imm" "$prefix/share/skidimm/configs/ltc_terrains.yaml" "$work/first_700.csv" \
  "$work/node.yaml" >"$work/online_first.txt" || fail "online_imm, first node: $(cat "$work/online_first.txt")"
"$work/online_imm-build/online_imm" "$prefix/share/skidimm/configs/ltc_terrains.yaml" \
  "$prefix/share/skidimm/configs/examples/ltc_switching.csv" "$work/node.yaml" >"$work/online_restarted.txt" ||
  fail "online_imm, restarted: $(cat "$work/online_restarted.txt")"
grep -q "^resumed at t = 14.0330 s$" "$work/online_restarted.txt" || fail "online_imm: $(cat "$work/online_restarted.txt")"
grep -q "^787 steps$" "$work/online_restarted.txt" || fail "online_imm: $(cat "$work/online_restarted.txt")"
[ "$(grep '^last step:' "$work/online_restarted.txt")" = "$(grep '^last step:' "$work/online.txt")" ] ||
  fail "online_imm restarted ends elsewhere: $(grep '^last step:' "$work/online_restarted.txt" "$work/online.txt")"

echo "out-of-tree plugin and program: all checks passed"
