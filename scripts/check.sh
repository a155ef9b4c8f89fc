#!/usr/bin/env bash
# The sanitizer stage (./scripts/test.sh --sanitizers runs it beside the gate,
# at a lower priority, with 5 s per fuzz target; see README):
#
#   ./scripts/check.sh           ASan+UBSan build, the test suite under it, each fuzz target for a bounded time
#   ./scripts/check.sh --tsan    also the ThreadSanitizer build and its thread-safety tests
#   ./scripts/check.sh --only-tsan
#   ./scripts/check.sh --build-only   only configure and build the ASan+UBSan tree
#   ./scripts/check.sh --skip-build   the suite and the fuzzers on the tree built before
#
# ASan+UBSan: one clang build at -O1 (SKIDIMM_SANITIZE=address), undefined
# behaviour fatal (-fno-sanitize-recover), of the core, the plugins, the CLI,
# the GoogleTest binaries (their own code with ASan only and unoptimized: tests/CMakeLists.txt)
# and the libFuzzer targets (tests/fuzz) - no Python
# package, no benchmarks. The suite runs without the reproduction tests (ctest
# names matching 'Reproduced|reproduce'): they rerun the paper's and the
# real-data experiments, about 14 minutes on two cores in Release and many
# times that under ASan; the Release suite runs them. Nor the
# OutOfTree tests (see below). Each fuzz
# target then runs for SKIDIMM_FUZZ_SECONDS (default 60) from the seed corpus
# (configs/ and tests/fuzz/corpus) and the committed regression inputs.
# Any sanitizer report, fuzzer finding or failing test fails the script.
#
# TSan: a second, tiny build (core, plugins, skidimm_thread_tests) running the
# tests that pin the thread-safety claims of imm.h, bank.h,
# plugin_registry.h and live_log.h (docs/engine.md, "Thread safety").
#
# Builds live under the build directory: $SKIDIMM_BUILD_DIR/sanitize-address
# and .../sanitize-thread. Installs what it needs first (setup.sh --sanitizers:
# clang, libclang-rt-14-dev, llvm-14).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${SKIDIMM_BUILD_DIR:-$root/build}
jobs=${SKIDIMM_JOBS:-$(nproc 2>/dev/null || echo 2)}
fuzz_seconds=${SKIDIMM_FUZZ_SECONDS:-60}
asan=1
tsan=0
build_asan=1
test_asan=1
for arg in "$@"; do
  case "$arg" in
    --tsan) tsan=1 ;;
    --only-tsan) asan=0; tsan=1 ;;
    --build-only) test_asan=0 ;;
    --skip-build) build_asan=0 ;;
    -h|--help) sed -n '2,30p' "$0"; exit 0 ;;
    *) echo "check.sh: unknown argument '$arg' (see --help)" >&2; exit 2 ;;
  esac
done

stamp() { echo "check.sh: $* ($(date -u +%H:%M:%S))" >&2; }

"$root/scripts/setup.sh" --sanitizers

# configure DIR ARGS...: clang, Release flags overridden to -O1 by the
# sanitizer options, no Python package, no benchmarks. Every target in unity
# batches: this tree is built from cold for a run of the suite, never edited
# file by file, and a batch of sources shares the parse of the headers they
# have in common (the core library and the test executables about halve).
# The instrumented builds compile the IMM's fixed-size kernels for the bundled
# banks' shapes only (SKIDIMM_FIXED_SIZE_KERNELS, CMakeLists.txt): each shape
# is the same template, and the engine then compiles in a third of the time.
configure() {
  local dir=$1; shift
  mkdir -p "$dir"
  CC=clang CXX=clang++ cmake -S "$root" -B "$dir" -DCMAKE_BUILD_TYPE=Release -DSKIDIMM_BUILD_TESTS=ON \
    -DSKIDIMM_BUILD_PYTHON=OFF -DSKIDIMM_BUILD_BENCHMARKS=OFF -DCMAKE_UNITY_BUILD=ON -DSKIDIMM_FIXED_SIZE_KERNELS=bundled "$@" >"$dir/configure.log" 2>&1 || {
    cat "$dir/configure.log" >&2
    exit 1
  }
}

export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}

if [ "$asan" -eq 1 ]; then
  dir=$build/sanitize-address
  if [ "$build_asan" -eq 1 ]; then
    stamp "ASan+UBSan build in $dir"
    configure "$dir" -DSKIDIMM_SANITIZE=address -DSKIDIMM_BUILD_FUZZERS=ON
    cmake --build "$dir" -j "$jobs"
  fi
  if [ "$test_asan" -eq 0 ]; then
    stamp "ASan+UBSan build done"
    exit 0
  fi
  stamp "ASan+UBSan test suite (without the reproduction tests)"
  export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=0:strict_string_checks=1:detect_stack_use_after_return=1}
  # Not the OutOfTree and Install tests either: they install this build (and
  # OutOfTree links a plain, uninstrumented program against it, which needs
  # the sanitizer runtime it does not have); they test packaging, which the
  # Release suite covers.
  (cd "$dir" && ctest --output-on-failure -j "$jobs" -E 'Reproduced|reproduce|OutOfTree|Install\.')
  # One fuzz target: one libFuzzer process, on one core.
  fuzz() {
    local fuzzer=$1 work f
    stamp "fuzzing $fuzzer for ${fuzz_seconds} s"
    work=$dir/fuzz/$fuzzer
    rm -rf "$work" && mkdir -p "$work/corpus" "$work/seeds" "$work/findings"
    local seeds=()
    case "$fuzzer" in
      bank_loader_fuzzer) seeds=("$root"/configs/*.yaml "$root"/configs/{physical,realistic,borealtc,husky}/*.yaml
                                 "$root"/tests/fixtures/banks/*.yaml) ;;
      scenario_loader_fuzzer) mapfile -t seeds < <(find "$root/configs/scenarios" -name '*.yaml') ;;
    esac
    seeds+=("$root/tests/fuzz/corpus/$fuzzer"/* "$root/tests/fuzz/regressions/$fuzzer"/*)
    for f in "${seeds[@]}"; do
      # Named after their path: configs/ltc_terrains.yaml and configs/physical/ltc_terrains.yaml both count.
      if [ -f "$f" ]; then cp "$f" "$work/seeds/$(echo "${f#"$root"/}" | tr / _)"; fi
    done
    # -max_len: the bundled banks are up to a few KB; longer inputs only slow
    # each run. Findings go to $work/findings (crash-*, leak-*, timeout-*).
    (cd "$work" && "$dir/bin/$fuzzer" corpus seeds -max_total_time="$fuzz_seconds" -max_len=16384 -timeout=20 \
       -rss_limit_mb=2048 -artifact_prefix=findings/ -print_final_stats=1 >"$work/log" 2>&1) || {
      tail -n 60 "$work/log" >&2
      echo "check.sh: $fuzzer found a problem; the input is in $work/findings/" >&2
      exit 1
    }
    grep -E '^stat::number_of_executed_units|^#[0-9]+.*DONE' "$work/log" | tail -n 2 | sed "s/^/$fuzzer: /" >&2 || true
  }
  # $jobs targets at a time (one per core). A finding fails the
  # stage once the targets still running have ended (each is bounded by
  # -max_total_time), so no fuzzer outlives the script.
  running=()
  finish_one() {
    local pid=${running[0]}
    running=("${running[@]:1}")
    wait "$pid" || {
      wait || true
      exit 1
    }
  }
  # Every target tests/fuzz builds (its list), so that a new one is fuzzed here without a second list to keep.
  mapfile -t fuzzers < <(sed -n '/^set(SKIDIMM_FUZZ_TARGETS/,/)/p' "$root/tests/fuzz/CMakeLists.txt" |
    grep -o '[a-z_]*_fuzzer')
  [ "${#fuzzers[@]}" -gt 0 ] || { echo "check.sh: no fuzz targets listed in tests/fuzz/CMakeLists.txt" >&2; exit 1; }
  for fuzzer in "${fuzzers[@]}"; do
    fuzz "$fuzzer" &
    running+=("$!")
    if [ "${#running[@]}" -ge "$jobs" ]; then finish_one; fi
  done
  while [ "${#running[@]}" -gt 0 ]; do finish_one; done
  stamp "ASan+UBSan stage passed"
fi

if [ "$tsan" -eq 1 ]; then
  dir=$build/sanitize-thread
  stamp "TSan build in $dir"
  configure "$dir" -DSKIDIMM_SANITIZE=thread
  cmake --build "$dir" -j "$jobs" --target skidimm_thread_tests
  stamp "TSan thread-safety tests"
  TSAN_OPTIONS=${TSAN_OPTIONS:-halt_on_error=1:second_deadlock_stack=1} "$dir/bin/skidimm_thread_tests"
  stamp "TSan stage passed"
fi
