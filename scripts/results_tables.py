#!/usr/bin/env python3
"""Fills the <!-- results:NAME --> ... <!-- end --> blocks of docs/results.md
from `skidimm eval --json` outputs. Standard library only.

    results_tables.py <eval dir> <results.md> <seeds>
"""
import glob
import json
import os
import re
import sys


def fmt(x, digits=2):
    return "-" if x is None else f"{x:.{digits}f}"


def summary_table(evals, seeds):
    rows = ["| scenario | bank | accuracy (mean ± sd over seeds) | worst seed | p(true mode) | "
            "new mode first most likely: median / max | stays until next switch: median, never |",
            "|---|---|---|---|---|---|---|"]
    for bank, data in evals:
        for group, g in data["groups"].items():
            acc = g["accuracy_per_log"]
            first, settled = g["first_latency"], g["latency"]
            switches = settled["switches"]
            latency = (f"{fmt(first['median'])} s / {fmt(first['max'])} s" if switches else "no switch")
            stays = (f"{fmt(settled['median'])} s, {switches - settled['followed']} of {switches}"
                     if switches else "-")
            rows.append(f"| {group} | {bank} | {fmt(acc['mean'], 3)} ± {fmt(acc['std'], 3)} | {fmt(acc['min'], 3)} | "
                        f"{fmt(g['mean_truth_probability'], 3)} | {latency} | {stays} |")
    return "\n".join(rows) + f"\n\n{seeds} seeds per scenario; accuracy is the fraction of time the most likely mode is the true one.\n"


def confusion_table(data, bank):
    confusion = data["overall"]["confusion_seconds"]
    modes = sorted({e for row in confusion.values() for e in row} | set(confusion))
    rows = [f"Confusion, bank `{bank}`, all seeds (rows: truth, columns: estimate, fraction of the truth's time):", "",
            "| truth \\ estimate | " + " | ".join(modes) + " |", "|---" * (len(modes) + 1) + "|"]
    for truth in sorted(confusion):
        total = sum(confusion[truth].values())
        cells = [fmt(confusion[truth].get(m, 0.0) / total if total else 0.0) for m in modes]
        rows.append(f"| {truth} | " + " | ".join(cells) + " |")
    nis = data["overall"]["nis"]
    if nis:
        rows += ["", "Filter consistency of the true mode (mean NIS per measured component, 95% bounds): " +
                 "; ".join(f"{m} {fmt(v['mean_per_dof'])} [{fmt(v['lower'])}, {fmt(v['upper'])}] {v['verdict']}"
                           for m, v in sorted(nis.items()))]
    return "\n".join(rows) + "\n"


def main():
    eval_dir, results, seeds = sys.argv[1], sys.argv[2], sys.argv[3]
    blocks = {}
    experiments = sorted({os.path.basename(p).split("__")[0] for p in glob.glob(os.path.join(eval_dir, "*.json"))})
    for experiment in experiments:
        evals = []
        for path in sorted(glob.glob(os.path.join(eval_dir, experiment + "__*.json"))):
            bank = os.path.basename(path)[len(experiment) + 2:-5]
            with open(path) as f:
                evals.append((bank, json.load(f)))
        blocks[experiment] = summary_table(evals, seeds) + "\n" + "\n".join(confusion_table(d, b) for b, d in evals)
    with open(results) as f:
        text = f.read()
    for name, block in blocks.items():
        pattern = re.compile(r"(<!-- results:%s -->\n).*?(<!-- end -->)" % re.escape(name), re.S)
        if not pattern.search(text):
            sys.exit(f"{results}: no <!-- results:{name} --> block")
        text = pattern.sub(lambda m: m.group(1) + block + m.group(2), text)
    with open(results, "w") as f:
        f.write(text)


if __name__ == "__main__":
    main()
