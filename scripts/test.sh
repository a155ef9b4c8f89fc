#!/usr/bin/env bash
# The test command: installs dependencies, builds everything, runs every test,
# then the sanitizer stage (scripts/check.sh: a clang build with ASan+UBSan,
# the suite under it without the reproduction tests, and each fuzz target for
# SKIDIMM_FUZZ_SECONDS, set below). CI runs this script.
#   ./scripts/test.sh
# SKIDIMM_CHECK=0 skips the sanitizer stage; SKIDIMM_CHECK_ARGS is passed to
# check.sh (e.g. --tsan for the ThreadSanitizer build as well).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${SKIDIMM_BUILD_DIR:-$root/build}
"$root/scripts/setup.sh"
"$root/scripts/build.sh"
cd "$build"
ctest --output-on-failure -j "${SKIDIMM_JOBS:-$(nproc 2>/dev/null || echo 2)}"
if [ "${SKIDIMM_CHECK:-1}" != 0 ]; then
  # 20 s per fuzz target keeps the whole script within CI's budget on two
  # cores (README); longer runs are for check.sh by hand (tests/fuzz/README.md).
  # shellcheck disable=SC2086 # word splitting of the arguments is intended
  SKIDIMM_FUZZ_SECONDS=${SKIDIMM_FUZZ_SECONDS:-20} "$root/scripts/check.sh" ${SKIDIMM_CHECK_ARGS:-}
fi
