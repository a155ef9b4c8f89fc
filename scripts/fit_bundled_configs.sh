#!/usr/bin/env bash
# Regenerates the bundled banks by fitting the physically derived starting
# points to simulated maneuvers, as the paper's authors fitted theirs to
# skidpad, clothoid and sinusoidal runs. Every number in the bundled banks
# comes from this script.
#
#   scripts/fit_bundled_configs.sh [output dir, default configs]
#
# Two sensor sets (docs/simulation.md):
#  * ideal: the simulator's ideal sensors; configs/physical/*.yaml fitted to
#    them give configs/{ltc_terrains,ltc_shared,stc_slip4,stc_slip16,stc_sided4,stc_sided16}.yaml,
#    whose R is the ideal sensors' own noise (labelled so in docs/results.md).
#  * realistic: a Husky-class robot's sensors (sensors: {preset: husky});
#    configs/physical/realistic/*.yaml (a data-sheet prior R) fitted to them,
#    then R (per measurement) and a scale on Q estimated by `skidimm tune` on
#    other logs, give configs/realistic/*.yaml. No R is copied from the simulator.
#    Only these sensors measure motor currents, so only they have the sided
#    model with currents (stc_traction4, stc_traction16), which also measures
#    the gyro and the currents (measurement.outputs), each mode with its own
#    noise for them (fit --output-noise: its residuals on its fitting logs).
#
# Each mode is driven through four 20 s maneuvers with a fixed seed: skidpads
# turning left and right (asymmetric slip turns differently each way), a
# clothoid sweeping curvature from -1.2 to +1.2 1/m, and sinusoidal steering.
# Seeds: scripts/seeds.sh (bundled_fit_first_seed), one per mode from each
# set's first, times 10 plus the maneuver's index.
# Logs go to ${SKIDIMM_FIT_LOGS:-build/fit_logs}.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
out=${1:-configs}
logs=${SKIDIMM_FIT_LOGS:-build/fit_logs}
skidimm=${SKIDIMM:-build/bin/skidimm}
[ -x "$skidimm" ] || { echo "$0: build skidimm first (scripts/build.sh)" >&2; exit 1; }
source scripts/seeds.sh
source scripts/same_bits.sh
mkdir -p "$out" "$out/realistic" "$logs" "$logs/realistic" "$logs/realistic_tune"

maneuvers=(
  "skidpad_left|{type: skidpad, speed: 0.9, radius: 1.5, direction: left}"
  "skidpad_right|{type: skidpad, speed: 0.9, radius: 1.5, direction: right}"
  "clothoid|{type: clothoid, speed: 0.8, initial_curvature: -1.2, curvature_rate: 0.12}"
  "sinusoidal|{type: sinusoidal, speed: 0.7, yaw_rate_amplitude: 0.9, period: 5}"
)
ideal_sensors="{rate: 50, jitter: 0.3, gps_rate: 10}"
realistic_sensors="{preset: husky}"

# simulate DIR MODE "TERRAIN" "[TARP]" SEED "SENSORS" -> prints the --log arguments
simulate() {
  local dir=$1 mode=$2 terrain=$3 tarp=$4 seed=$5 sensors=$6 args=() i
  for i in 0 1 2 3; do
    local entry=${maneuvers[$i]}
    local name=${entry%%|*} maneuver=${entry#*|}
    local scenario="$dir/${mode}_${name}.yaml" log="$dir/${mode}_${name}.csv"
    cat >"$scenario" <<SCENARIO
name: fit_${mode}_${name}
duration: 20
modes: {${mode}: {terrain: ${terrain}, tarp: [${tarp}]}}
mode: ${mode}
maneuver: ${maneuver}
sensors: ${sensors}
SCENARIO
    "$skidimm" simulate -q --scenario "$scenario" --output "$log" --seed $((seed * 10 + i))
    args+=(--log "${mode}=${log}")
  done
  echo "${args[@]}"
}

# ltc_logs DIR SEED "SENSORS" -> --log arguments of the three terrains (seeds SEED..SEED+2)
ltc_logs() {
  local dir=$1 seed=$2 sensors=$3 args=()
  for terrain in asphalt grass crushed_concrete; do
    read -r -a more <<<"$(simulate "$dir" "$terrain" "$terrain" "" "$seed" "$sensors")"
    args+=("${more[@]}")
    seed=$((seed + 1))
  done
  echo "${args[@]}"
}

# stc_logs DIR SEED "SENSORS" -> --log arguments of the 16 slip modes (seeds SEED..SEED+15)
wheels=(FL FR RL RR)
stc_logs() {
  local dir=$1 seed=$2 sensors=$3 args=()
  for mask in $(seq 0 15); do
    local tarp=() name=""
    for w in 0 1 2 3; do
      if (((mask >> w) & 1)); then tarp+=("${wheels[$w]}"); name+="_${wheels[$w]}"; fi
    done
    local mode=${name:+slip$name}
    mode=${mode:-no_slip}
    read -r -a more <<<"$(simulate "$dir" "$mode" asphalt "$(IFS=,; echo "${tarp[*]:-}")" "$seed" "$sensors")"
    args+=("${more[@]}")
    seed=$((seed + 1))
  done
  echo "${args[@]}"
}

# four_of "--log M=F ..." -> the --log arguments of the paper's four slip modes
four_of() {
  local all=("$@") picked=()
  for ((i = 0; i < ${#all[@]}; i += 2)); do
    case "${all[$((i + 1))]}" in
      no_slip=* | slip_FL_FR=* | slip_FR_RR=* | slip_FL_FR_RL_RR=*) picked+=(--log "${all[$((i + 1))]}") ;;
    esac
  done
  echo "${picked[@]}"
}

fit() {  # fit STARTING_BANK OUTPUT REPORT ARGS...
  local bank=$1 output=$2 report=$3
  shift 3
  "$skidimm" fit --bank "$bank" --objective window "$@" --output-bank "$output" 2>"$report"
}

# Four independent pipelines share the cores: the ideal banks, and the
# realistic banks of each STC model (slip, sided, traction; the realistic LTC
# banks with the first). Each writes its own files.
ideal() {
  echo "== ideal sensors: LTC terrains" >&2
  local ltc stc stc4
  read -r -a ltc <<<"$(ltc_logs "$logs" "$(bundled_fit_first_seed ideal ltc)" "$ideal_sensors")"
  fit configs/physical/ltc_terrains.yaml "$out/ltc_terrains.yaml" "$logs/ltc_terrains.report" --window 0.5 "${ltc[@]}"
  fit configs/physical/ltc_shared.yaml "$out/ltc_shared.yaml" "$logs/ltc_shared.report" --window 0.5 --shared "${ltc[@]}"
  echo "== ideal sensors: STC slip modes" >&2
  read -r -a stc <<<"$(stc_logs "$logs" "$(bundled_fit_first_seed ideal stc)" "$ideal_sensors")"
  read -r -a stc4 <<<"$(four_of "${stc[@]}")"
  for model in slip sided; do
    fit "configs/physical/stc_${model}16.yaml" "$out/stc_${model}16.yaml" "$logs/stc_${model}16.report" --window 1 "${stc[@]}"
    fit "configs/physical/stc_${model}4.yaml" "$out/stc_${model}4.yaml" "$logs/stc_${model}4.report" --window 1 "${stc4[@]}"
  done
}
ideal &
ideal_job=$!

echo "== realistic sensors: simulating fitting and tuning logs" >&2
read -r -a ltc_fit <<<"$(ltc_logs "$logs/realistic" "$(bundled_fit_first_seed realistic ltc)" "$realistic_sensors")"
read -r -a stc_fit <<<"$(stc_logs "$logs/realistic" "$(bundled_fit_first_seed realistic stc)" "$realistic_sensors")"
read -r -a stc4_fit <<<"$(four_of "${stc_fit[@]}")"
read -r -a ltc_tune <<<"$(ltc_logs "$logs/realistic_tune" "$(bundled_fit_first_seed realistic_tune ltc)" \
  "$realistic_sensors")"
read -r -a stc_tune <<<"$(stc_logs "$logs/realistic_tune" "$(bundled_fit_first_seed realistic_tune stc)" \
  "$realistic_sensors")"
read -r -a stc4_tune <<<"$(four_of "${stc_tune[@]}")"
fitted="$logs/realistic/fitted"
mkdir -p "$fitted"

tune() {  # tune BANK KNOBS ARGS...: every log is one mode's; leave-one-log-out
  local bank=$1 knobs=$2 result="$out/realistic/$1.yaml"
  shift 2
  "$skidimm" tune -q --bank "$fitted/$bank.yaml" "$@" --objective none --tune "$knobs" --no-assess \
    --threads 1 --output-bank "$result" >"$fitted/$bank.tune" 2>&1
  # The header of the tuned bank says how it was tuned; add how it was fitted.
  { grep '^#' "$result"
    echo "# Its models were fitted, from configs/physical/realistic/$bank.yaml, by:"
    grep '^#   skidimm fit' "$fitted/$bank.yaml"
    grep -v '^#' "$result"; } >"$result.partial"
  mv "$result.partial" "$result"
}
realistic() {  # realistic MODEL: fit, then estimate R and the scale of Q with skidimm tune
  local model=$1 own=() knobs=r-components,q-scale
  echo "== realistic sensors: stc_${model}, fitting and tuning" >&2
  # A bank that measures its models' outputs gives each mode its own noise for
  # them: the gyro and currents as well as that mode's model predicts them.
  # The gyro is then heard, 50 times a second, and its errors, a model's
  # miss that lasts through a turn, are far from independent from one sample
  # to the next: tune also chooses the likelihood weight that tempers them.
  if [ "$model" = traction ]; then
    own=(--output-noise)
    knobs=r-components,q-scale,likelihood-weight
  fi
  fit "configs/physical/realistic/stc_${model}16.yaml" "$fitted/stc_${model}16.yaml" "$fitted/stc_${model}16.report" \
    --window 1 "${own[@]}" "${stc_fit[@]}"
  fit "configs/physical/realistic/stc_${model}4.yaml" "$fitted/stc_${model}4.yaml" "$fitted/stc_${model}4.report" \
    --window 1 "${own[@]}" "${stc4_fit[@]}"
  tune "stc_${model}16" "$knobs" "${stc_tune[@]}"
  tune "stc_${model}4" "$knobs" "${stc4_tune[@]}"
  if [ "$model" = slip ]; then
    echo "== realistic sensors: LTC, fitting and tuning" >&2
    fit configs/physical/realistic/ltc_terrains.yaml "$fitted/ltc_terrains.yaml" "$fitted/ltc_terrains.report" \
      --window 0.5 "${ltc_fit[@]}"
    fit configs/physical/realistic/ltc_shared.yaml "$fitted/ltc_shared.yaml" "$fitted/ltc_shared.report" \
      --window 0.5 --shared "${ltc_fit[@]}"
    tune ltc_terrains r-components,q-scale "${ltc_tune[@]}"
    tune ltc_shared r-components,q-scale "${ltc_tune[@]}"
  fi
}
realistic slip &
slip_job=$!
realistic sided &
sided_job=$!
# The sided model with motor currents: only the realistic sensors measure them.
realistic traction &
traction_job=$!
status=0
for job in $ideal_job $slip_job $sided_job $traction_job; do wait "$job" || status=1; done
[ $status -eq 0 ] || { echo "$0: a fitting pipeline failed (reports in $logs)" >&2; exit 1; }
echo "wrote $out/{ltc_terrains,ltc_shared,stc_slip4,stc_slip16,stc_sided4,stc_sided16}.yaml, the same under" \
  "$out/realistic/ with stc_traction{4,16}.yaml; fit reports and tuning tables in $logs" >&2
