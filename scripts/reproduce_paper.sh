#!/usr/bin/env bash
# Reproduces the paper's experiments (section V) with the simulator and the
# fitted banks, over many seeds, and regenerates the tables and figures of
# docs/results.md (between its <!-- results:NAME --> markers).
#   scripts/reproduce_paper.sh [seeds, default 20]
#
# Every experiment runs twice: with the simulator's ideal sensors
# (configs/scenarios/*.yaml, scored with the banks in configs/, whose R is
# those sensors' own noise) and with a Husky-class robot's sensors
# (configs/scenarios/realistic/*.yaml, scored with configs/realistic/, whose R
# skidimm tune estimated). The STC experiments compare eq. 3 (stc_slip*) with
# the sided model (stc_sided*), with 4 and 16 modes, and with a Husky's
# sensors the sided model that also measures the gyro and the motor currents
# (stc_traction*).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
seeds=${1:-20}
skidimm=${SKIDIMM:-build/bin/skidimm}
work=${SKIDIMM_PAPER_DIR:-build/paper}
figures=${SKIDIMM_FIGURES_DIR:-docs/images/results}
results=${SKIDIMM_RESULTS_MD:-docs/results.md}
python=$(command -v /usr/bin/python3 || command -v python3)
[ -x "$skidimm" ] || { echo "$0: build skidimm first (scripts/build.sh)" >&2; exit 1; }
source scripts/seeds.sh
source scripts/same_bits.sh
eval_seeds=$(paper_eval_seeds "$seeds")
check_disjoint "$eval_seeds" "$(bundled_fit_seeds)" "$(tuning_fit_seeds)" "$(decision_default_seeds)" "$(model_selection_seeds)" "$(window_protocol_seeds)"
# The decision's settings are weighed on seeds of their own: none may be a fitting one either.
check_disjoint "$(decision_default_seeds)" "$(bundled_fit_seeds)" "$(tuning_fit_seeds)" "$(model_selection_seeds)" "$(window_protocol_seeds)"
first_seed=${eval_seeds%%$'\n'*}  # no `| head`: with pipefail, echo's SIGPIPE (it writes line by line) would end the script
rm -rf "$work/logs" "$work/eval" "$work/banks" "$work/kinematics" "$work/decision_defaults" "$work/model_selection"  # a rerun must not score last run's logs
mkdir -p "$work/logs" "$work/eval" "$work/banks" "$work/kinematics" "$figures/realistic"

scenarios=(ltc_singular_crushed_concrete ltc_singular_grass ltc_singular_asphalt ltc_switching
           stc_singular_no_slip stc_singular_slip_FL_FR stc_singular_slip_FR_RR stc_singular_slip_FL_FR_RL_RR
           stc_switching)
scenario_file() {  # scenario_file SENSORS SCENARIO
  if [ "$1" = ideal ]; then echo "configs/scenarios/$2.yaml"; else echo "configs/scenarios/$1/$2.yaml"; fi
}
bank_file() {  # bank_file SENSORS BANK
  if [ "$1" = ideal ]; then echo "configs/$2.yaml"; else echo "configs/$1/$2.yaml"; fi
}

echo "== simulating ${#scenarios[@]} scenarios x $seeds seeds x 2 sensor sets" >&2
simulate_all() {  # simulate_all SENSORS
  local sensors=$1 scenario seed
  for scenario in "${scenarios[@]}"; do
    mkdir -p "$work/logs/$sensors/$scenario"
    for seed in $eval_seeds; do
      "$skidimm" simulate -q --scenario "$(scenario_file "$sensors" "$scenario")" \
        --output "$work/logs/$sensors/$scenario/seed_$seed.csv" --seed "$seed"
    done
  done
}
# Each sensor set on its own core.
run_both() {  # run_both FUNCTION: FUNCTION ideal and FUNCTION realistic in parallel
  "$1" ideal &
  local ideal_job=$!
  local status=0
  "$1" realistic || status=1
  wait "$ideal_job" || status=1
  [ $status -eq 0 ] || { echo "$0: $1 failed" >&2; exit 1; }
}
run_both simulate_all

echo "== evaluating" >&2
stc_banks_of() {  # stc_banks_of SENSORS: the STC banks scored with those sensors, on one line
  local banks=(stc_slip4 stc_sided4 stc_slip16 stc_sided16)
  # Only a Husky's sensors measure motor currents.
  [ "$1" != realistic ] || banks+=(stc_traction4 stc_traction16)
  echo "${banks[@]}"
}
evaluate() {  # evaluate NAME SENSORS BANK SCENARIO...
  local name=$1 sensors=$2 bank=$3
  shift 3
  local inputs=()
  for s in "$@"; do inputs+=(--input "$work/logs/$sensors/$s"); done
  local file
  file=$(bank_file "$sensors" "$bank")
  "$skidimm" eval --bank "$file" "${inputs[@]}" --json >"$work/eval/${name}__${sensors}__${bank}.json"
  # Every bank is smoothed too, the 16-mode ones included, although their
  # 16^2 mode pairs per step make that a large part of this script's time.
  "$skidimm" eval --bank "$file" "${inputs[@]}" --smooth --json \
    >"$work/eval/${name}__${sensors}__${bank}__smoothed.json"
}
evaluate_all() {  # evaluate_all SENSORS
  local sensors=$1 bank
  for bank in ltc_terrains ltc_shared; do
    evaluate ltc_singular "$sensors" "$bank" ltc_singular_crushed_concrete ltc_singular_grass ltc_singular_asphalt
    evaluate ltc_switching "$sensors" "$bank" ltc_switching
  done
  local stc_banks
  read -r -a stc_banks <<<"$(stc_banks_of "$sensors")"
  for bank in "${stc_banks[@]}"; do
    evaluate stc_singular "$sensors" "$bank" stc_singular_no_slip stc_singular_slip_FL_FR stc_singular_slip_FR_RR \
      stc_singular_slip_FL_FR_RL_RR
    evaluate stc_switching "$sensors" "$bank" stc_switching
  done
}
run_both evaluate_all

# The decision's default settings against others, on switching logs of
# their own seeds (decision_default_seeds; results_tables.py,
# decision_defaults_table): each bank runs once over each log, and every
# candidate setting remakes the decision from the probabilities it wrote
# (eval --estimates --decision-*). The defaults are skidimm's compiled ones,
# which a run's summary names.
echo "== the decision's settings on their own switching logs" >&2
compiled_defaults=$("$skidimm" run --bank configs/ltc_terrains.yaml --input configs/examples/ltc_switching.csv \
  --output "$work/decision_defaults_probe.csv" 2>&1 >/dev/null |
  sed -n 's/.*the decision (enter \([^,]*\), leave \([^,]*\), hold \([^ ]*\) s).*/\1,\2,\3/p')
[ -n "$compiled_defaults" ] || { echo "$0: skidimm run's summary names no decision settings" >&2; exit 1; }
choice="$work/decision_defaults"
rm -rf "$choice"
mkdir -p "$choice/eval"
choose_all() {  # choose_all SENSORS
  local sensors=$1 scenario seed bank banks
  for scenario in ltc_switching stc_switching; do
    mkdir -p "$choice/logs/$sensors/$scenario"
    for seed in $(decision_default_seeds); do
      "$skidimm" simulate -q --scenario "$(scenario_file "$sensors" "$scenario")" \
        --output "$choice/logs/$sensors/$scenario/seed_$seed.csv" --seed "$seed"
    done
    if [ "$scenario" = ltc_switching ]; then banks=(ltc_terrains ltc_shared); else read -r -a banks <<<"$(stc_banks_of "$sensors")"; fi
    for bank in "${banks[@]}"; do
      local runs="$choice/runs/$sensors/$scenario/$bank"
      mkdir -p "$runs"
      for seed in $(decision_default_seeds); do
        "$skidimm" run -q --bank "$(bank_file "$sensors" "$bank")" \
          --input "$choice/logs/$sensors/$scenario/seed_$seed.csv" --output "$runs/seed_$seed.csv"
      done
      # Every candidate setting, the runs' files read once.
      "$skidimm" eval --estimates "$runs" --bank "$(bank_file "$sensors" "$bank")" --json \
        --decision-enter 0.55,0.6,0.65,0.7,0.75,0.8,0.85,0.9,0.95 --decision-leave 0.02,0.05,0.1 \
        --decision-hold 0.5,1,2 >"$choice/eval/${scenario}__${sensors}__${bank}.json"
    done
  done
}
run_both choose_all

# The traction banks on the spirals kept for choices about their model
# (model_selection_seeds), next to the scored seeds: the model was reworked
# while its scores on the scored seeds were read (results.md, "How the
# traction model was chosen").
echo "== the traction banks on the model-selection seeds" >&2
selection="$work/model_selection"
rm -rf "$selection"
mkdir -p "$selection/eval"
selection_scenarios=(stc_singular_no_slip stc_singular_slip_FL_FR stc_singular_slip_FR_RR stc_singular_slip_FL_FR_RL_RR)
for scenario in "${selection_scenarios[@]}"; do
  mkdir -p "$selection/logs/$scenario"
  for seed in $(model_selection_seeds); do
    "$skidimm" simulate -q --scenario "$(scenario_file realistic "$scenario")" \
      --output "$selection/logs/$scenario/seed_$seed.csv" --seed "$seed"
  done
done
select_bank() {  # select_bank BANK
  local inputs=() scenario
  for scenario in "${selection_scenarios[@]}"; do inputs+=(--input "$selection/logs/$scenario"); done
  "$skidimm" eval --bank "$(bank_file realistic "$1")" "${inputs[@]}" --json \
    >"$selection/eval/stc_singular__realistic__$1.json"
}
select_bank stc_traction4 &
selection_job=$!
select_bank stc_traction16
wait "$selection_job"

# What the evaluation maneuver lets a filter see: every wheel configuration
# driven through the spiral (noise-free truth columns; the seed only moves
# the sample times).
echo "== the 16 wheel configurations on the spiral" >&2
wheels=(FL FR RL RR)
for mask in $(seq 0 15); do
  tarp=() name=""
  for w in 0 1 2 3; do
    if (((mask >> w) & 1)); then tarp+=("${wheels[$w]}"); name+="_${wheels[$w]}"; fi
  done
  mode=${name:+slip$name}
  mode=${mode:-no_slip}
  cat >"$work/kinematics/$mode.yaml" <<SCENARIO
name: spiral_$mode
duration: 30
modes: {$mode: {terrain: asphalt, tarp: [$(IFS=,; echo "${tarp[*]:-}")]}}
mode: $mode
maneuver: {type: spiral, speed: 0.8, initial_radius: 0.6, radius_rate: 0.12}
sensors: {rate: 50, jitter: 0.3, gps_rate: 10}
SCENARIO
  "$skidimm" simulate -q --scenario "$work/kinematics/$mode.yaml" --output "$work/kinematics/$mode.csv" \
    --seed "$first_seed"
done

echo "== figures (seed $first_seed)" >&2
figure() {  # figure SENSORS SCENARIO BANK
  local out="$work/run_${1}_${2}__${3}.csv"
  "$skidimm" run -q --bank "$(bank_file "$1" "$3")" --input "$work/logs/$1/$2/seed_$first_seed.csv" --output "$out"
  "$skidimm" plot --estimates "$out" --output "$figures/$1/${2}__${3}.png" \
    --title "$2, $1 sensors, bank $3 (seed $first_seed)"
}
for s in ltc_singular_crushed_concrete ltc_singular_grass ltc_singular_asphalt ltc_switching; do
  figure realistic "$s" ltc_terrains
done
for s in stc_singular_no_slip stc_singular_slip_FL_FR stc_singular_slip_FR_RR stc_singular_slip_FL_FR_RL_RR stc_switching; do
  figure realistic "$s" stc_slip4
  figure realistic "$s" stc_sided4
  figure realistic "$s" stc_traction4
done

"$python" scripts/results_tables.py "$work/eval" "$results" "$seeds" "$work/kinematics" \
  --decision-defaults "$choice/eval" --compiled-defaults "$compiled_defaults" \
  --model-selection "$selection/eval" --model-selection-seeds "$(model_selection_seeds | tr '\n' ' ')"
echo "updated $results and $figures/" >&2
