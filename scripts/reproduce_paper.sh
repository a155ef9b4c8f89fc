#!/usr/bin/env bash
# Reproduces the paper's experiments (section V) with the simulator and the
# fitted banks, over many seeds, and regenerates the tables and figures of
# docs/results.md (between its <!-- results:NAME --> markers).
#   scripts/reproduce_paper.sh [seeds, default 20]
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
eval_seeds=$(paper_eval_seeds "$seeds")
check_disjoint "$eval_seeds" "$(bundled_fit_seeds)" "$(tuning_fit_seeds)" "$(decision_default_seeds)"
first_seed=$(echo "$eval_seeds" | head -n 1)
rm -rf "$work/logs" "$work/eval"  # a rerun must not score last run's logs
mkdir -p "$work/logs" "$work/eval" "$figures"

scenarios=(ltc_singular_crushed_concrete ltc_singular_grass ltc_singular_asphalt ltc_switching
           stc_singular_no_slip stc_singular_slip_FL_FR stc_singular_slip_FR_RR stc_singular_slip_FL_FR_RL_RR
           stc_switching)
echo "== simulating ${#scenarios[@]} scenarios x $seeds seeds" >&2
for scenario in "${scenarios[@]}"; do
  mkdir -p "$work/logs/$scenario"
  for seed in $eval_seeds; do
    "$skidimm" simulate -q --scenario "configs/scenarios/$scenario.yaml" \
      --output "$work/logs/$scenario/seed_$seed.csv" --seed "$seed"
  done
done

echo "== evaluating" >&2
evaluate() {  # evaluate NAME BANK SCENARIO...
  local name=$1 bank=$2
  shift 2
  local inputs=()
  for s in "$@"; do inputs+=(--input "$work/logs/$s"); done
  "$skidimm" eval --bank "configs/$bank.yaml" "${inputs[@]}" --json >"$work/eval/${name}__${bank}.json"
  "$skidimm" eval --bank "configs/$bank.yaml" "${inputs[@]}" --smooth --json >"$work/eval/${name}__${bank}__smoothed.json"
}
for bank in ltc_terrains ltc_shared; do
  evaluate ltc_singular "$bank" ltc_singular_crushed_concrete ltc_singular_grass ltc_singular_asphalt
  evaluate ltc_switching "$bank" ltc_switching
done
for bank in stc_slip4 stc_slip16; do
  evaluate stc_singular "$bank" stc_singular_no_slip stc_singular_slip_FL_FR stc_singular_slip_FR_RR \
    stc_singular_slip_FL_FR_RL_RR
  evaluate stc_switching "$bank" stc_switching
done

echo "== figures (seed $first_seed)" >&2
figure() {  # figure SCENARIO BANK
  local out="$work/run_${1}__${2}.csv"
  "$skidimm" run -q --bank "configs/$2.yaml" --input "$work/logs/$1/seed_$first_seed.csv" --output "$out"
  "$skidimm" plot --estimates "$out" --output "$figures/${1}__${2}.png" --title "$1, bank $2 (seed $first_seed)"
}
for s in ltc_singular_crushed_concrete ltc_singular_grass ltc_singular_asphalt ltc_switching; do figure "$s" ltc_terrains; done
for s in stc_singular_no_slip stc_singular_slip_FL_FR stc_singular_slip_FR_RR stc_singular_slip_FL_FR_RL_RR stc_switching; do
  figure "$s" stc_slip4
done

"$python" scripts/results_tables.py "$work/eval" "$results" "$seeds"
echo "updated $results and $figures/" >&2
