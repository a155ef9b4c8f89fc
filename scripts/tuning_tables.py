#!/usr/bin/env python3
"""Fills the <!-- tuning:NAME --> ... <!-- end --> blocks of docs/tuning.md
from the outputs of scripts/reproduce_tuning.sh. Standard library only.

    tuning_tables.py <work dir> <tuning.md> <seeds>
"""
import json
import os
import re
import sys


def fmt(x, digits=3):
    return "-" if x is None else f"{x:.{digits}f}"


def load(work, name):
    with open(os.path.join(work, "eval", name + ".json")) as f:
        return json.load(f)["overall"]


def row(label, e):
    acc = e["accuracy_per_log"]
    settled = e["latency"]
    return (f"| {label} | {fmt(acc['mean'])} ± {fmt(acc['std'])} | {fmt(acc['min'])} | "
            f"{fmt(e['mean_truth_probability'])} | {fmt(e['mean_truth_log_probability'])} | "
            f"{settled['switches'] - settled['followed']} of {settled['switches']} |")


HEADER = ("| bank | accuracy (mean ± sd over logs) | worst log | p(true mode) | mean log p(truth) | "
          "switches never followed |\n|---|---|---|---|---|---|")


def main():
    work, doc, seeds = sys.argv[1], sys.argv[2], sys.argv[3]
    true, lik, win = (load(work, n) for n in ("known_true", "known_likelihood", "known_window"))
    known = "\n".join([
        HEADER,
        row("the true bank (`configs/ltc_terrains.yaml`)", true),
        row("fitted, likelihood objective", lik),
        row("fitted, window objective (0.2 s)", win),
    ])
    known += (f"\n\n{seeds} fresh logs (seeds 8001-{8000 + int(seeds)}); the likelihood fit is "
              f"{fmt(100 * (true['accuracy'] - lik['accuracy']), 1)} points of accuracy from the true bank, "
              f"the window fit {fmt(100 * (true['accuracy'] - win['accuracy']), 1)}.\n")

    shipped, true_noise, tuned = (load(work, n) for n in ("poor_shipped", "poor_true_noise", "poor_tuned"))
    with open(os.path.join(work, "tune.txt")) as f:
        chosen = f.readline().strip()
    poor = "\n".join([
        HEADER,
        row("as shipped (R for the default sensors)", shipped),
        row("told the true sensor noise (R twice as large)", true_noise),
        row("tuned by `skidimm tune` on 10 other logs", tuned),
    ])
    ratio = tuned["accuracy"] / true_noise["accuracy"] if true_noise["accuracy"] else 0.0
    poor += (f"\n\n{seeds} fresh logs (seeds 8001-{8000 + int(seeds)}). The tuned bank reaches "
             f"{fmt(100 * ratio, 1)}% of the accuracy of the bank told the true noise. "
             f"Tune {chosen[len('chosen: '):] if chosen.startswith('chosen: ') else chosen}.\n")

    blocks = {"known_system": known, "poor_sensors": poor}
    with open(doc) as f:
        text = f.read()
    for name, block in blocks.items():
        pattern = re.compile(r"(<!-- tuning:%s -->\n).*?(<!-- end -->)" % re.escape(name), re.S)
        if not pattern.search(text):
            sys.exit(f"{doc}: no <!-- tuning:{name} --> block")
        text = pattern.sub(lambda m: m.group(1) + block + m.group(2), text)
    with open(doc, "w") as f:
        f.write(text)


if __name__ == "__main__":
    main()
