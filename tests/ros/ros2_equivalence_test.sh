#!/usr/bin/env bash
# configs/borealtc/terrains_ros2.yaml on ROS 2 bags equals configs/borealtc/terrains.yaml
# on the CSV pairs they were written from, bit for bit: every BorealTC run in
# shared/data is written as a bag by the npm packages (write_borealtc_bag.cjs:
# @mcap/core, @foxglove/rosmsg2-serialization; .db3 by write_db3.py with
# Python's sqlite3), in every storage skidimm reads, one run each in turn:
#   MCAP, zstd chunks, indexed | MCAP, lz4 chunks | MCAP without a summary |
#   MCAP without schemas (bundled definitions) | .db3 with definitions (Iron on) |
#   .db3 without (Humble: bundled definitions)
# and `skidimm run` on the bag must write the same file as on the CSV pair
# (same steps, same probabilities, states and variances to the last bit).
# Then `eval` over directories of bags labelled by terrain equals `eval` of
# the CSV pairs, `fit` and `tune` on bags write the same bank as on the CSV
# pairs (but for the bag bank's own sampling.skip_out_of_order), `plot --log` of a bag draws the same figure, and the Python package (run_log, and skidimm.dask.eval on a local cluster)
# reads bags as the CLI does (python_bag_check.py).
#   ros2_equivalence_test.sh SOURCE_DIR SKIDIMM WORK_DIR DATA_DIR NODE NODE_MODULES PYTHON PYTHONPATH
set -euo pipefail
source_dir=$1 skidimm=$2 work=$3 data=$4/borealtc node=$5 node_modules=$6 python=$7 python_path=$8
[ -d "$data" ] || { echo "no BorealTC data at $data: skipped"; exit 77; }
rm -rf "$work" && mkdir -p "$work"
export NODE_PATH=$node_modules
csv_bank=$source_dir/configs/borealtc/terrains.yaml
bag_bank=$source_dir/configs/borealtc/terrains_ros2.yaml
kinds=(zstd lz4 no_summary no_schemas db3_definitions db3)
runs=0 same=0 i=0
for terrain_dir in "$data"/*/; do
  terrain=$(basename "$terrain_dir")
  mkdir -p "$work/bags/$terrain"
  for pro in "$terrain_dir"pro_*.csv; do
    n=${pro##*pro_}; n=${n%.csv}
    imu=$terrain_dir/imu_$n.csv
    kind=${kinds[$((i % ${#kinds[@]}))]}
    i=$((i + 1))
    name=${terrain}_$n
    case "$kind" in
      zstd) "$node" "$source_dir/tests/ros/write_borealtc_bag.cjs" "$pro" "$imu" "$work/bags/$terrain/$name.mcap"
            bag=$work/bags/$terrain/$name.mcap ;;
      lz4) "$node" "$source_dir/tests/ros/write_borealtc_bag.cjs" "$pro" "$imu" "$work/bags/$terrain/$name.mcap" --compression lz4
           bag=$work/bags/$terrain/$name.mcap ;;
      no_summary) "$node" "$source_dir/tests/ros/write_borealtc_bag.cjs" "$pro" "$imu" "$work/bags/$terrain/$name.mcap" --no-summary
                  bag=$work/bags/$terrain/$name.mcap ;;
      no_schemas) "$node" "$source_dir/tests/ros/write_borealtc_bag.cjs" "$pro" "$imu" "$work/bags/$terrain/$name.mcap" --no-schemas
                  bag=$work/bags/$terrain/$name.mcap ;;
      db3*) "$node" "$source_dir/tests/ros/write_borealtc_bag.cjs" "$pro" "$imu" "$work/$name.jsonl"
            flag=(); [ "$kind" = db3_definitions ] && flag=(--definitions)
            "$python" "$source_dir/tests/ros/write_db3.py" "$work/$name.jsonl" "$work/bags/$terrain/$name" "${flag[@]}"
            bag=$work/bags/$terrain/$name ;;
    esac
    "$skidimm" run -q --bank "$csv_bank" --input "$pro+$imu" --output "$work/$name.csv.out"
    "$skidimm" run -q --bank "$bag_bank" --input "$bag" --output "$work/$name.bag.out"
    runs=$((runs + 1))
    if cmp -s "$work/$name.csv.out" "$work/$name.bag.out"; then
      same=$((same + 1))
    else
      echo "FAIL: $name ($kind): the bag's estimates differ from the CSV pair's:" >&2
      diff "$work/$name.csv.out" "$work/$name.bag.out" | head -n 6 >&2
    fi
  done
done
echo "$same of $runs BorealTC runs: the same estimates, bit for bit, from the bag as from the CSV pair"
[ "$runs" -gt 40 ] || { echo "FAIL: expected the 47 BorealTC runs, found $runs" >&2; exit 1; }

# eval over directories of bags, labelled by terrain, equals eval of the CSV pairs.
csv_logs=() bag_logs=()
for terrain_dir in "$data"/*/; do
  terrain=$(basename "$terrain_dir")
  csv_logs+=(--input "$terrain=$terrain_dir/pro_*.csv+$terrain_dir/imu_*.csv")
  bag_logs+=(--input "$terrain=$work/bags/$terrain")
done
"$skidimm" eval --bank "$csv_bank" "${csv_logs[@]}" --json >"$work/eval_csv.json"
"$skidimm" eval --bank "$bag_bank" "${bag_logs[@]}" --json >"$work/eval_bag.json"
# The logs' names differ (pro_00.csv+imu_00.csv, ASPHALT_00.mcap): compare the
# overall and per-group scores, which every log's steps make up.
strip() { "$python" -c 'import json,sys
d=json.load(open(sys.argv[1]))
print(json.dumps({"overall": d["overall"], "groups": d["groups"]}, sort_keys=True))' "$1"; }
if [ "$(strip "$work/eval_csv.json")" != "$(strip "$work/eval_bag.json")" ]; then
  echo "FAIL: eval over the bags differs from eval over the CSV pairs" >&2
  diff <(strip "$work/eval_csv.json" | tr ',' '\n') <(strip "$work/eval_bag.json" | tr ',' '\n') | head -n 10 >&2
  exit 1
fi
echo "eval over directories of bags equals eval over the CSV pairs"

# A written bank from sampling: on, without the bag bank's own key: columns: and
# sampling.skip_out_of_order differ by design (scripts/derive_ros2_config.py).
bank_body() { grep -v '^#' "$1" | grep -v '^  skip_out_of_order: true' | sed -n '/^sampling:/,$p'; }

# fit: the same fitted bank.
"$skidimm" fit --bank "$csv_bank" --objective window --hold-unexcited --output-bank "$work/fit_csv.yaml" \
  --log "SNOW=$data/SNOW/pro_0*.csv+$data/SNOW/imu_0*.csv" 2>/dev/null
"$skidimm" fit --bank "$bag_bank" --objective window --hold-unexcited --output-bank "$work/fit_bag.yaml" \
  --log "SNOW=$work/bags/SNOW/SNOW_0*" 2>/dev/null
grep -q '^  skip_out_of_order: true' "$work/fit_bag.yaml" ||
  { echo "FAIL: fit on bags dropped the bag bank's sampling.skip_out_of_order" >&2; exit 1; }
! grep -q '^  skip_out_of_order' "$work/fit_csv.yaml" ||
  { echo "FAIL: fit on the CSV pairs wrote a sampling.skip_out_of_order its bank does not have" >&2; exit 1; }
if ! diff <(bank_body "$work/fit_csv.yaml") <(bank_body "$work/fit_bag.yaml") >"$work/fit.diff"; then
  echo "FAIL: fit on bags writes another bank than on the CSV pairs:" >&2
  head -n 10 "$work/fit.diff" >&2
  exit 1
fi
grep -q "SNOW_turning" "$work/fit_bag.yaml"
echo "fit on SNOW bags writes the same bank as on their CSV pairs"

# tune: the same choice and the same bank, from bags as from the CSV pairs.
tune=(--objective none --tune floor,dwell --no-assess --folds 2 --threads 2 -q)
"$skidimm" tune --bank "$csv_bank" "${tune[@]}" --output-bank "$work/tune_csv.yaml" \
  --log "ICE=$data/ICE/pro_*.csv+$data/ICE/imu_*.csv" --log "SNOW=$data/SNOW/pro_*.csv+$data/SNOW/imu_*.csv" \
  >"$work/tune_csv.txt" 2>&1
"$skidimm" tune --bank "$bag_bank" "${tune[@]}" --output-bank "$work/tune_bag.yaml" \
  --log "ICE=$work/bags/ICE" --log "SNOW=$work/bags/SNOW" >"$work/tune_bag.txt" 2>&1
grep -q '^  skip_out_of_order: true' "$work/tune_bag.yaml" ||
  { echo "FAIL: tune on bags dropped the bag bank's sampling.skip_out_of_order" >&2; exit 1; }
! grep -q '^  skip_out_of_order' "$work/tune_csv.yaml" ||
  { echo "FAIL: tune on the CSV pairs wrote a sampling.skip_out_of_order its bank does not have" >&2; exit 1; }
if ! diff <(bank_body "$work/tune_csv.yaml") <(bank_body "$work/tune_bag.yaml") >"$work/tune.diff"; then
  echo "FAIL: tune on bags chooses another bank than on the CSV pairs:" >&2
  head -n 10 "$work/tune.diff" >&2
  exit 1
fi
echo "tune on ICE and SNOW bags writes the same bank as on their CSV pairs"

# plot: the measurements drawn from a bag are the CSV pair's, pixel for pixel.
if command -v gnuplot >/dev/null; then
  first=ASPHALT_00.mcap  # pro_00 and imu_00, written first: MCAP with zstd chunks
  "$skidimm" run -q --bank "$bag_bank" --input "$work/bags/ASPHALT/$first" --output "$work/plot_estimates.csv"
  "$skidimm" plot --estimates "$work/plot_estimates.csv" --bank "$csv_bank" --states --output "$work/plot_csv.png" \
    --log "$data/ASPHALT/pro_00.csv+$data/ASPHALT/imu_00.csv"
  "$skidimm" plot --estimates "$work/plot_estimates.csv" --bank "$bag_bank" --states --output "$work/plot_bag.png" \
    --log "$work/bags/ASPHALT/$first"
  cmp -s "$work/plot_csv.png" "$work/plot_bag.png" || { echo "FAIL: plot --log of a bag draws another figure" >&2; exit 1; }
  echo "plot --log of a bag draws the CSV pair's figure, byte for byte"
fi

if [ -n "$python_path" ]; then
  PYTHONPATH=$python_path "$python" "$source_dir/tests/ros/python_bag_check.py" "$source_dir" "$data" "$work/bags"
else
  echo "(no Python package in this build: Python and Dask not checked)"
fi
[ "$same" = "$runs" ]
