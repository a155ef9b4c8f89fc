#!/usr/bin/env bash
# The real-data results of docs/real-data.md, regenerated between its
# <!-- real:NAME --> markers, and the banks configs/borealtc/terrains.yaml
# and configs/borealtc/wheels.yaml.
#
#  A. Husky on ice (shared/data/husky_ice, one terrain): the ltc_linear model
#     fitted by the window and by the likelihood objective on runs 01-09;
#     runs 10 and 11 (driven faster) held out.
#  B. BorealTC (shared/data/borealtc: five terrains, 47 runs, multi-rate).
#     A lockbox of 10 runs (scripts/borealtc_lockbox.py: a quarter of each
#     terrain, seeded) was drawn before the design was chosen; the design
#     (configs/borealtc/terrains_start.yaml against physics_start.yaml, the
#     Student-t likelihood, which settings tune searches, each mode's
#     parameter uncertainty, partial pooling of their fits) was chosen on the
#     other 37, the development runs, and scored on the lockbox here.
#     B1. The design: `skidimm tune --parameter-uncertainty --partial-pooling` on the
#         development runs with every protocol
#         of nested assessment (each log held out; each session held out;
#         per terrain, the fastest and the most-turning runs held out), and
#         the lockbox scored by the bank tuned on the development runs.
#         `skidimm eval --estimates` recomputes each protocol's metrics,
#         with calibration, from the held-out outputs tune wrote.
#     B1b. The first design, frozen and scored on the lockbox before the
#         others: the same without parameter uncertainty, on the protocols
#         that hold out several runs at a time (each session; the fastest;
#         the most-turning), as every comparison of designs here, and the
#         lockbox.
#     B1c. A third design, tried and not kept: each mode's parameter
#         uncertainty with each log's rows counted as correlated, on the
#         same protocols and the lockbox.
#     B1d. The second design, the design without partial pooling, on the
#         same protocols and the lockbox.
#     B2. The physics-shaped alternative with parameter uncertainty, on the
#         same runs and protocols, against the design, and the rule that
#         picks one of the two inside each fold by the fold's inner
#         cross-validation (from both --table files);
#         B2d. the first design with an unknown hypothesis, on the
#         extrapolation protocols; B2f. the first design and the design
#         with the extrapolation discount, on the extrapolation protocols;
#         B2c. the first design with correlated innovations, on the
#         extrapolation protocols and on development runs spliced end to end.
#     B3. The bundled bank: the design fitted and tuned on all 47 runs.
#     B4. Without an IMU: the wheel-only bank, each development log held out
#         and the lockbox, then fitted and tuned on all 47 runs.
#  C. Changes of terrain: the lockbox runs spliced end to end in five
#     rotations of the terrains (scripts/borealtc_splices.py), scored by the
#     bank tuned on the development runs only.
#     C2. The price of a quicker reaction: the same splices scored with the
#         development bank's likelihood weight multiplied by 2, 4 and 8
#         (nothing chosen by it), and the weight a search scoring spliced
#         development runs chooses.
#
#   scripts/reproduce_real_data.sh [shared data dir, default ../shared/data]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
source scripts/same_bits.sh
data=${1:-../shared/data}
skidimm=${SKIDIMM:-build/bin/skidimm}
work=${SKIDIMM_REAL_DATA_DIR:-build/real_data}
doc=${SKIDIMM_REAL_DATA_MD:-docs/real-data.md}
bank_out=${SKIDIMM_REAL_DATA_BANK:-configs/borealtc/terrains.yaml}
wheels_out=${SKIDIMM_REAL_DATA_WHEELS:-configs/borealtc/wheels.yaml}
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

echo "== B: BorealTC" >&2
bt=$data/borealtc
# The lockbox: a quarter of each terrain's runs, drawn with a fixed seed and
# kept aside from every design choice.
mapfile -t lockbox < <("$python" scripts/borealtc_lockbox.py "$bt")
# Looked up in an array, not with `printf | grep -q`: with pipefail, printf's
# SIGPIPE when grep stops at a match would make the test false at random.
declare -A in_lockbox=()
for run in "${lockbox[@]}"; do in_lockbox[$run]=1; done
develop=()   # --log arguments: the development runs
aside=()     # --lockbox arguments
for terrain in "${terrains[@]}"; do
  for file in "$bt/$terrain"/pro_*.csv; do
    run=$(basename "$file" .csv); run=${run#pro_}
    log="$terrain=$bt/$terrain/pro_$run.csv+$bt/$terrain/imu_$run.csv"
    if [ -n "${in_lockbox[$terrain/$run]:-}" ]; then aside+=(--lockbox "$log"); else develop+=(--log "$log"); fi
  done
done
all=("${develop[@]}")
for ((i = 1; i < ${#aside[@]}; i += 2)); do all+=(--log "${aside[$i]}"); done
# Both extrapolation protocols rank runs by the same expressions of the wheel
# speeds, whatever the bank's inputs, so both forms hold out the same runs.
speed='speed=abs(velL + velR) / 2'
turn='turn=abs(velR - velL)'
protocols="logs,sessions,extrapolation:$speed,extrapolation:$turn"
# The first and third designs and the physics-shaped form (B1b, B1c, B2) are compared with the design on the
# protocols that hold out several runs at a time: each run held out alone, the costliest (a search
# per development run), leaves the runs recorded with it in training; it scores the design (B1) and
# the wheel-only bank (B4).
compared="sessions,extrapolation:$speed,extrapolation:$turn"
# How every tune here fits and searches: each inner fold holds out one log (--inner-folds 0), except
# step C2's splice-scored search, which needs several logs per inner fold; each log-spaced setting is
# walked from its start (--walk), with fewer runs than its whole grid. When the walk was adopted,
# no number this script publishes moved: on these runs it chose what the grid chose, in every fold.
inner() { echo --objective window --hold-unexcited --full-q --walk --inner-folds "$1"; }
read -ra fit <<<"$(inner 0)"
# Which runs were recorded together, for the protocol that holds each session out.
by_session=(--sessions configs/borealtc/sessions.txt)
knobs=likelihood-weight,likelihood-dof,q-scale,r-scale,floor
# The design's parameter uncertainty: each mode's parameter covariance, its rows counted independent
# (the second design; the third counted each log's rows as correlated, step B1c), and the fits of
# the modes of one regime (turning, straight) pooled partially by it (the fourth, the design).
uncertainty=(--parameter-uncertainty --partial-pooling)

# B1. The design, scored.
"$skidimm" tune -q --bank configs/borealtc/terrains_start.yaml "${develop[@]}" "${aside[@]}" "${fit[@]}" \
  "${uncertainty[@]}" --tune "$knobs" --assess "$protocols" "${by_session[@]}" --table "$work/borealtc/scores.csv" \
  --estimates "$work/borealtc/held_out" --output-bank "$work/borealtc/development.yaml" >"$work/borealtc/tune.txt"
# How many runs of each terrain the data set's held-back test split holds (21 runs; counted for us by those
# who score it, not read from its data): each protocol's eval says the range a set of that many runs would
# score in, drawn as that protocol's held-out runs were.
held_back_split=ASPHALT=2,FLOORING=2,ICE=4,SANDY_LOAM=4,SNOW=9
for folder in "$work/borealtc/held_out"/*/; do
  name=$(basename "$folder")
  "$skidimm" eval --estimates "$folder" --bank "$work/borealtc/development.yaml" --range-for "$held_back_split" \
    --json >"$work/borealtc/eval_$name.json"
done

# Another design, tuned and assessed as the design is but on the compared protocols, and the
# lockbox: PREFIX_tune.txt, PREFIX_scores.csv, PREFIX_held_out/, PREFIX_development.yaml and
# PREFIX_eval_<protocol>.json. The arguments after PREFIX are its fit options beyond `fit`.
another_design() {
  local prefix=$1
  shift
  "$skidimm" tune -q --bank configs/borealtc/terrains_start.yaml "${develop[@]}" "${aside[@]}" "${fit[@]}" "$@" \
    --tune "$knobs" --assess "$compared" "${by_session[@]}" --table "$work/borealtc/${prefix}_scores.csv" \
    --estimates "$work/borealtc/${prefix}_held_out" --output-bank "$work/borealtc/${prefix}_development.yaml" \
    >"$work/borealtc/${prefix}_tune.txt"
  for folder in "$work/borealtc/${prefix}_held_out"/*/; do
    "$skidimm" eval --estimates "$folder" --bank "$work/borealtc/${prefix}_development.yaml" --json \
      >"$work/borealtc/${prefix}_eval_$(basename "$folder").json"
  done
}

# B1b. The first design: the same without each mode's parameter uncertainty. It was frozen and
# scored on the lockbox first; parameter uncertainty was added afterwards on the development runs'
# scores of both (the second design, B1, and B1b), and the lockbox scored the second design.
another_design first

# B1c. The third design: each mode's parameter uncertainty with each log's rows counted as correlated.
# It was taken by the rule the design's choices are made by, on the development runs' scores of it and
# the second design, while tune's search stopped at its sweeps' reach, and scored on the lockbox; with
# the search going on while the score rises, the same rule on the same protocols does not take it.
another_design correlated --parameter-uncertainty --uncertainty-per-log

# B1d. The second design: each mode's parameter uncertainty, without partial pooling. Partial pooling
# was added on the development runs' scores of both, by the rule the design's choices are made by,
# before the lockbox scored it.
another_design unpooled --parameter-uncertainty

# B2. The physics-shaped form with each mode's parameter uncertainty, as the design has it: the two
# forms compared as the bank would use them, on the same runs and compared protocols (no lockbox: it
# was not chosen), and the rule that picks one of the two inside each fold by the fold's inner
# cross-validation (from both --table files).
"$skidimm" tune -q --bank configs/borealtc/physics_start.yaml "${develop[@]}" "${fit[@]}" "${uncertainty[@]}" \
  --tune "$knobs" --assess "$compared" "${by_session[@]}" --table "$work/borealtc/physics_scores.csv" \
  >"$work/borealtc/physics_tune.txt"

# B2d. The first design with an explicit unknown hypothesis ("none of these": bank key `unknown:`, its
# covariance factor tuned inside each fold with the other knobs; enter 0.01 and leave 0.1 a step,
# fixed beforehand), on the same development runs and the two extrapolation protocols. Development
# only: the lockbox does not score this.
{ echo "unknown: {inflation: 100, enter: 0.01, leave: 0.1}"; cat configs/borealtc/terrains_start.yaml; } \
  >"$work/borealtc/unknown_start.yaml"
"$skidimm" tune -q --bank "$work/borealtc/unknown_start.yaml" "${develop[@]}" "${fit[@]}" --tune "$knobs,unknown-inflation" \
  --assess "extrapolation:$speed,extrapolation:$turn" \
  --table "$work/borealtc/unknown_scores.csv" --estimates "$work/borealtc/unknown_held_out" \
  >"$work/borealtc/unknown_tune.txt"
for slug in extrapolation-speed extrapolation-turn; do
  "$skidimm" eval --estimates "$work/borealtc/unknown_held_out/$slug" --bank "$work/borealtc/unknown_start.yaml" \
    --json >"$work/borealtc/unknown_eval_$slug.json"
done

# B2f. The first design and the design with the extrapolation discount (bank key `extrapolation_scale`:
# a terrain's evidence fades where the inputs leave the ranges its modes were fitted on), its scale
# tuned inside each fold with the other knobs, off among the candidates, on the same development runs
# and the two extrapolation protocols, where it is meant to help. Development only: the lockbox does
# not score this.
for variant in discount_first discount; do
  design_uncertainty=(); [ "$variant" = discount ] && design_uncertainty=("${uncertainty[@]}")
  "$skidimm" tune -q --bank configs/borealtc/terrains_start.yaml "${develop[@]}" "${fit[@]}" "${design_uncertainty[@]}" \
    --tune "$knobs,extrapolation-scale" --assess "extrapolation:$speed,extrapolation:$turn" \
    --table "$work/borealtc/${variant}_scores.csv" --estimates "$work/borealtc/${variant}_held_out" \
    >"$work/borealtc/${variant}_tune.txt"
  for slug in extrapolation-speed extrapolation-turn; do
    "$skidimm" eval --estimates "$work/borealtc/${variant}_held_out/$slug" --bank configs/borealtc/terrains_start.yaml \
      --json >"$work/borealtc/${variant}_eval_$slug.json"
  done
done

# B2c. The first design with correlated innovations (`--residual-correlation`: each mode's likelihood of a
# step conditioned on its last innovation, with the lag-1 correlation each fold fits on its training
# runs), on the same development runs and the two extrapolation protocols; the weight and the rest
# are tuned inside each fold as for the design. Then changes of terrain: development runs spliced
# end to end (five rotations, as C splices the lockbox), scored by the first design's development bank and
# by this one. Both banks were fitted on these runs, so the splices measure how fast each follows a
# change, not how well it generalises. Development only: the lockbox does not score this.
"$skidimm" tune -q --bank configs/borealtc/terrains_start.yaml "${develop[@]}" "${fit[@]}" --tune "$knobs" \
  --residual-correlation --assess "extrapolation:$speed,extrapolation:$turn" \
  --table "$work/borealtc/correlation_scores.csv" --estimates "$work/borealtc/correlation_held_out" \
  --output-bank "$work/borealtc/correlation_development.yaml" >"$work/borealtc/correlation_tune.txt"
for slug in extrapolation-speed extrapolation-turn; do
  "$skidimm" eval --estimates "$work/borealtc/correlation_held_out/$slug" --bank configs/borealtc/terrains_start.yaml \
    --json >"$work/borealtc/correlation_eval_$slug.json"
done
development_runs=()
for ((i = 1; i < ${#develop[@]}; i += 2)); do
  log=${develop[$i]}; terrain=${log%%=*}; run=${log##*/imu_}; development_runs+=("$terrain/${run%.csv}")
done
"$python" scripts/borealtc_splices.py "$work/splices/development_logs" "$bt" "${development_runs[@]}" \
  >"$work/splices/development_inputs.txt"
mapfile -t development_splices <"$work/splices/development_inputs.txt"
for bank in first_development correlation_development; do
  "$skidimm" eval --bank "$work/borealtc/$bank.yaml" --input "${development_splices[@]}" --json \
    >"$work/splices/${bank}_eval.json"
done

# B3. The bundled bank.
"$skidimm" tune -q --bank configs/borealtc/terrains_start.yaml "${all[@]}" "${fit[@]}" "${uncertainty[@]}" \
  --tune "$knobs" --no-assess --output-bank "$work/borealtc/terrains.yaml" >"$work/borealtc/final_tune.txt"
sed "s|$bt/||g; s|$data/||g" "$work/borealtc/terrains.yaml" >"$bank_out"
# The same bank reading ROS 2 bags follows it (scripts/derive_ros2_config.py).
if [ "$bank_out" = configs/borealtc/terrains.yaml ]; then "$python" scripts/derive_ros2_config.py; fi

# B4. Without an IMU: the wheel file of each run alone.
wheel_develop=(); wheel_aside=(); wheel_all=()
for ((i = 1; i < ${#develop[@]}; i += 2)); do wheel_develop+=(--log "${develop[$i]%%+*}"); done
for ((i = 1; i < ${#aside[@]}; i += 2)); do wheel_aside+=(--lockbox "${aside[$i]%%+*}"); done
for ((i = 1; i < ${#all[@]}; i += 2)); do wheel_all+=(--log "${all[$i]%%+*}"); done
"$skidimm" tune -q --bank configs/borealtc/wheels_start.yaml "${wheel_develop[@]}" "${wheel_aside[@]}" "${fit[@]}" \
  --tune "$knobs" --assess logs --table "$work/borealtc/wheels_scores.csv" --estimates "$work/borealtc/wheels_held_out" \
  --output-bank "$work/borealtc/wheels_development.yaml" >"$work/borealtc/wheels_tune.txt"
for held in logs lockbox; do
  "$skidimm" eval --estimates "$work/borealtc/wheels_held_out/$held" --bank "$work/borealtc/wheels_development.yaml" \
    --range-for "$held_back_split" --json >"$work/borealtc/wheels_eval_$held.json"
done
"$skidimm" tune -q --bank configs/borealtc/wheels_start.yaml "${wheel_all[@]}" "${fit[@]}" --tune "$knobs" --no-assess \
  --output-bank "$work/borealtc/wheels.yaml" >"$work/borealtc/wheels_final_tune.txt"
sed "s|$bt/||g; s|$data/||g" "$work/borealtc/wheels.yaml" >"$wheels_out"

echo "== C: the lockbox spliced" >&2
"$python" scripts/borealtc_splices.py "$work/splices/logs" "$bt" "${lockbox[@]}" >"$work/splices/inputs.txt"
mapfile -t splices <"$work/splices/inputs.txt"
"$skidimm" eval --bank "$work/borealtc/development.yaml" --input "${splices[@]}" --json >"$work/splices/eval.json"
"$skidimm" run -q --bank "$work/borealtc/development.yaml" --input "${splices[0]}" --output "$work/splices/rotation_0.csv"
mkdir -p "$(dirname "$figure")"
"$skidimm" plot --estimates "$work/splices/rotation_0.csv" --bank "$work/borealtc/development.yaml" --output "$figure" \
  --title "BorealTC lockbox runs spliced end to end, scored by a bank tuned without them"

echo "== C2: the price of a quicker reaction" >&2
# The same lockbox splices, scored by the development bank with its likelihood weight multiplied by
# 2, 4 and 8: what a user who raises the weight for a quicker reaction gets on runs no fit or choice
# saw. Nothing is chosen by these scores; the bundled bank keeps its tuned weight. Then what a
# search that scores spliced development runs (--splice, five inner folds so that each held-out set
# holds several terrains) chooses, without assessment.
weight=$(sed -n 's/^likelihood_weight: //p' "$work/borealtc/development.yaml")
for factor in 2 4 8; do
  scaled=$("$python" -c "print(f'{min(1.0, $weight * $factor):.10g}')")
  echo "$scaled" >"$work/borealtc/weight_x$factor.txt"
  "$skidimm" eval --bank "$work/borealtc/development.yaml" --input "${splices[@]}" --likelihood-weight "$scaled" \
    --json >"$work/splices/eval_x$factor.json"
done
read -ra splice_search <<<"$(inner 5)"
"$skidimm" tune -q --bank configs/borealtc/terrains_start.yaml "${develop[@]}" "${splice_search[@]}" \
  "${uncertainty[@]}" --tune "$knobs" --splice --no-assess --output-bank "$work/borealtc/splice_development.yaml" \
  >"$work/borealtc/splice_tune.txt"

"$python" scripts/real_data_tables.py "$work" "$doc" "$bt"
echo "updated $doc, $bank_out and $wheels_out" >&2
