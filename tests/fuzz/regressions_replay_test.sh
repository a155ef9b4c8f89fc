#!/usr/bin/env bash
# Replays every fuzz regression input (tests/fuzz/regressions/, one per row
# of the robustness findings' table and per finding) through the skidimm command a user
# would run on it, in the ordinary build: the fuzzers themselves need a clang
# sanitizer build (scripts/check.sh), this needs none. Each must end without
# a signal or a hang, an error must name its file and carry no raw control
# byte, and a run that succeeds must have written only finite states and
# non-negative variances.
#   regressions_replay_test.sh <source dir> <skidimm> <work dir>
set -euo pipefail
source=$1
skidimm=$2
work=$3
regressions=$source/tests/fuzz/regressions
rm -rf "$work"
mkdir -p "$work"
failures=0
# The inputs a command must accept (a regression input is otherwise bad, and
# must be refused): a floor just under 1/N is a valid bank since the floor is
# exact; outliers and unused odd cells in a log are the filter's business,
# not errors; an unknown truth label is scored as a class of its own.
accepted=(
  bank_loader_fuzzer/row11_floor_one_third.yaml
  log_reader_fuzzer/row01_measurement_1e150.csv
  log_reader_fuzzer/row03_input_1e200.csv
  log_reader_fuzzer/row06_true_state_1e-320.csv
  log_reader_fuzzer/row08_escape_utf8_nul_in_log.csv
  estimates_reader_fuzzer/row08_escape_in_truth.csv
)
should_accept() {
  local name=${1#"$regressions"/}
  for a in "${accepted[@]}"; do [ "$a" = "$name" ] && return 0; done
  return 1
}
# Accepted inputs exit 0; refused ones exit non-zero with a message naming the file.
check_outcome() {
  local status=$1 input=$2 messages=$3
  if should_accept "$input"; then
    [ "$status" -eq 0 ] || fail "$input: refused (exit $status): $(head -c 300 "$messages")"
  else
    [ "$status" -ne 0 ] || fail "$input: accepted, but it is bad input"
    [ "$status" -eq 0 ] || check_names_file "$messages" "$input"
  fi
}
fail() {
  echo "FAIL: $*" >&2
  failures=$((failures + 1))
}

# Exit status below 124: no signal, no timeout (timeout(1) gives 124).
check_ended() {
  local status=$1 input=$2
  if [ "$status" -ge 124 ]; then fail "$input: exit $status (signal or hang)"; return 1; fi
}
# A message is safe to print: no ESC, no other C0 control byte but tab and newline.
check_printable() {
  local file=$1 input=$2
  if LC_ALL=C grep -q -P '[\x00-\x08\x0b-\x1f\x7f]' "$file"; then fail "$input: raw control bytes in $(basename "$file")"; fi
}
check_names_file() {
  local file=$1 input=$2
  grep -qF "$(basename "$input")" "$file" || fail "$input: the error does not name the file: $(head -c 300 "$file")"
}
# Every state and variance cell of a run output is finite, every var_ cell >= 0.
check_estimates() {
  local output=$1 input=$2
  awk -F, 'NR == 1 { for (i = 1; i <= NF; ++i) if ($i ~ /^var_/) var[i] = 1; next }
           { for (i = 1; i <= NF; ++i) {
               if (tolower($i) ~ /^[-+]?(nan|inf)/) { print "row " NR - 1 " column " i ": " $i; exit 1 }
               if ((i in var) && $i + 0 < 0) { print "row " NR - 1 " column " i ": negative variance " $i; exit 1 } } }' \
    "$output" >"$work/estimates_check.txt" || fail "$input: $(cat "$work/estimates_check.txt")"
}

for input in "$regressions"/bank_loader_fuzzer/*; do
  status=0
  timeout 60 "$skidimm" validate "$input" >"$work/out.txt" 2>"$work/err.txt" || status=$?
  check_ended "$status" "$input" || continue
  check_outcome "$status" "$input" "$work/err.txt"
  check_printable "$work/err.txt" "$input"
done

for input in "$regressions"/log_reader_fuzzer/*; do
  status=0
  timeout 60 "$skidimm" run -q --bank "$source/configs/ltc_terrains.yaml" --input "$input" --output "$work/run.csv" \
    2>"$work/err.txt" || status=$?
  check_ended "$status" "$input" || continue
  check_outcome "$status" "$input" "$work/err.txt"
  [ "$status" -ne 0 ] || check_estimates "$work/run.csv" "$input"
  check_printable "$work/err.txt" "$input"
  rm -f "$work/run.csv"
done

for input in "$regressions"/scenario_loader_fuzzer/*; do
  status=0
  timeout 60 "$skidimm" simulate -q --scenario "$input" --output "$work/sim.csv" 2>"$work/err.txt" || status=$?
  check_ended "$status" "$input" || continue
  check_outcome "$status" "$input" "$work/err.txt"
  [ "$status" -eq 0 ] || [ ! -e "$work/sim.csv" ] || fail "$input: a log was written"
  rm -f "$work/sim.csv"
  check_printable "$work/err.txt" "$input"
done

for input in "$regressions"/estimates_reader_fuzzer/*; do
  status=0
  timeout 60 "$skidimm" eval --estimates "$input" >"$work/out.txt" 2>"$work/err.txt" || status=$?
  check_ended "$status" "$input" || continue
  check_outcome "$status" "$input" "$work/err.txt"
  check_printable "$work/out.txt" "$input"
  check_printable "$work/err.txt" "$input"
done

# A checkpoint is refused before any row is read (the example log starts before every regression's time).
for input in "$regressions"/checkpoint_reader_fuzzer/*; do
  status=0
  timeout 60 "$skidimm" run -q --bank "$source/tests/fuzz/checkpoint_bank.yaml" \
    --input "$source/configs/examples/ltc_switching.csv" --output "$work/out.csv" --resume "$input" \
    >"$work/out.txt" 2>"$work/err.txt" || status=$?
  check_ended "$status" "$input" || continue
  check_outcome "$status" "$input" "$work/err.txt"
  check_printable "$work/err.txt" "$input"
done

count=$(find "$regressions" -type f | wc -l)
[ "$count" -gt 0 ] || fail "no regression inputs under $regressions"
[ "$failures" -eq 0 ] && echo "$count regression inputs replayed"
exit $((failures > 0))
