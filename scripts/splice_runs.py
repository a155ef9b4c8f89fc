#!/usr/bin/env python3
"""Splices BorealTC runs of different terrains into one log, end to end.

    scripts/splice_runs.py OUT_DIR NAME DATA_DIR TERRAIN/NN [TERRAIN/NN ...]

writes OUT_DIR/pro_NAME.csv and OUT_DIR/imu_NAME.csv: each run's rows in
turn, its times shifted to start one wheel-file period after the previous
run's last row, and a `terrain` column (in the wheel file) naming the
terrain each row was driven on: the truth a bank's `columns.truth_mode:
terrain` reads. The robot did not drive from one terrain onto the next, so a
splice tests how fast and how cleanly the IMM follows a change of terrain,
not what the transition zone looks like.
"""
import csv
import os
import sys

PRO_PERIOD = 2.0 / 13.0  # s, the wheel file's period (README)


def read(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], rows[1:]


def main(argv):
    if len(argv) < 5:
        sys.exit(__doc__)
    out_dir, name, data, runs = argv[1], argv[2], argv[3], argv[4:]
    os.makedirs(out_dir, exist_ok=True)
    pro_out, imu_out = [], []
    pro_header = imu_header = None
    offset = 0.0
    for run in runs:
        terrain, number = run.split("/")
        header, pro = read(os.path.join(data, terrain, "pro_%s.csv" % number))
        imu_h, imu = read(os.path.join(data, terrain, "imu_%s.csv" % number))
        if pro_header is None:
            pro_header, imu_header = header + ["terrain"], imu_h
        elif header + ["terrain"] != pro_header or imu_h != imu_header:
            sys.exit("%s: columns differ from the first run's" % run)
        start = float(pro[0][0])
        end = max(float(pro[-1][0]), float(imu[-1][0]))
        for row in pro:
            pro_out.append([repr(float(row[0]) - start + offset)] + row[1:] + [terrain])
        for row in imu:
            imu_out.append([repr(float(row[0]) - start + offset)] + row[1:])
        offset += end - start + PRO_PERIOD
    for path, header, rows in ((os.path.join(out_dir, "pro_%s.csv" % name), pro_header, pro_out),
                               (os.path.join(out_dir, "imu_%s.csv" % name), imu_header, imu_out)):
        with open(path, "w", newline="") as f:
            writer = csv.writer(f, lineterminator="\n")
            writer.writerow(header)
            writer.writerows(rows)


if __name__ == "__main__":
    main(sys.argv)
