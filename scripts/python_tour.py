#!/usr/bin/env python3
"""The tour of docs/python.md, end to end: simulate, run, evaluate, draw.

  PYTHONPATH=build/lib/python3.11/dist-packages /usr/bin/python3 scripts/python_tour.py \
      [--output python_mode_probabilities.png]

Writes the figure of docs/python.md (mode probabilities over a simulated
terrain-switching run, the true terrain shaded) and prints the numbers the
tour quotes. The figure goes to the current directory unless --output says
otherwise (--output docs/images/python_mode_probabilities.png redraws the
page's). python/tests/test_tour.py runs it, so the page stays true.
"""

import argparse
import pathlib
import shutil
import tempfile

import numpy as np

import skidimm

ROOT = pathlib.Path(__file__).resolve().parents[1]
SEED = 5001  # an evaluation seed (scripts/seeds.sh): disjoint from the bank's fitting seeds


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--output", default="python_mode_probabilities.png",
                        help="the figure (PNG); docs/images/python_mode_probabilities.png is the page's")
    args = parser.parse_args()

    # 1. A bank, its plugins found next to the package.
    imm = skidimm.Imm.from_yaml(ROOT / "configs" / "ltc_terrains.yaml")
    bank = imm.bank

    # 2. A log: the paper's switching experiment, simulated (columns as numpy arrays).
    directory = tempfile.mkdtemp(prefix="skidimm_tour_")
    log_file = pathlib.Path(directory) / "switching.csv"
    log = skidimm.simulate(ROOT / "configs" / "scenarios" / "ltc_switching.yaml", seed=SEED, output=log_file)
    t = log["t"]
    u = np.column_stack([log[name] for name in bank.inputs])
    z = np.column_stack([log[name] for name in bank.measurements])

    # 3. One step, as in a robot's loop.
    first = imm.step(t[0], u[0], z[0])
    print(f"first step: {first.status}, mode probabilities {np.round(first.mode_probabilities, 3).tolist()}")

    # 4. The whole log in C++: the columns `skidimm run` writes.
    out = imm.run(t, u, z, truth=log["mode"])
    accuracy = np.mean(out["mode"] == out["truth_mode"])
    print(f"{len(t)} rows; most likely mode = truth on {accuracy:.3f} of the rows")
    smoothed = imm.run(t, u, z, truth=log["mode"], smooth=True)
    print(f"smoothed over the whole log: {np.mean(smoothed['mode'] == smoothed['truth_mode']):.3f}")

    # 5. The CLI's evaluation, as a dict.
    report = skidimm.eval(bank, [log_file])
    shutil.rmtree(directory)
    overall = report["overall"]
    print(f"eval: accuracy {overall['accuracy']}, mean probability of the truth "
          f"{overall['mean_truth_probability']}, switches followed {overall['latency']['followed']} of "
          f"{overall['latency']['switches']}, median first latency {overall['first_latency']['median']} s")

    # 6. The figure.
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 3.2), dpi=100)
    colours = {"asphalt": "tab:grey", "grass": "tab:green", "crushed_concrete": "tab:orange"}
    truth = out["truth_mode"]
    starts = np.flatnonzero(np.r_[True, truth[1:] != truth[:-1]])
    ends = np.r_[starts[1:], len(truth)]
    for s, e in zip(starts, ends):
        ax.axvspan(t[s], t[e - 1], color=colours.get(truth[s], "white"), alpha=0.12, lw=0)
    for mode in bank.modes:
        ax.plot(t, out[f"mu_{mode}"], color=colours.get(mode), lw=1.2, label=mode.replace("_", " "))
    ax.set_xlabel("t (s)")
    ax.set_ylabel("mode probability")
    ax.set_ylim(-0.02, 1.02)
    ax.set_xlim(t[0], t[-1])
    ax.set_title(f"skidimm from Python: {bank.name}, simulated switching run (seed {SEED}); shading = true terrain",
                 fontsize=9)
    ax.legend(loc="center right", fontsize=8)
    fig.tight_layout()
    fig.savefig(args.output, metadata={"Software": None})
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
