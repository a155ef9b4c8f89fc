#!/usr/bin/env bash
# `skidimm new-plugin` writes a project that builds against the installed SDK
# alone, passes its own conformance test, and loads into the installed,
# unmodified skidimm: listed, validated, run over the installed example log.
#   new_plugin_test.sh <skidimm build dir> <work dir>
set -euo pipefail
build=$1
work=$2
prefix="$work/prefix"

fail() { echo "FAIL: $*" >&2; exit 1; }
step() { echo "== $*"; }

rm -rf "$work"
mkdir -p "$work"

step "install skidimm into $prefix"
cmake --install "$build" --prefix "$prefix" >"$work/install.log"
skidimm="$prefix/bin/skidimm"

step "skidimm new-plugin slip_speed writes the project"
"$skidimm" new-plugin slip_speed --dir "$work/projects" >"$work/new.txt"
project="$work/projects/slip_speed"
for f in CMakeLists.txt slip_speed_plugin.cc slip_speed_test.cc slip_speed_bank.yaml README.md; do
  [ -f "$project/$f" ] || fail "not written: $f ($(cat "$work/new.txt"))"
done
grep -q "find_package(skidimm 0.1 REQUIRED COMPONENTS sdk)" "$project/CMakeLists.txt" ||
  fail "CMakeLists does not use the SDK component"
grep -q "SKIDIMM_EXPORT_FUNCTION_MODEL(SlipSpeed)" "$project/slip_speed_plugin.cc" || fail "not the one-function form"

step "a second time it refuses, and leaves the project alone"
echo "// mine" >>"$project/slip_speed_plugin.cc"
if "$skidimm" new-plugin slip_speed --dir "$work/projects" 2>"$work/again.txt"; then fail "overwrote a project"; fi
grep -q "already exists; nothing was written" "$work/again.txt" || fail "message: $(cat "$work/again.txt")"
tail -n 1 "$project/slip_speed_plugin.cc" | grep -q "// mine" || fail "the existing project was changed"
sed -i '$d' "$project/slip_speed_plugin.cc"

step "it builds against the installed SDK only"
cmake -S "$project" -B "$project/build" -DCMAKE_PREFIX_PATH="$prefix" >"$work/configure.log" 2>&1 ||
  { cat "$work/configure.log"; fail "configure"; }
cmake --build "$project/build" -j 2 >"$work/build.log" 2>&1 || { cat "$work/build.log"; fail "build"; }
[ -f "$project/build/slip_speed.so" ] || fail "no slip_speed.so"

grep -q "Ceres_DIR\|glog_DIR" "$project/build/CMakeCache.txt" && fail "the SDK component dragged in the engine's dependencies"

step "its conformance test passes"
(cd "$project/build" && ctest --output-on-failure >"$work/ctest.log" 2>&1) || { cat "$work/ctest.log"; fail "ctest"; }
grep -q "100% tests passed" "$work/ctest.log" || fail "$(cat "$work/ctest.log")"

step "the installed skidimm lists, validates and runs it"
"$skidimm" plugins --plugin-path "$project/build" >"$work/plugins.txt"
grep -q "^slip_speed 0.1.0" "$work/plugins.txt" || fail "not listed: $(cat "$work/plugins.txt")"
grep -q "      omega: yaw rate (rad/s)" "$work/plugins.txt" || fail "states not shown: $(cat "$work/plugins.txt")"
"$skidimm" validate "$project/slip_speed_bank.yaml" --plugin-path "$project/build" >"$work/validate.txt" ||
  fail "validate"
grep -q "grip: plugin slip_speed 0.1.0 ($project/build/slip_speed.so)" "$work/validate.txt" ||
  fail "validate: $(cat "$work/validate.txt")"
log="$prefix/share/skidimm/configs/examples/ltc_switching.csv"
"$skidimm" run --bank "$project/slip_speed_bank.yaml" --plugin-path "$project/build" --input "$log" \
  --output "$work/out.csv" 2>"$work/run.txt" || { cat "$work/run.txt"; fail "run"; }
head -n 1 "$work/out.csv" | grep -q "^t,mu_grip,mu_slip,V,omega" || fail "header: $(head -n 1 "$work/out.csv")"
[ "$(wc -l <"$work/out.csv")" -eq "$(wc -l <"$log")" ] || fail "one output row per input row"
if grep -q "was rejected" "$work/run.txt"; then fail "a mode was rejected: $(cat "$work/run.txt")"; fi
step "cmake --install puts it where an installed skidimm looks"
cmake --install "$project/build" --prefix "$work/plugin_prefix" >"$work/plugin_install.log" ||
  fail "install: $(cat "$work/plugin_install.log")"
[ -f "$work/plugin_prefix/lib/skidimm/plugins/slip_speed.so" ] || fail "not installed: $(cat "$work/plugin_install.log")"

echo "OK"
