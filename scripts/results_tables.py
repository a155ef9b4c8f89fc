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


def detection(first, settled, switches):
    if not switches:
        return "no switch", "-"
    return (f"{fmt(first['median'])} s / {fmt(first['max'])} s, never {switches - first['detected']}",
            f"{fmt(settled['median'])} s, never {switches - settled['followed']}")


def summary_table(evals, seeds):
    """One row per scenario, bank and estimate: the filter's most likely mode,
    the filter's decision (decision.h) and the smoothed most likely mode."""
    rows = ["| scenario | bank | estimate | accuracy (mean ± sd over seeds) | worst seed | p(true mode) | "
            "changes per minute (truth) | changes per switch (median) | new mode first: median / max, never | "
            "stays until next switch: median, never |",
            "|---|---|---|---|---|---|---|---|---|---|"]
    for bank, data, smoothed in evals:
        for group, g in data["groups"].items():
            s = smoothed["groups"][group] if smoothed else None
            switches = g["latency"]["switches"]
            per_minute = g["changes_per_minute"]
            first, stays = detection(g["first_latency"], g["latency"], switches)
            acc = g["accuracy_per_log"]
            per_switch = lambda x: fmt(x, 1) if switches else "-"
            rows.append(f"| {group} | {bank} | most likely | {fmt(acc['mean'], 3)} ± {fmt(acc['std'], 3)} | "
                        f"{fmt(acc['min'], 3)} | {fmt(g['mean_truth_probability'], 3)} | "
                        f"{fmt(per_minute['most_likely'], 1)} ({fmt(per_minute['truth'], 1)}) | "
                        f"{per_switch(g['latency']['median_changes_per_switch'])} | {first} | {stays} |")
            d = g["decision"]
            dacc = d["accuracy_per_log"]
            first = (f"{fmt(d['first_median'])} s, never {switches - d['first_detected']}" if switches else "no switch")
            stays = (f"{fmt(d['settled_median'])} s, never {switches - d['settled']}" if switches else "-")
            rows.append(f"| {group} | {bank} | decision | {fmt(dacc['mean'], 3)} ± {fmt(dacc['std'], 3)} | "
                        f"{fmt(dacc['min'], 3)} | - | {fmt(per_minute['decision'], 1)} ({fmt(per_minute['truth'], 1)}) | "
                        f"{per_switch(d['median_changes_per_switch'])} | {first} | {stays} |")
            if s:
                sacc = s["accuracy_per_log"]
                first, stays = detection(s["first_latency"], s["latency"], switches)
                rows.append(f"| {group} | {bank} | smoothed | {fmt(sacc['mean'], 3)} ± {fmt(sacc['std'], 3)} | "
                            f"{fmt(sacc['min'], 3)} | {fmt(s['mean_truth_probability'], 3)} | "
                            f"{fmt(s['changes_per_minute']['most_likely'], 1)} ({fmt(per_minute['truth'], 1)}) | "
                            f"{per_switch(s['latency']['median_changes_per_switch'])} | {first} | {stays} |")
    return "\n".join(rows) + (
        f"\n\n{seeds} seeds per scenario. *most likely*: the filter's most likely mode at each step; *decision*: "
        "the filter's decision with the default thresholds (enter 0.9, leave 0.05, hold 1 s; `unknown` counts as "
        "wrong); *smoothed*: the most likely mode smoothed over the whole log (`run --smooth`). Accuracy is the "
        "fraction of time the estimate is the true mode; *never* counts the switches where it did not happen.\n")


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
            if bank.endswith("__smoothed"):
                continue
            with open(path) as f:
                data = json.load(f)
            smoothed_path = path[:-5] + "__smoothed.json"
            smoothed = None
            if os.path.exists(smoothed_path):
                with open(smoothed_path) as f:
                    smoothed = json.load(f)
            evals.append((bank, data, smoothed))
        blocks[experiment] = summary_table(evals, seeds) + "\n" + "\n".join(confusion_table(d, b) for b, d, _ in evals)
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
