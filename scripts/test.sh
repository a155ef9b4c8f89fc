#!/usr/bin/env bash
# The test command: installs dependencies, builds everything, runs every test.
# CI runs this script.
#   ./scripts/test.sh               the gate
#   ./scripts/test.sh --quick       the loop while editing: an incremental build and
#                                   every test but those labelled `slow` (the
#                                   reproductions, the install, demo and
#                                   out-of-tree packaging tests)
#   ./scripts/test.sh --sanitizers  the gate and, beside it, the sanitizer stage
#                                   (scripts/check.sh: a clang build with ASan+UBSan,
#                                   the suite under it without the reproduction
#                                   tests, each fuzz target for SKIDIMM_FUZZ_SECONDS,
#                                   set below); SKIDIMM_CHECK_ARGS is passed to
#                                   check.sh (e.g. --tsan)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${SKIDIMM_BUILD_DIR:-$root/build}
jobs=${SKIDIMM_JOBS:-$(nproc 2>/dev/null || echo 2)}
quick=0
sanitizers=0
for arg in "$@"; do
  case "$arg" in
    --quick) quick=1 ;;
    --sanitizers) sanitizers=1 ;;
    -h|--help) sed -n '2,14p' "$0"; exit 0 ;;
    *) echo "test.sh: unknown argument '$arg' (see --help)" >&2; exit 2 ;;
  esac
done
if [ "$quick" -eq 1 ] && [ "$sanitizers" -eq 1 ]; then
  echo "test.sh: --quick and --sanitizers do not go together (the stage is a cold build of its own)" >&2
  exit 2
fi
# Everything either half needs, installed before they start side by side
# (two apt-get runs at once would fight over dpkg's lock).
if [ "$sanitizers" -eq 1 ]; then "$root/scripts/setup.sh" --sanitizers; else "$root/scripts/setup.sh"; fi
# The sanitizer stage is not in the gate by default: its second, instrumented
# build of everything and its suite cost about as much CPU as the Release
# build and suite together, against the gate's budget of 20 minutes from
# cold on two cores (README). It runs on request, and by hand before a release.
if [ "$sanitizers" -eq 1 ]; then
  # The whole sanitizer stage runs beside the Release build and suite: it
  # needs nothing from them, and on two cores the gate is bound by the CPU
  # time of all its parts together, so the stage fills the cycles they leave
  # idle (link steps, the one-core stretches of the reproductions) instead of
  # starting only when they have ended. Its own session, so that a failure
  # here stops it too; with Linux's autogroup (Debian's default) a session is
  # scheduled as a group, so the nice value only orders the stage's own
  # processes and the two halves share the cores evenly. 5 s per fuzz target
  # here; the corpus and the regression inputs are replayed whole in any
  # case, and longer runs are for check.sh alone (tests/fuzz/README.md).
  mkdir -p "$build"
  sanitizer_log=$build/sanitizer.log
  # shellcheck disable=SC2086 # word splitting of the arguments is intended
  SKIDIMM_FUZZ_SECONDS=${SKIDIMM_FUZZ_SECONDS:-5} setsid nice -n 10 "$root/scripts/check.sh" ${SKIDIMM_CHECK_ARGS:-} \
    >"$sanitizer_log" 2>&1 &
  sanitizer_stage=$!
  trap 'kill -- -"$sanitizer_stage" 2>/dev/null || true' EXIT
fi
# The gate builds from cold: every target in unity batches, which share the
# parse of the headers their sources have in common (a third less CPU for the
# build). The quick loop keeps what the tree was configured with.
if [ "$quick" -eq 0 ]; then export SKIDIMM_UNITY_BUILD=${SKIDIMM_UNITY_BUILD:-ON}; fi
"$root/scripts/build.sh"
cd "$build"
if [ "$quick" -eq 1 ]; then
  exec ctest --output-on-failure -j "$jobs" -LE slow
fi
ctest --output-on-failure -j "$jobs"
if [ "$sanitizers" -eq 1 ]; then
  echo "test.sh: the Release suite passed; waiting for the sanitizer stage ($sanitizer_log)" >&2
  status=0
  wait "$sanitizer_stage" || status=$?
  trap - EXIT
  # The stage's own report (its build's output stays in the log).
  sed -n '/ASan+UBSan test suite/,$p' "$sanitizer_log"
  if [ "$status" -ne 0 ]; then
    tail -n 60 "$sanitizer_log" >&2
    echo "test.sh: the sanitizer stage failed (the whole log: $sanitizer_log)" >&2
    exit 1
  fi
fi
