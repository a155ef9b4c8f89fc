#!/usr/bin/env bash
# The real-data results of docs/real-data.md, regenerated between its
# <!-- real:NAME --> markers, and the bank configs/borealtc/terrains.yaml.
#
#  A. Husky on ice (shared/data/husky_ice, one terrain): the ltc_linear model
#     fitted by the window and by the likelihood objective on runs 01-09;
#     runs 10 and 11 (driven faster) held out.
#  B. BorealTC (shared/data/borealtc: five terrains, 47 runs, multi-rate):
#     `skidimm tune` from configs/borealtc/terrains_start.yaml with nested
#     leave-one-run-out cross-validation: every run is scored by a bank whose
#     models were fitted, and whose likelihood weight, Q and R scales and
#     probability floor were tuned, on the other 46 runs only (the dwell time
#     is the start bank's: single-terrain runs cannot tell how often terrain
#     changes). `skidimm eval --estimates`
#     recomputes every metric from the held-out outputs tune wrote; the
#     script checks that both agree. The bank fitted and tuned on every run
#     is configs/borealtc/terrains.yaml.
#  C. Switches: the last run of each terrain is held out, a bank is tuned on
#     the other 42 runs, and the five held-out runs are spliced end to end
#     in five rotations (scripts/splice_runs.py): 20 changes of terrain the
#     bank never saw, scored as switches.
#
#   scripts/reproduce_real_data.sh [shared data dir, default ../shared/data]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
data=${1:-../shared/data}
skidimm=${SKIDIMM:-build/bin/skidimm}
work=${SKIDIMM_REAL_DATA_DIR:-build/real_data}
doc=${SKIDIMM_REAL_DATA_MD:-docs/real-data.md}
bank_out=${SKIDIMM_REAL_DATA_BANK:-configs/borealtc/terrains.yaml}
figure=${SKIDIMM_REAL_DATA_FIGURE:-docs/images/real_data_splice.png}
python=$(command -v /usr/bin/python3 || command -v python3)
[ -x "$skidimm" ] || { echo "$0: build skidimm first (scripts/build.sh)" >&2; exit 1; }
[ -d "$data/husky_ice" ] && [ -d "$data/borealtc" ] || { echo "$0: no shared data at $data" >&2; exit 1; }
rm -rf "$work"
mkdir -p "$work"/{husky,borealtc,splices}
terrains=(ASPHALT FLOORING ICE SANDY_LOAM SNOW)

echo "== A: Husky on ice" >&2
ice=$data/husky_ice
logs=()
for run in 01 02 03 04 05 06 07 08 09; do logs+=(--log "$ice/TSyn_$run.csv+$ice/joint_states_$run.csv"); done
for objective in window likelihood; do
  "$skidimm" fit --bank configs/husky/ice_ltc_start.yaml --mode ice --objective "$objective" "${logs[@]}" \
    --held-out "$ice/TSyn_10.csv+$ice/joint_states_10.csv" --held-out "$ice/TSyn_11.csv+$ice/joint_states_11.csv" \
    --output-bank "$work/husky/ice_$objective.yaml" 2>&1 | sed "s|$ice/||g" >"$work/husky/$objective.report"
done

echo "== B: BorealTC, nested leave-one-run-out" >&2
bt=$data/borealtc
logs=()
for terrain in "${terrains[@]}"; do logs+=(--log "$terrain=$bt/$terrain/pro_*.csv+$bt/$terrain/imu_*.csv"); done
tune=(--objective window --hold-unexcited --full-q --tune likelihood-weight,q-scale,r-scale,floor --inner-folds 0)
"$skidimm" tune -q --bank configs/borealtc/terrains_start.yaml "${logs[@]}" "${tune[@]}" \
  --table "$work/borealtc/scores.csv" --estimates "$work/borealtc/held_out" --output-bank "$work/borealtc/terrains.yaml" \
  >"$work/borealtc/tune.txt"
sed "s|$bt/||g; s|$data/||g" "$work/borealtc/terrains.yaml" >"$bank_out"
# The same bank reading ROS 2 bags follows it (scripts/derive_ros2_config.py).
if [ "$bank_out" = configs/borealtc/terrains.yaml ]; then python3 scripts/derive_ros2_config.py; fi
"$skidimm" eval --estimates "$work/borealtc/held_out/logs" --bank "$bank_out" --json >"$work/borealtc/eval.json"
"$skidimm" eval --estimates "$work/borealtc/held_out/logs" --bank "$bank_out" >"$work/borealtc/eval.txt"

echo "== C: spliced runs" >&2
held=()
training=()
for terrain in "${terrains[@]}"; do
  runs=($(ls "$bt/$terrain" | sed -n 's/^pro_\([0-9]*\)\.csv$/\1/p' | sort))
  last=${runs[${#runs[@]} - 1]}
  held+=("$terrain/$last")
  for run in "${runs[@]}"; do
    [ "$run" = "$last" ] || training+=(--log "$terrain=$bt/$terrain/pro_$run.csv+$bt/$terrain/imu_$run.csv")
  done
done
"$skidimm" tune -q --bank configs/borealtc/terrains_start.yaml "${training[@]}" "${tune[@]}" --no-assess \
  --output-bank "$work/splices/bank.yaml" >"$work/splices/tune.txt"
for k in 0 1 2 3 4; do
  order=("${held[@]:$k}" "${held[@]:0:$k}")
  "$python" scripts/splice_runs.py "$work/splices/logs" "rotation_$k" "$bt" "${order[@]}"
done
splices=()
for k in 0 1 2 3 4; do splices+=("$work/splices/logs/pro_rotation_$k.csv+$work/splices/logs/imu_rotation_$k.csv"); done
"$skidimm" eval --bank "$work/splices/bank.yaml" --input "${splices[@]}" --json >"$work/splices/eval.json"
"$skidimm" eval --bank "$work/splices/bank.yaml" --input "${splices[@]}" >"$work/splices/eval.txt"
"$skidimm" run -q --bank "$work/splices/bank.yaml" --input "${splices[0]}" --output "$work/splices/rotation_0.csv"
mkdir -p "$(dirname "$figure")"
"$skidimm" plot --estimates "$work/splices/rotation_0.csv" --output "$figure" \
  --title "BorealTC runs spliced end to end, scored by a bank tuned without them"

"$python" scripts/real_data_tables.py "$work" "$doc" "$bt"
echo "updated $doc and $bank_out" >&2
