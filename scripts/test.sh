#!/usr/bin/env bash
# The test command: installs dependencies, builds everything, runs every test,
# then the sanitizer stage (scripts/check.sh: a clang build with ASan+UBSan,
# the suite under it without the reproduction tests, and each fuzz target for
# SKIDIMM_FUZZ_SECONDS, set below). CI runs this script.
#   ./scripts/test.sh            the full gate
#   ./scripts/test.sh --quick    the loop while editing: an incremental build and
#                                every test but those labelled `slow` (the
#                                reproductions, the install, demo and
#                                out-of-tree packaging tests); no sanitizer stage
# SKIDIMM_CHECK=0 skips the sanitizer stage; SKIDIMM_CHECK_ARGS is passed to
# check.sh (e.g. --tsan for the ThreadSanitizer build as well).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${SKIDIMM_BUILD_DIR:-$root/build}
jobs=${SKIDIMM_JOBS:-$(nproc 2>/dev/null || echo 2)}
quick=0
for arg in "$@"; do
  case "$arg" in
    --quick) quick=1 ;;
    -h|--help) sed -n '2,12p' "$0"; exit 0 ;;
    *) echo "test.sh: unknown argument '$arg' (see --help)" >&2; exit 2 ;;
  esac
done
"$root/scripts/setup.sh"
"$root/scripts/build.sh"
cd "$build"
if [ "$quick" -eq 1 ]; then
  exec ctest --output-on-failure -j "$jobs" -LE slow
fi
ctest --output-on-failure -j "$jobs"
if [ "${SKIDIMM_CHECK:-1}" != 0 ]; then
  # 20 s per fuzz target keeps the whole script within CI's budget on two
  # cores (README); longer runs are for check.sh by hand (tests/fuzz/README.md).
  # shellcheck disable=SC2086 # word splitting of the arguments is intended
  SKIDIMM_FUZZ_SECONDS=${SKIDIMM_FUZZ_SECONDS:-20} "$root/scripts/check.sh" ${SKIDIMM_CHECK_ARGS:-}
fi
