#!/usr/bin/env python3
"""Spliced BorealTC logs for docs/real-data.md: runs of the five terrains end
to end, so that a bank meets changes of terrain it never saw.

    borealtc_splices.py OUT_DIR DATA_DIR TERRAIN/NN ...

Given some runs per terrain (the lockbox), writes five rotations of the
terrains (asphalt, flooring, ice, sandy loam, snow; then flooring first;
...): rotation k drives, on each terrain in turn, that terrain's run number
k (modulo how many it has), so every run is driven at least once when no
terrain has more than five. Each is a pro/imu pair written by
splice_runs.py (a `terrain` column gives the truth); prints one `skidimm
--input` argument per rotation.
"""
import os
import sys

from splice_runs import main as splice

TERRAINS = ["ASPHALT", "FLOORING", "ICE", "SANDY_LOAM", "SNOW"]


def rotations(runs):
    """The runs (TERRAIN/NN) each rotation drives, in order: rotation k starts on TERRAINS[k] and takes, on
    each terrain, that terrain's run k modulo how many it has (in sorted order)."""
    by_terrain = {t: sorted(r for r in runs if r.split("/")[0] == t) for t in TERRAINS}
    missing = [t for t in TERRAINS if not by_terrain[t]]
    if missing:
        sys.exit("no run of " + ", ".join(missing))
    return [[by_terrain[t][k % len(by_terrain[t])] for t in TERRAINS[k:] + TERRAINS[:k]]
            for k in range(len(TERRAINS))]


def main(argv):
    if len(argv) < 4:
        sys.exit(__doc__)
    out_dir, data, runs = argv[1], argv[2], argv[3:]
    for k, chosen in enumerate(rotations(runs)):
        name = f"rotation_{k}"
        splice(["splice_runs.py", out_dir, name, data] + chosen)
        print(f"{os.path.join(out_dir, 'pro_' + name + '.csv')}+{os.path.join(out_dir, 'imu_' + name + '.csv')}")


if __name__ == "__main__":
    main(sys.argv)
