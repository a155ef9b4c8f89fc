#!/usr/bin/env bash
# The test command: installs dependencies, builds everything, runs every test,
# then the sanitizer stage (scripts/check.sh: a clang build with ASan+UBSan,
# built beside the Release build and suite at a lower priority; the suite
# under it without the reproduction tests, and each fuzz target for
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
    -h|--help) sed -n '2,13p' "$0"; exit 0 ;;
    *) echo "test.sh: unknown argument '$arg' (see --help)" >&2; exit 2 ;;
  esac
done
"$root/scripts/setup.sh"
check=0
if [ "$quick" -eq 0 ] && [ "${SKIDIMM_CHECK:-1}" != 0 ]; then check=1; fi
if [ "$check" -eq 1 ]; then
  # The sanitizer tree needs nothing from the Release one, so it is built
  # beside the Release build and suite, at a lower priority: it takes the
  # cycles they leave idle (link steps, the one-core stretches of the
  # reproductions) and the rest after them, instead of starting only when
  # they have ended. Its own session, so that a failure here stops it too.
  mkdir -p "$build"
  sanitizer_log=$build/sanitizer-build.log
  setsid nice -n 10 "$root/scripts/check.sh" --build-only >"$sanitizer_log" 2>&1 &
  sanitizer_build=$!
  trap 'kill -- -"$sanitizer_build" 2>/dev/null || true' EXIT
fi
"$root/scripts/build.sh"
cd "$build"
if [ "$quick" -eq 1 ]; then
  exec ctest --output-on-failure -j "$jobs" -LE slow
fi
ctest --output-on-failure -j "$jobs"
if [ "$check" -eq 1 ]; then
  wait "$sanitizer_build" || {
    tail -n 60 "$sanitizer_log" >&2
    echo "test.sh: the sanitizer build failed (the whole log: $sanitizer_log)" >&2
    exit 1
  }
  trap - EXIT
  # 20 s per fuzz target keeps the whole script within CI's budget on two
  # cores (README); longer runs are for check.sh by hand (tests/fuzz/README.md).
  # shellcheck disable=SC2086 # word splitting of the arguments is intended
  SKIDIMM_FUZZ_SECONDS=${SKIDIMM_FUZZ_SECONDS:-20} "$root/scripts/check.sh" --skip-build ${SKIDIMM_CHECK_ARGS:-}
fi
