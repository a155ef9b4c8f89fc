#!/usr/bin/env bash
# The test command: installs dependencies, builds everything, runs every test.
#   ./scripts/test.sh
# SKIDIMM_CHECK=1 then runs the sanitizer stage (scripts/check.sh: the suite
# under ASan+UBSan without the reproduction tests, and each fuzz target for a
# bounded time), with SKIDIMM_CHECK_ARGS passed to it (e.g. --tsan). It is
# off by default: on CI's two cores it adds an estimated 20-30 minutes to the
# 30-35 the Release build and suite take, past CI's 45-minute budget (README).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${SKIDIMM_BUILD_DIR:-$root/build}
"$root/scripts/setup.sh"
"$root/scripts/build.sh"
cd "$build"
ctest --output-on-failure -j "${SKIDIMM_JOBS:-$(nproc 2>/dev/null || echo 2)}"
if [ "${SKIDIMM_CHECK:-0}" != 0 ]; then
  # shellcheck disable=SC2086 # word splitting of the arguments is intended
  "$root/scripts/check.sh" ${SKIDIMM_CHECK_ARGS:-}
fi
