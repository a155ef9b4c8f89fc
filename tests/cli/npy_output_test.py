"""`skidimm run --output out.npy` read by NumPy, against the CSV output of
the same run: every number the same double, every text the same, and each
reason_code mapping through out.reasons.json to the CSV's reason. The
commands that read a run's output as CSV (plot, eval --estimates, run
--plot) refuse a .npy, saying so.

Usage: npy_output_test.py SOURCE_DIR SKIDIMM WORK_DIR
"""
import csv
import json
import pathlib
import shutil
import subprocess
import sys

import numpy


def run(skidimm, source, output, *extra):
    subprocess.run([skidimm, "run", "-q", "--bank", str(source / "configs" / "ltc_terrains.yaml"),
                    "--input", str(source / "configs" / "examples" / "ltc_switching.csv"),
                    "--output", str(output), *extra], check=True)


def main():
    source, skidimm, work = pathlib.Path(sys.argv[1]), sys.argv[2], pathlib.Path(sys.argv[3])
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    # A tight gate: most rows have a reason, many of them distinct (their NIS).
    gate = ["--innovation-gate", "0.9"]
    run(skidimm, source, work / "out.csv", *gate)
    run(skidimm, source, work / "out.npy", *gate)

    estimates = numpy.load(work / "out.npy")
    with open(work / "out.reasons.json", encoding="utf-8") as f:
        texts = json.load(f)
    with open(work / "out.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    failures = []
    if len(estimates) != len(rows):
        failures.append(f"{len(estimates)} records in the .npy, {len(rows)} rows in the CSV")
    names = list(estimates.dtype.names)
    if names[:-1] + ["reason"] != list(rows[0].keys()):
        failures.append(f"columns {names} against the CSV's {list(rows[0].keys())}")
    if texts[0] != "":
        failures.append(f"code 0 is {texts[0]!r}, not the empty reason")
    reasons = numpy.array(texts, dtype=object)[estimates["reason_code"]]
    with_reason = 0
    for k, (record, row) in enumerate(zip(estimates, rows)):
        for name in names[:-1]:
            value = record[name]
            if estimates.dtype[name].kind == "f":
                same = float(row[name]) == value or (numpy.isnan(value) and row[name] == "nan")
            else:
                same = value.decode() == row[name]
            if not same:
                failures.append(f"row {k}, {name}: {value!r} in the .npy, {row[name]!r} in the CSV")
        if reasons[k] != row["reason"]:
            failures.append(f"row {k}: reason {reasons[k]!r} in the .npy, {row['reason']!r} in the CSV")
        with_reason += row["reason"] != ""
        if len(failures) > 10:
            break
    if with_reason < 100 or len(texts) < 10:
        failures.append(f"only {with_reason} rows with a reason and {len(texts)} texts: the gate did not bite")
    # The compact file: a 4-byte code instead of a 256-byte text column.
    size_npy = (work / "out.npy").stat().st_size + (work / "out.reasons.json").stat().st_size
    if size_npy > (work / "out.csv").stat().st_size:
        failures.append(f".npy and its table ({size_npy} bytes) larger than the CSV")
    # What reads CSV says it was given a NumPy array, and run --plot refuses
    # before computing anything.
    for command in (["plot", "--estimates", str(work / "out.npy"), "--output", str(work / "fig.png")],
                    ["eval", "--estimates", str(work / "out.npy")]):
        done = subprocess.run([skidimm, *command], capture_output=True, text=True)
        if done.returncode != 1 or "a NumPy array (.npy), not CSV" not in done.stderr:
            failures.append(f"skidimm {command[0]} on a .npy: exit {done.returncode}, {done.stderr.strip()!r}")
    done = subprocess.run([skidimm, "run", "-q", "--bank", str(source / "configs" / "ltc_terrains.yaml"),
                           "--input", str(source / "configs" / "examples" / "ltc_switching.csv"),
                           "--output", str(work / "plotted.npy"), "--plot", str(work / "fig.png")],
                          capture_output=True, text=True)
    if done.returncode != 2 or "--plot draws a CSV output" not in done.stderr or (work / "plotted.npy").exists():
        failures.append(f"run --output .npy --plot: exit {done.returncode}, {done.stderr.strip()!r}")
    # A truth label longer than its column, first at data row 10: an error
    # naming the row, and the .partial array holds the 9 rows before it and
    # nothing after them (a half-written row followed the header's count).
    with open(source / "configs" / "examples" / "ltc_switching.csv", newline="") as f:
        table = list(csv.reader(f))
    truth = table[0].index("mode")
    for row in table[10:]:
        row[truth] = "x" * 100
    with open(work / "long_label.csv", "w", newline="") as f:
        csv.writer(f).writerows(table)
    done = subprocess.run([skidimm, "run", "-q", "--bank", str(source / "configs" / "ltc_terrains.yaml"),
                           "--input", str(work / "long_label.csv"), "--output", str(work / "long.npy")],
                          capture_output=True, text=True)
    partial = work / "long.npy.partial"
    if done.returncode != 1 or "row 10: the truth label 'xxx" not in done.stderr or not partial.exists():
        failures.append(f"a truth label too long for .npy: exit {done.returncode}, {done.stderr.strip()!r}")
    else:
        kept = numpy.load(partial)
        # The header is padded to a multiple of 64 bytes; the records follow it, and nothing else.
        if len(kept) != 9 or (partial.stat().st_size - kept.nbytes) % 64 != 0:
            failures.append(f"{len(kept)} rows, {partial.stat().st_size} bytes in {partial.name}: not the 9 rows alone")
        if "the 9 rows computed before the error" not in done.stderr:
            failures.append(f"the rows kept, as said: {done.stderr.strip()!r}")
    for failure in failures:
        print("FAIL:", failure)
    print(f"{len(estimates)} records, {with_reason} with a reason, {len(texts)} distinct reason texts")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
