#!/usr/bin/env bash
# Reruns scripts/reproduce_paper.sh into a temporary copy of docs/results.md
# and checks that every published table is what the code produces now.
#   results_reproduce_test.sh <source dir> <skidimm> <work dir>
set -euo pipefail
source=$1
skidimm=$2
work=$3
rm -rf "$work"
mkdir -p "$work"
# shellcheck source=../show_log_on_failure.sh
source "$(dirname "$0")/../show_log_on_failure.sh"
show_log_on_failure "$work/log.txt"
cp "$source/docs/results.md" "$work/results.md"
SKIDIMM="$skidimm" SKIDIMM_PAPER_DIR="$work/paper" SKIDIMM_FIGURES_DIR="$work/figures" \
  SKIDIMM_RESULTS_MD="$work/results.md" "$source/scripts/reproduce_paper.sh" 20 2>"$work/log.txt"
if ! diff "$source/docs/results.md" "$work/results.md" >"$work/results.diff"; then
  echo "FAIL: docs/results.md is not what scripts/reproduce_paper.sh produces now:" >&2
  head -n 30 "$work/results.diff" >&2
  exit 1
fi
figures=$(find "$work/figures" -name '*.png' | wc -l)
[ "$figures" -gt 0 ] || { echo "FAIL: no figures in $work/figures" >&2; exit 1; }
while IFS= read -r f; do [ -s "$f" ] || { echo "FAIL: empty figure $f" >&2; exit 1; }; done \
  < <(find "$work/figures" -name '*.png')
echo "docs/results.md reproduced"
