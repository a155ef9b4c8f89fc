#!/usr/bin/env bash
# Reruns scripts/reproduce_tuning.sh into a temporary copy of docs/tuning.md
# and checks that its tables are what the code produces now.
#   tuning_reproduce_test.sh <source dir> <skidimm> <work dir>
set -euo pipefail
source=$1
skidimm=$2
work=$3
rm -rf "$work"
mkdir -p "$work"
# shellcheck source=../show_log_on_failure.sh
source "$(dirname "$0")/../show_log_on_failure.sh"
show_log_on_failure "$work/log.txt"
cp "$source/docs/tuning.md" "$work/tuning.md"
SKIDIMM="$skidimm" SKIDIMM_TUNING_DIR="$work/run" SKIDIMM_TUNING_MD="$work/tuning.md" \
  "$source/scripts/reproduce_tuning.sh" 20 2>"$work/log.txt"
if ! diff "$source/docs/tuning.md" "$work/tuning.md" >"$work/tuning.diff"; then
  echo "FAIL: docs/tuning.md is not what scripts/reproduce_tuning.sh produces now:" >&2
  head -n 30 "$work/tuning.diff" >&2
  exit 1
fi
echo "docs/tuning.md reproduced"
