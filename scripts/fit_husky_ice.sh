#!/usr/bin/env bash
# Fits ltc_linear to the real Husky ice logs: runs 01-09 for fitting, 10 and
# 11 (driven faster) held out. Writes configs/husky/ice_ltc.yaml and the fit
# report (with held-out errors) to configs/husky/ice_ltc.report.
#   scripts/fit_husky_ice.sh [data dir, default ../shared/data/husky_ice]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
source scripts/same_bits.sh
data=${1:-../shared/data/husky_ice}
skidimm=${SKIDIMM:-build/bin/skidimm}
[ -d "$data" ] || { echo "$0: no Husky data at $data" >&2; exit 1; }
logs=()
for run in 01 02 03 04 05 06 07 08 09; do logs+=(--log "$data/TSyn_$run.csv+$data/joint_states_$run.csv"); done
"$skidimm" fit --bank configs/husky/ice_ltc_start.yaml --mode ice --objective window --window 0 "${logs[@]}" \
  --held-out "$data/TSyn_10.csv+$data/joint_states_10.csv" \
  --held-out "$data/TSyn_11.csv+$data/joint_states_11.csv" \
  --output-bank configs/husky/ice_ltc.yaml 2>&1 | sed "s|$data/||g" | tee configs/husky/ice_ltc.report
