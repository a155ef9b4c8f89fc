#!/usr/bin/env bash
# Configures and builds skidimm (Release) in ${SKIDIMM_BUILD_DIR:-build}.
# Extra arguments are passed to `cmake --build` (e.g. --target skidimm).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${SKIDIMM_BUILD_DIR:-$root/build}
jobs=${SKIDIMM_JOBS:-$(nproc 2>/dev/null || echo 2)}
mkdir -p "$build"
# The configure output belongs to the build, not the source tree.
# SKIDIMM_UNITY_BUILD=ON|OFF sets CMAKE_UNITY_BUILD (scripts/test.sh: ON);
# unset, the tree keeps what it was configured with.
cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release -DSKIDIMM_BUILD_TESTS=ON \
  ${SKIDIMM_UNITY_BUILD:+-DCMAKE_UNITY_BUILD=$SKIDIMM_UNITY_BUILD} >"$build/configure.log" 2>&1 || {
  cat "$build/configure.log" >&2
  exit 1
}
cmake --build "$build" -j "$jobs" "$@"
