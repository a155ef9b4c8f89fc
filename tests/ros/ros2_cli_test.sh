#!/usr/bin/env bash
# skidimm's ROS 2 front end on real files, checked with the npm packages:
#  1. `run --output estimates.mcap --copy-topics` on a BorealTC bag: @mcap/core
#     reads the file (both its readers, every CRC); every /skidimm/estimate
#     message equals the row `run --output estimates.csv` writes (every column),
#     and the bag's topics are copied whole.
#  2. `skidimm bag`: the topics, types and message counts of the CSV files the
#     bag was written from, the rates, and the column paths with the joint names.
#  3. `run --serve` at the end of a pipe, seen by @foxglove/ws-protocol's
#     client (serve_test.cjs).
#  4. Bad input: a bag cut short, a wrong CRC, a corrupt chunk, messages not in
#     CDR, a definition skidimm cannot read, a field the type lacks, a .db3
#     without its metadata.yaml: each a located error, a non-zero exit, and the
#     rows computed before it kept in <output>.partial.
#   ros2_cli_test.sh SOURCE_DIR SKIDIMM WORK_DIR DATA_DIR NODE NODE_MODULES PYTHON FIXTURE_DIR
set -euo pipefail
source_dir=$1 skidimm=$2 work=$3 data=$4/borealtc node=$5 node_modules=$6 python=$7 fixtures=$8
[ -d "$data" ] || { echo "no BorealTC data at $data: skipped"; exit 77; }
rm -rf "$work" && mkdir -p "$work"
export NODE_PATH=$node_modules
bank=$source_dir/configs/borealtc/terrains_ros2.yaml
pro=$data/ASPHALT/pro_00.csv imu=$data/ASPHALT/imu_00.csv
write_bag() { "$node" "$source_dir/tests/ros/write_borealtc_bag.cjs" "$pro" "$imu" "$@"; }
fail() { echo "FAIL: $*" >&2; exit 1; }

# 1. MCAP output read by @mcap/core, against the CSV output.
write_bag "$work/drive.mcap"
"$skidimm" run -q --bank "$bank" --input "$work/drive.mcap" --output "$work/estimates.csv"
"$skidimm" run -q --bank "$bank" --input "$work/drive.mcap" --output "$work/estimates.mcap" --copy-topics
[ ! -e "$work/estimates.mcap.partial" ] || fail "estimates.mcap.partial left after a complete run"
"$node" "$source_dir/tests/ros/read_mcap.cjs" "$work/estimates.mcap" >"$work/estimates.json"
"$python" - "$work/estimates.csv" "$work/estimates.json" "$pro" "$imu" <<'PY'
import csv, json, math, sys
rows = list(csv.DictReader(open(sys.argv[1])))
read = json.load(open(sys.argv[2]))
assert read["profile"] == "" and read["library"] == "skidimm", read["library"]
topics = {c["topic"]: c for c in read["channels"]}
assert topics["/skidimm/estimate"]["schemaEncoding"] == "jsonschema" and topics["/skidimm/estimate"]["messageEncoding"] == "json"
assert topics["/imu/data"]["schemaName"] == "sensor_msgs/msg/Imu" and topics["/imu/data"]["schemaEncoding"] == "ros2msg"
estimates = [m for m in read["messages"] if m["topic"] == "/skidimm/estimate"]
assert len(estimates) == len(rows), (len(estimates), len(rows))
def same(text, value):
    return (value is None and text == "nan") or (value is not None and float(text) == value)
for row, m in zip(rows, estimates):
    e = m["json"]
    assert same(row["t"], e["t"]) and int(m["logTime"]) == round(e["t"] * 1e9), (row["t"], e["t"], m["logTime"])
    for mode, p in e["probability"].items():
        assert same(row["mu_" + mode], p), (mode, row["mu_" + mode], p)
    for state, x in e["state"].items():
        assert same(row[state], x) and same(row["var_" + state], e["variance"][state]), state
    for key in ("mode", "decision", "status", "reason"):
        assert row[key] == e[key], (key, row[key], e[key])
counts = read["statistics"]["channelMessageCounts"]
imu_rows = sum(1 for _ in open(sys.argv[4])) - 1
pro_rows = sum(1 for _ in open(sys.argv[3])) - 1
assert int(counts["/imu/data"]) == imu_rows and int(counts["/joint_states"]) == pro_rows, (counts, imu_rows, pro_rows)
print(f"1. estimates.mcap: @mcap/core reads {len(estimates)} estimates, each equal to its CSV row, "
      f"and the bag's {imu_rows} + {pro_rows} messages copied alongside")
PY

# 1b. A bank with an unknown hypothesis: its probability is a field of the
# message, equal to the CSV's column, and `mode` says unknown as the CSV does (an
# entry and exit share of 0.05 a step: it leads about half of the steps).
{ cat "$bank"; echo "unknown: {inflation: 10, enter: 0.05, leave: 0.05}"; } >"$work/unknown_bank.yaml"
"$skidimm" run -q --bank "$work/unknown_bank.yaml" --input "$work/drive.mcap" --output "$work/unknown.csv"
"$skidimm" run -q --bank "$work/unknown_bank.yaml" --input "$work/drive.mcap" --output "$work/unknown.mcap"
"$node" "$source_dir/tests/ros/read_mcap.cjs" "$work/unknown.mcap" >"$work/unknown.json"
"$python" - "$work/unknown.csv" "$work/unknown.json" <<'PY'
import csv, json, sys
rows = list(csv.DictReader(open(sys.argv[1])))
read = json.load(open(sys.argv[2]))
channel = [c for c in read["channels"] if c["topic"] == "/skidimm/estimate"][0]
assert "unknown_probability" in json.loads(channel["schema"])["properties"], channel["schema"]
estimates = [m["json"] for m in read["messages"] if m["topic"] == "/skidimm/estimate"]
assert len(estimates) == len(rows), (len(estimates), len(rows))
for row, e in zip(rows, estimates):
    assert float(row["unknown_probability"]) == e["unknown_probability"], (row["unknown_probability"], e)
    assert row["mode"] == e["mode"] and (e["mode_index"] == -1) == (e["mode"] == "unknown"), (row["mode"], e)
unknown = sum(e["mode"] == "unknown" for e in estimates)
assert 0 < unknown, "the untuned unknown hypothesis should lead some steps of a real run"
print(f"1b. with an unknown hypothesis: every message's unknown_probability equals the CSV's; unknown leads {unknown} of {len(estimates)}")
PY

# 2. skidimm bag.
"$skidimm" bag "$work/drive.mcap" >"$work/bag.txt"
imu_rows=$(($(wc -l <"$imu") - 1)) pro_rows=$(($(wc -l <"$pro") - 1))
grep -Eq "^  /imu/data +sensor_msgs/msg/Imu +$imu_rows msgs +100\.00 Hz +time header\.stamp" "$work/bag.txt" ||
  { cat "$work/bag.txt" >&2; fail "skidimm bag: /imu/data should have $imu_rows messages at 100 Hz"; }
grep -Eq "^  /joint_states +sensor_msgs/msg/JointState +$pro_rows msgs +6\.50 Hz" "$work/bag.txt" ||
  { cat "$work/bag.txt" >&2; fail "skidimm bag: /joint_states should have $pro_rows messages at 6.5 Hz"; }
grep -q "/joint_states.velocity\[left\] /joint_states.velocity\[right\]" "$work/bag.txt" ||
  fail "skidimm bag: the joint names should be in the column paths"
grep -q "Messages:  $((imu_rows + pro_rows))$" "$work/bag.txt" || fail "skidimm bag: total message count"
echo "2. skidimm bag: $imu_rows IMU and $pro_rows joint messages, 100 and 6.5 Hz, velocity[left] and [right]"

# 2b. One IMU message stamped 15 ms behind its slot, 5 ms before the message
# before it, as a driver stamping on another thread writes now and then: the
# bundled bag bank leaves it out, counts it, and runs to the end.
write_bag "$work/jitter.mcap" --stamp-back 1001:15
"$skidimm" run --bank "$bank" --input "$work/jitter.mcap" --output "$work/jitter.csv" 2>"$work/jitter.err" ||
  { cat "$work/jitter.err" >&2; fail "jitter: one IMU stamp out of order stopped the bundled bag bank"; }
grep -q "1 row(s) whose time was not after their file's last row were left out (sampling.skip_out_of_order)" \
  "$work/jitter.err" || { cat "$work/jitter.err" >&2; fail "jitter: the summary should count the message left out"; }
[ "$(wc -l <"$work/jitter.csv")" -eq "$(wc -l <"$work/estimates.csv")" ] || fail "jitter: not every step was written"
echo "2b. one IMU stamp 5 ms before the one before it: left out and counted, every step written"

# 3. --serve at the end of a pipe.
"$node" "$source_dir/tests/ros/serve_test.cjs" "$skidimm" "$source_dir/configs/ltc_terrains.yaml" \
  "$source_dir/configs/examples/ltc_switching.csv" "$work/serve" | sed 's/^/3. /'

# 4. Bad input. expect_error NAME PATTERN KEPT_ROWS(yes|no) -- skidimm arguments...
expect_error() {
  local name=$1 pattern=$2 kept=$3
  shift 4
  local status=0
  "$skidimm" "$@" >"$work/$name.out" 2>"$work/$name.err" || status=$?
  [ "$status" -ne 0 ] || fail "$name: skidimm exited 0"
  grep -q -- "$pattern" "$work/$name.err" || { cat "$work/$name.err" >&2; fail "$name: expected '$pattern' in the message"; }
  if [ "$kept" = yes ]; then
    grep -q "rows computed before the error are in" "$work/$name.err" || fail "$name: the rows before the error were not kept"
    [ "$(wc -l <"$work/$name.csv.partial")" -gt 10 ] || fail "$name: $name.csv.partial has too few rows"
  fi
  echo "4. $name: $(grep -m1 "error" "$work/$name.err" | cut -c1-160)"
}
# A recording cut short (no summary, cut in the middle of a chunk).
write_bag "$work/no_summary.mcap" --no-summary
head -c "$(($(stat -c %s "$work/no_summary.mcap") * 2 / 3))" "$work/no_summary.mcap" >"$work/cut.mcap"
expect_error cut "cut.mcap: byte [0-9]*: .*cut short" yes -- run --bank "$bank" --input "$work/cut.mcap" --output "$work/cut.csv"
# ... into an MCAP output: the .partial file is a complete MCAP of the steps before the cut.
expect_error cut_mcap "cut short" no -- run --bank "$bank" --input "$work/cut.mcap" --output "$work/cut_out.mcap"
"$node" "$source_dir/tests/ros/read_mcap.cjs" "$work/cut_out.mcap.partial" >"$work/cut_out.json"
rows=$(grep -o "the [0-9]* rows computed before the error" "$work/cut_mcap.err" | grep -o "[0-9]*")
"$python" -c 'import json,sys; n=len(json.load(open(sys.argv[1]))["messages"]); assert n == int(sys.argv[2]) > 10, n' \
  "$work/cut_out.json" "$rows" || fail "cut_mcap: the .partial MCAP should hold the $rows steps before the error"
echo "4. cut_mcap: @mcap/core reads the $rows steps before the cut in cut_out.mcap.partial"
# A step whose time an MCAP log time cannot hold (nanoseconds from 0 to 1.8e10 s) is refused, not
# clamped onto one instant with every later step; the steps before it are in the .partial MCAP.
expect_error late_mcap "s cannot be written to an MCAP file, whose log times are nanoseconds from 0 to 1.8e10 s" no -- \
  run --bank "$source_dir/configs/ltc_terrains.yaml" --input "$source_dir/configs/examples/ltc_switching.csv@17999999995" \
  --output "$work/late.mcap"
"$node" "$source_dir/tests/ros/read_mcap.cjs" "$work/late.mcap.partial" >"$work/late.json"
rows=$(grep -o "the [0-9]* rows computed before the error" "$work/late_mcap.err" | grep -o "[0-9]*")
"$python" -c 'import json,sys; m=json.load(open(sys.argv[1]))["messages"]; assert len(m) == int(sys.argv[2]) > 100, len(m)' \
  "$work/late.json" "$rows" || fail "late_mcap: the .partial MCAP should hold the $rows steps before t = 1.8e10 s"
echo "4. late_mcap: @mcap/core reads the $rows steps before t = 1.8e10 s in late.mcap.partial"
# A byte changed in a message of an uncompressed chunk: only the chunk's CRC can tell.
write_bag "$work/plain.mcap" --compression none
"$python" - "$work/plain.mcap" "$work/crc.mcap" <<'PY'
import sys
data = bytearray(open(sys.argv[1], "rb").read())
at = data.find(b"imu_link", len(data) // 2)
data[at] ^= 0x20
open(sys.argv[2], "wb").write(data)
PY
expect_error crc "crc.mcap: byte [0-9]*: Chunk's CRC is .* the chunk is corrupt" yes -- \
  run --bank "$bank" --input "$work/crc.mcap" --output "$work/crc.csv"
# A zstd chunk overwritten in its middle.
"$python" - "$work/drive.mcap" "$work/corrupt.mcap" <<'PY'
import sys
data = bytearray(open(sys.argv[1], "rb").read())
middle = len(data) // 2
data[middle:middle + 64] = bytes(64)
open(sys.argv[2], "wb").write(data)
PY
expect_error corrupt "corrupt.mcap: byte [0-9]*: Chunk" yes -- run --bank "$bank" --input "$work/corrupt.mcap" --output "$work/corrupt.csv"
# Messages in JSON, not CDR; a definition stored as IDL for a type skidimm does not bundle.
# (ltc_terrains with columns from the fixtures' topics.)
small_bank() {  # MEASURED_TOPIC_FIELD OUTPUT
  "$python" - "$source_dir/configs/ltc_terrains.yaml" "$1" "$2" <<'PY'
import sys
text = open(sys.argv[1]).read()
start = text.index("columns:\n")
end = text.index("measurement:\n")
columns = ("columns:\n  time: header.stamp\n"
           "  inputs: {phi_dot_L: \"/imu/data.angular_velocity.x\", phi_dot_R: \"/imu/data.angular_velocity.y\"}\n"
           f"  measurements: {{V: \"{sys.argv[2]}\", omega: \"/imu/data.angular_velocity.z\"}}\n")
open(sys.argv[3], "w").write(text[:start] + columns + text[end:])
PY
}
small_bank /json.data "$work/json_bank.yaml"
expect_error encoding "topic /json (std_msgs/msg/String): messages encoded as 'json'" no -- \
  run --bank "$work/json_bank.yaml" --input "$fixtures/mixed.mcap" --output "$work/encoding.csv"
small_bank /custom.data "$work/idl_bank.yaml"
expect_error schema "topic /custom (my_msgs/msg/Custom): the bag stores its definition as 'ros2idl'" no -- \
  run --bank "$work/idl_bank.yaml" --input "$fixtures/idl.mcap" --output "$work/schema.csv"
# A field the message does not have: the paths it has are listed.
sed 's|angular_velocity.z|angular_velocity.w|' "$bank" >"$work/field_bank.yaml"
expect_error field "topic /imu/data: no column '/imu/data.angular_velocity.w'.*Its columns: /imu/data.header.stamp" no -- \
  run --bank "$work/field_bank.yaml" --input "$work/drive.mcap" --output "$work/field.csv"
# A .db3 without the metadata.yaml of its bag directory.
write_bag "$work/drive.jsonl"
"$python" "$source_dir/tests/ros/write_db3.py" "$work/drive.jsonl" "$work/db3_bag" --no-metadata
expect_error db3 "drive\|db3_bag_0.db3: no metadata.yaml beside this .db3 file" no -- \
  run --bank "$bank" --input "$work/db3_bag/db3_bag_0.db3" --output "$work/db3.csv"
expect_error bag_cut "cut short" no -- bag "$work/cut.mcap"
# Cut inside its first chunk: no channel was read, which is the file's fault, not the bank's.
head -c 1000 "$work/no_summary.mcap" >"$work/cut_first.mcap"
expect_error cut_first "no channel was read from the file (a recording cut short inside its first chunk" no -- \
  run --bank "$bank" --input "$work/cut_first.mcap" --output "$work/cut_first.csv"
# --copy-topics without an MCAP output or a bag input: refused before the run
# (a bad command line, exit 2), not after it.
expect_error copy_csv "--copy-topics copies a bag's topics into an MCAP output" no -- \
  run --bank "$bank" --input "$work/drive.mcap" --output "$work/copy.csv" --copy-topics
status=0
"$skidimm" run -q --bank "$bank" --input "$work/drive.mcap" --output "$work/copy.csv" --copy-topics 2>/dev/null || status=$?
[ "$status" -eq 2 ] || fail "copy_csv: exit $status, expected 2 (a bad command line)"
[ ! -e "$work/copy.csv.partial" ] || fail "copy_csv: the run started"
# A bag through a pipe is named as one, not read as a CSV header of binary junk.
expect_error stdin_bag "standard input:1: an MCAP bag through a pipe or standard input" no -- \
  run --bank "$bank" --input - --output "$work/stdin_bag.csv" <"$work/drive.mcap"
expect_error bag_stdin "skidimm bag: error: a bag is read from its file, not from standard input" no -- \
  bag - <"$work/drive.mcap"
echo "every bad input: a located error, a non-zero exit, the rows before it kept"
