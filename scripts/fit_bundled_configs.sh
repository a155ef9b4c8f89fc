#!/usr/bin/env bash
# Regenerates the bundled banks (configs/*.yaml) by fitting the physically
# derived starting points (configs/physical/*.yaml) to simulated maneuvers,
# as the paper's authors fitted theirs to skidpad, clothoid and sinusoidal
# runs. Every number in the bundled banks comes from this script.
#
#   scripts/fit_bundled_configs.sh [output dir, default configs]
#
# Each mode is driven through four 20 s maneuvers with a fixed seed: skidpads
# turning left and right (asymmetric slip turns differently each way), a
# clothoid sweeping curvature from -1.2 to +1.2 1/m, and sinusoidal steering.
# Logs go to ${SKIDIMM_FIT_LOGS:-build/fit_logs}.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
out=${1:-configs}
logs=${SKIDIMM_FIT_LOGS:-build/fit_logs}
skidimm=${SKIDIMM:-build/bin/skidimm}
[ -x "$skidimm" ] || { echo "$0: build skidimm first (scripts/build.sh)" >&2; exit 1; }
mkdir -p "$out" "$logs"

maneuvers=(
  "skidpad_left|{type: skidpad, speed: 0.9, radius: 1.5, direction: left}"
  "skidpad_right|{type: skidpad, speed: 0.9, radius: 1.5, direction: right}"
  "clothoid|{type: clothoid, speed: 0.8, initial_curvature: -1.2, curvature_rate: 0.12}"
  "sinusoidal|{type: sinusoidal, speed: 0.7, yaw_rate_amplitude: 0.9, period: 5}"
)

# simulate MODE "TERRAIN" "[TARP]" SEED -> prints the --log arguments
simulate() {
  local mode=$1 terrain=$2 tarp=$3 seed=$4 args=() i=0
  for entry in "${maneuvers[@]}"; do
    local name=${entry%%|*} maneuver=${entry#*|}
    local scenario="$logs/${mode}_${name}.yaml" log="$logs/${mode}_${name}.csv"
    cat >"$scenario" <<SCENARIO
name: fit_${mode}_${name}
duration: 20
modes: {${mode}: {terrain: ${terrain}, tarp: [${tarp}]}}
mode: ${mode}
maneuver: ${maneuver}
sensors: {rate: 50, jitter: 0.3, gps_rate: 10}
SCENARIO
    "$skidimm" simulate -q --scenario "$scenario" --output "$log" --seed $((seed * 10 + i))
    args+=(--log "${mode}=${log}")
    i=$((i + 1))
  done
  echo "${args[@]}"
}

echo "== LTC terrains" >&2
ltc_logs=()
seed=100
for terrain in asphalt grass crushed_concrete; do
  read -r -a more <<<"$(simulate "$terrain" "$terrain" "" "$seed")"
  ltc_logs+=("${more[@]}")
  seed=$((seed + 1))
done
"$skidimm" fit --bank configs/physical/ltc_terrains.yaml --objective window --window 0.5 "${ltc_logs[@]}" \
  --output-bank "$out/ltc_terrains.yaml" 2>"$logs/ltc_terrains.report"
"$skidimm" fit --bank configs/physical/ltc_shared.yaml --objective window --window 0.5 --shared "${ltc_logs[@]}" \
  --output-bank "$out/ltc_shared.yaml" 2>"$logs/ltc_shared.report"

echo "== STC slip modes" >&2
wheels=(FL FR RL RR)
stc_logs=()
seed=200
for mask in $(seq 0 15); do
  tarp=() name=""
  for w in 0 1 2 3; do
    if (((mask >> w) & 1)); then tarp+=("${wheels[$w]}"); name+="_${wheels[$w]}"; fi
  done
  mode=${name:+slip$name}
  mode=${mode:-no_slip}
  read -r -a more <<<"$(simulate "$mode" asphalt "$(IFS=,; echo "${tarp[*]:-}")" "$seed")"
  stc_logs+=("${more[@]}")
  seed=$((seed + 1))
done
"$skidimm" fit --bank configs/physical/stc_slip16.yaml --objective window --window 1 "${stc_logs[@]}" \
  --output-bank "$out/stc_slip16.yaml" 2>"$logs/stc_slip16.report"
slip4_logs=()
for ((i = 0; i < ${#stc_logs[@]}; i += 2)); do
  case "${stc_logs[$((i + 1))]}" in
    no_slip=* | slip_FL_FR=* | slip_FR_RR=* | slip_FL_FR_RL_RR=*) slip4_logs+=(--log "${stc_logs[$((i + 1))]}") ;;
  esac
done
"$skidimm" fit --bank configs/physical/stc_slip4.yaml --objective window --window 1 "${slip4_logs[@]}" \
  --output-bank "$out/stc_slip4.yaml" 2>"$logs/stc_slip4.report"
echo "wrote $out/{ltc_terrains,ltc_shared,stc_slip4,stc_slip16}.yaml; fit reports in $logs/*.report" >&2
