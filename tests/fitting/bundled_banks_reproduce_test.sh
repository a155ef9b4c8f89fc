#!/usr/bin/env bash
# Reruns scripts/fit_bundled_configs.sh into a temporary directory and checks
# that it reproduces every bundled bank (all but the recorded command line),
# for the ideal sensors (configs/) and a Husky-class robot's (configs/realistic/,
# with the banks that measure motor currents).
#   bundled_banks_reproduce_test.sh <source dir> <skidimm> <work dir>
set -euo pipefail
source=$1
skidimm=$2
work=$3
rm -rf "$work"
mkdir -p "$work/out"
# shellcheck source=../show_log_on_failure.sh
source "$(dirname "$0")/../show_log_on_failure.sh"
show_log_on_failure "$work/log.txt"
SKIDIMM="$skidimm" SKIDIMM_FIT_LOGS="$work/logs" "$source/scripts/fit_bundled_configs.sh" "$work/out" 2>"$work/log.txt"
status=0
banks=(ltc_terrains ltc_shared stc_slip4 stc_slip16 stc_sided4 stc_sided16)
# The realistic stc_sided banks' mode slip_FR_RL is fitted with alpha_r_outer
# at its bound (100): its other parameters are determined to about 1e-3 only,
# and their last digits depend on more than the logs and the binary (on one
# machine this script gives x_icr -0.01133898 where the same fit run alone,
# and this script on another machine, give -0.01135847). Those two banks are
# compared to 1 % in each number, the text exactly; every other bank to the
# bit.
loose=" realistic/stc_sided4 realistic/stc_sided16 "
# Only the realistic sensors measure motor currents (stc_traction).
for bank in "${banks[@]}" "${banks[@]/#/realistic/}" realistic/stc_traction4 realistic/stc_traction16; do
  if ! diff <(grep -v '^#' "$source/configs/$bank.yaml") <(grep -v '^#' "$work/out/$bank.yaml") \
      >"$work/${bank//\//_}.diff"; then
    if [[ "$loose" == *" $bank "* ]] &&
      python3 "$(dirname "$0")/same_numbers.py" "$source/configs/$bank.yaml" "$work/out/$bank.yaml" 1e-2 >&2; then
      echo "configs/$bank.yaml reproduced to 1 % in each number (the text exactly), not to the bit" >&2
      continue
    fi
    echo "FAIL: configs/$bank.yaml differs from what scripts/fit_bundled_configs.sh produces:" >&2
    head -n 20 "$work/${bank//\//_}.diff" >&2
    status=1
  fi
done
[ $status -eq 0 ] && echo "all bundled banks reproduced"
exit $status
