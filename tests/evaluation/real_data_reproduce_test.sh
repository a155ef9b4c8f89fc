#!/usr/bin/env bash
# Reruns scripts/reproduce_real_data.sh into temporary copies of
# docs/real-data.md, configs/borealtc/terrains.yaml and wheels.yaml and
# checks that the published tables and the bundled banks are what the code
# produces now, on
# the shared real data. Skips (ctest code 77) when the data is absent.
#   real_data_reproduce_test.sh <source dir> <skidimm> <work dir> <shared data dir>
set -euo pipefail
source=$1
skidimm=$2
work=$3
data=$4
if [ ! -d "$data/borealtc" ] || [ ! -d "$data/husky_ice" ]; then
  echo "no shared data at $data: skipped"
  exit 77
fi
rm -rf "$work"
mkdir -p "$work"
# shellcheck source=../show_log_on_failure.sh
source "$(dirname "$0")/../show_log_on_failure.sh"
show_log_on_failure "$work/log.txt"
cp "$source/docs/real-data.md" "$work/real-data.md"
SKIDIMM="$skidimm" SKIDIMM_REAL_DATA_DIR="$work/run" SKIDIMM_REAL_DATA_MD="$work/real-data.md" \
  SKIDIMM_REAL_DATA_BANK="$work/terrains.yaml" SKIDIMM_REAL_DATA_WHEELS="$work/wheels.yaml" SKIDIMM_REAL_DATA_FIGURE="$work/splice.png" \
  "$source/scripts/reproduce_real_data.sh" "$data" 2>"$work/log.txt"
status=0
if ! diff "$source/docs/real-data.md" "$work/real-data.md" >"$work/real-data.diff"; then
  echo "FAIL: docs/real-data.md is not what scripts/reproduce_real_data.sh produces now:" >&2
  head -n 30 "$work/real-data.diff" >&2
  status=1
fi
# A bank's header holds the command with this run's paths: compare the rest.
for bank in terrains wheels; do
  if ! diff <(grep -v '^#' "$source/configs/borealtc/$bank.yaml") <(grep -v '^#' "$work/$bank.yaml") \
    >"$work/$bank.diff"; then
    echo "FAIL: configs/borealtc/$bank.yaml is not what the script produces now:" >&2
    head -n 20 "$work/$bank.diff" >&2
    status=1
  fi
done
[ -s "$work/splice.png" ] || { echo "FAIL: no figure" >&2; status=1; }
[ "$status" = 0 ] && echo "docs/real-data.md and configs/borealtc/{terrains,wheels}.yaml reproduced"
exit "$status"
