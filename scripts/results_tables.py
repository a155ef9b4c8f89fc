#!/usr/bin/env python3
"""Fills the <!-- results:NAME --> ... <!-- end --> blocks of docs/results.md
from `skidimm eval --json` outputs and simulated logs. Standard library only.

    results_tables.py <eval dir> <results.md> <seeds> [<kinematics dir>]
        [--decision-defaults DIR] [--compiled-defaults ENTER,LEAVE,HOLD]
        [--model-selection DIR --model-selection-seeds "SEEDS"]

Eval outputs are named EXPERIMENT__SENSORS__BANK.json (and
...__smoothed.json), SENSORS being "ideal" or "realistic". The kinematics
directory holds one noise-free spiral per wheel configuration (truth columns).
The decision-defaults directory holds, per switching experiment on the
seeds kept for choosing the defaults, the `eval --estimates` output that
compares every candidate setting (lists of --decision-*), named
EXPERIMENT__SENSORS__BANK.json; --compiled-defaults are
skidimm's own (DecisionConfig), which the tables name.
"""
import argparse
import csv
import glob
import json
import math
import os
import re
import sys

SENSORS = ("realistic", "ideal")
SENSOR_LABEL = {"realistic": "realistic", "ideal": "ideal"}
# Banks in the order the tables list them; the sided model next to eq. 3.
BANK_ORDER = ["ltc_terrains", "ltc_shared", "stc_slip4", "stc_sided4", "stc_traction4", "stc_slip16", "stc_sided16",
              "stc_traction16"]
# Configurations that move alike whatever the maneuver: scaling every wheel's
# friction by one factor leaves the quasi-static motion unchanged
# (docs/simulation.md), so a tarp on all four wheels is no slip up to inertia
# and rolling resistance. The 16-mode banks of the kinematic models are also
# scored with these as one; the banks that measure motor currents, which tell
# them apart, are not.
INDISTINGUISHABLE = [{"no_slip", "slip_FL_FR_RL_RR"}]
MEASURES_CURRENTS = {"stc_traction4", "stc_traction16"}
FOUR = ["no_slip", "slip_FL_FR", "slip_FR_RR", "slip_FL_FR_RL_RR"]
TARGET_ACCURACY_4 = 0.8
TARGET_SWITCH_SECONDS = 3.0
TARGET_SWITCH_SEEDS = 18
TARGET_ACCURACY_16 = 0.7


def fmt(x, digits=2):
    return "-" if x is None else f"{x:.{digits}f}"


def detection(first, settled, switches):
    if not switches:
        return "no switch", "-"
    return (f"{fmt(first['median'])} s / {fmt(first['max'])} s, never {switches - first['detected']}",
            f"{fmt(settled['median'])} s, never {switches - settled['followed']}")


def load_evals(eval_dir):
    """{experiment: [(sensors, bank, data, smoothed)]} in table order."""
    out = {}
    for path in glob.glob(os.path.join(eval_dir, "*.json")):
        parts = os.path.basename(path)[:-5].split("__")
        if len(parts) != 3:
            continue
        experiment, sensors, bank = parts
        with open(path) as f:
            data = json.load(f)
        smoothed = None
        if os.path.exists(path[:-5] + "__smoothed.json"):
            with open(path[:-5] + "__smoothed.json") as f:
                smoothed = json.load(f)
        out.setdefault(experiment, []).append((sensors, bank, data, smoothed))
    for experiment in out:
        out[experiment].sort(key=lambda e: (SENSORS.index(e[0]), BANK_ORDER.index(e[1])))
    return out


def summary_table(evals, seeds, defaults):
    """One row per sensor set, scenario, bank and estimate: the filter's most
    likely mode, the filter's decision (decision.h) and the smoothed most
    likely mode."""
    rows = ["| sensors | scenario | bank | estimate | accuracy (mean ± sd over seeds) | worst seed | p(true mode) | "
            "changes per minute (truth) | changes per switch (median) | new mode first: median / max, never | "
            "stays until next switch: median, never |",
            "|---|---|---|---|---|---|---|---|---|---|---|"]
    for sensors, bank, data, smoothed in evals:
        label = SENSOR_LABEL[sensors]
        for group, g in data["groups"].items():
            s = smoothed["groups"][group] if smoothed else None
            switches = g["latency"]["switches"]
            per_minute = g["changes_per_minute"]
            first, stays = detection(g["first_latency"], g["latency"], switches)
            acc = g["accuracy_per_log"]
            per_switch = lambda x: fmt(x, 1) if switches else "-"
            rows.append(f"| {label} | {group} | {bank} | most likely | {fmt(acc['mean'], 3)} ± {fmt(acc['std'], 3)} | "
                        f"{fmt(acc['min'], 3)} | {fmt(g['mean_truth_probability'], 3)} | "
                        f"{fmt(per_minute['most_likely'], 1)} ({fmt(per_minute['truth'], 1)}) | "
                        f"{per_switch(g['latency']['median_changes_per_switch'])} | {first} | {stays} |")
            d = g["decision"]
            dacc = d["accuracy_per_log"]
            first = (f"{fmt(d['first_median'])} s, never {switches - d['first_detected']}" if switches else "no switch")
            stays = (f"{fmt(d['settled_median'])} s, never {switches - d['settled']}" if switches else "-")
            rows.append(f"| {label} | {group} | {bank} | decision | {fmt(dacc['mean'], 3)} ± {fmt(dacc['std'], 3)} | "
                        f"{fmt(dacc['min'], 3)} | - | {fmt(per_minute['decision'], 1)} ({fmt(per_minute['truth'], 1)}) | "
                        f"{per_switch(d['median_changes_per_switch'])} | {first} | {stays} |")
            if s:
                sacc = s["accuracy_per_log"]
                first, stays = detection(s["first_latency"], s["latency"], switches)
                rows.append(f"| {label} | {group} | {bank} | smoothed | {fmt(sacc['mean'], 3)} ± {fmt(sacc['std'], 3)} | "
                            f"{fmt(sacc['min'], 3)} | {fmt(s['mean_truth_probability'], 3)} | "
                            f"{fmt(s['changes_per_minute']['most_likely'], 1)} ({fmt(per_minute['truth'], 1)}) | "
                            f"{per_switch(s['latency']['median_changes_per_switch'])} | {first} | {stays} |")
    return "\n".join(rows) + (
        f"\n\n{seeds} seeds per scenario. *ideal*: the simulator's ideal sensors, banks in `configs/` (R is those "
        "sensors' own noise); *realistic*: a Husky-class robot's sensors, banks in `configs/realistic/` (R estimated "
        "by `skidimm tune`). *most likely*: the filter's most likely mode at each step; *decision*: "
        f"the filter's decision with the default thresholds ({settings_text(defaults)}; `unknown` counts as "
        "wrong); *smoothed*: the most likely mode smoothed over the whole log (`run --smooth`). Accuracy is the "
        "fraction of time the estimate is the true mode; *never* counts the switches where it did not happen.\n")


def confusion_table(data, sensors, bank):
    confusion = data["overall"]["confusion_seconds"]
    modes = sorted({e for row in confusion.values() for e in row} | set(confusion))
    rows = [f"Confusion, {SENSOR_LABEL[sensors]} sensors, bank `{bank}`, all seeds (rows: truth, columns: estimate, "
            "fraction of the truth's time):", "",
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


def shows_confusion(experiment, sensors, bank):
    """Which confusion tables the page prints: every 3- and 4-mode bank, and
    the 16-mode banks with the realistic sensors only (16 columns each)."""
    return not bank.endswith("16") or sensors == "realistic"


def block(evals, seeds, experiment, defaults):
    text = summary_table(evals, seeds, defaults) + "\n"
    text += "\n".join(confusion_table(d, s, b) for s, b, d, _ in evals if shows_confusion(experiment, s, b))
    return text


def group_of(evals, sensors, bank, group, smoothed=False):
    for s, b, d, sm in evals:
        if s == sensors and b == bank:
            source = sm if smoothed else d
            return source["groups"].get(group) if source else None
    return None


def class_of(mode):
    for c in INDISTINGUISHABLE:
        if mode in c:
            return c
    return {mode}


def class_accuracy(g, strict=False):
    """Time fraction the estimate is the truth or indistinguishable from it
    (strict: the truth only)."""
    right = total = 0.0
    for truth, row in g["confusion_seconds"].items():
        same = {truth} if strict else class_of(truth)
        for estimate, seconds in row.items():
            total += seconds
            right += seconds if estimate in same else 0.0
    return right / total if total else None


def followed_within(data, smoothed, seconds):
    """Switches (one per seed) whose new mode is most likely, decided and
    smoothed from within `seconds` of the switch until the end."""
    def count(source):
        n = 0
        for g in source["groups"].values():
            n += sum(1 for s in g["switches"] if s["latency"] is not None and s["latency"] <= seconds)
        return n
    decided = sum(1 for log in data["logs"].values()
                  if log["decision"]["settled"] and log["decision"]["settled_median"] <= seconds)
    first_never = sum(g["latency"]["switches"] - g["first_latency"]["detected"] for g in data["groups"].values())
    total = sum(g["latency"]["switches"] for g in data["groups"].values())
    return count(data), decided, count(smoothed) if smoothed else None, first_never, total


def verdict(met):
    return "**met**" if met else "not met"


def targets_table(all_evals, seeds):
    singular = all_evals.get("stc_singular", [])
    switching = all_evals.get("stc_switching", [])
    models = (("eq. 3", "stc_slip"), ("sided", "stc_sided"), ("sided + currents", "stc_traction"))
    rows = ["| target (realistic sensors, %s seeds) | estimate | eq. 3 (`stc_slip4`, `stc_slip16`) | "
            "sided (`stc_sided4`, `stc_sided16`) | sided + currents (`stc_traction4`, `stc_traction16`) | "
            "met by sided + currents? |" % seeds,
            "|---|---|---|---|---|---|"]
    text = lambda vs: ", ".join(fmt(v) for v in vs)
    # 1. Four modes: each configuration identified at least 80% of the time.
    for estimate, smoothed in (("most likely", False), ("smoothed", True)):
        cells = {}
        for _, prefix in models:
            values = []
            for mode in FOUR:
                g = group_of(singular, "realistic", prefix + "4", "stc_singular_" + mode, smoothed)
                values.append(None if g is None else g["accuracy_per_log"]["mean"])
            cells[prefix] = values
        met = all(v is not None and v >= TARGET_ACCURACY_4 for v in cells["stc_traction"])
        rows.append(f"| 4 modes: each of no slip, front two, right two, all four identified >= "
                    f"{TARGET_ACCURACY_4:.0%} of the time | {estimate} | "
                    + " | ".join(text(cells[prefix]) for _, prefix in models) + f" | {verdict(met)} |")
    # 2. Fig. 6: the switch followed and held within 3 s in at least 18 of 20 seeds.
    results = {}
    for _, prefix in models:
        for s, b, d, sm in switching:
            if s == "realistic" and b == prefix + "4":
                results[prefix] = followed_within(d, sm, TARGET_SWITCH_SECONDS)
    if len(results) == len(models):
        for index, estimate in ((0, "most likely"), (1, "decision"), (2, "smoothed")):
            cell = lambda r: f"{r[index]} of {r[4]}"
            met = results["stc_traction"][index] is not None and results["stc_traction"][index] >= TARGET_SWITCH_SEEDS
            rows.append(f"| Fig. 6: right two -> all four followed and held within {TARGET_SWITCH_SECONDS:.0f} s "
                        f"in >= {TARGET_SWITCH_SEEDS} of 20 seeds | {estimate} | "
                        + " | ".join(cell(results[prefix]) for _, prefix in models) + f" | {verdict(met)} |")
        rows.append("| Fig. 6: the switch never detected at all (most likely) | most likely | "
                    + " | ".join(f"{results[prefix][3]} of {results[prefix][4]}" for _, prefix in models) + " | - |")
    # 3. Sixteen modes: the true configuration or one indistinguishable from it.
    for estimate, smoothed in (("most likely", False), ("smoothed", True)):
        cells = {}
        for _, prefix in models:
            values = []
            for mode in FOUR:
                g = group_of(singular, "realistic", prefix + "16", "stc_singular_" + mode, smoothed)
                values.append(None if g is None else class_accuracy(g, strict=prefix + "16" in MEASURES_CURRENTS))
            cells[prefix] = values
        met = all(v is not None and v >= TARGET_ACCURACY_16 for v in cells["stc_traction"])
        rows.append(f"| 16 modes: the true configuration (without currents: or no slip and all four taken for "
                    f"each other) >= {TARGET_ACCURACY_16:.0%} of the time | {estimate} | "
                    + " | ".join(text(cells[prefix]) for _, prefix in models) + f" | {verdict(met)} |")
    return "\n".join(rows) + (
        "\n\nAccuracies are listed for no slip, front two, right two and all four slipping, in that order: the "
        "fraction of time over the seeds' 30 s spirals. *Followed and held*: the new mode is the estimate from "
        "within 3 s of the switch until the end of the run (the decision: it settles on it within 3 s). For 16 "
        "modes, the kinematic models' estimate counts as right when it is the true configuration or, for no slip "
        "and all four, either of them (docs/simulation.md: scaling every wheel's friction alike does not change "
        "the motion); the model that measures the motor currents, which do tell them apart, must name the true "
        "configuration.\n")


TARGET_CHANGES_PER_SWITCH = 1.0
TARGET_SETTLED_EXTRA_SECONDS = 1.0
TARGET_SMOOTHING_BELOW = 0.99


def decision_target(group):
    """The decision target on one experiment's eval group: (met,
    changes per switch, switches lost, settled median, most likely's first
    median)."""
    d = group["decision"]
    changes = d["median_changes_per_switch"]
    lost = d["lost"]
    settled, first = d["settled_median"], group["first_latency"]["median"]
    # A decision that never settles on a new mode is not in time, even where
    # the most likely mode never finds one either.
    in_time = settled is not None and first is not None and settled <= first + TARGET_SETTLED_EXTRA_SECONDS
    met = changes is not None and changes <= TARGET_CHANGES_PER_SWITCH and lost == 0 and in_time
    return met, changes, lost, settled, first


def settings_text(settings):
    enter, leave, hold = settings
    return f"enter {enter:g}, leave {leave:g}, hold {hold:g} s"


def decision_defaults_table(directory, defaults):
    """The decision's settings tried on switching logs of their own seeds:
    every candidate setting scored on every switching experiment (sensor set
    and bank) by the decision target, the decision's accuracy and how
    often it changes per true switch (mean over logs: the target's median
    hides the seeds where it flickers). Marks the defaults and names the
    setting that meets the target most often."""
    scores = {}  # (enter, leave, hold) -> [(met, accuracy, [changes per switch of each log])]
    for path in sorted(glob.glob(os.path.join(directory, "*.json"))):
        with open(path) as f:
            compared = json.load(f)["decision_settings"]  # one experiment, every setting (eval with lists)
        for setting in compared:
            candidate = (setting["enter"], setting["leave"], setting["hold"])
            data = setting["report"]
            per_log = [l["decision"]["median_changes_per_switch"] for l in data["logs"].values()]
            for group in data["groups"].values():
                scores.setdefault(candidate, []).append(
                    (decision_target(group)[0], group["decision"]["accuracy"], [c for c in per_log if c is not None]))
    if defaults not in scores:
        sys.exit(f"{directory}: the defaults ({settings_text(defaults)}) are not among the settings tried")
    counts = {len(v) for v in scores.values()}
    if len(counts) != 1:
        sys.exit(f"{directory}: the settings were tried on different numbers of experiments")

    def merit(setting):
        v = scores[setting]
        changes = [c for _, _, per_log in v for c in per_log]
        return (sum(met for met, _, _ in v), sum(a for _, a, _ in v) / len(v),
                sum(changes) / len(changes) if changes else None)

    def cell(setting):
        met, accuracy, changes = merit(setting)
        return f"{met} / {accuracy:.3f} / {fmt(changes)}"

    # Most experiments meeting the target, then the highest accuracy; ties
    # (settings that differ in leave only, say) go to the defaults' values.
    most = max(scores, key=lambda c: (merit(c)[0], round(merit(c)[1], 6),
                                      -sum(abs(a - b) for a, b in zip(c, defaults))))
    enters = sorted({c[0] for c in scores})
    leaves = sorted({c[1] for c in scores})
    holds = sorted({c[2] for c in scores})
    leave_matters = any(merit((e, l, h)) != merit((e, defaults[1], h)) for e, l, h in scores)
    rows = ["| enter | " + " | ".join(f"hold {h:g} s" for h in holds) + " |", "|---" * (len(holds) + 1) + "|"]
    for e in enters:
        cells = []
        for h in holds:
            c = (e, defaults[1], h)
            cells.append(f"**{cell(c)}**" if c == defaults else cell(c))
        rows.append(f"| {e:g} | " + " | ".join(cells) + " |")
    return "\n".join(rows) + (
        f"\n\nEach cell, with leave {defaults[1]:g}: the switching experiments (of {counts.pop()}: sensor set and "
        "bank) on which the decision meets its target / its accuracy averaged over them / its changes per true "
        f"switch, averaged over every log. Leave {', '.join(f'{x:g}' for x in leaves)} were tried with every enter "
        f"and hold: {'they differ' if leave_matters else 'it changes no score'}. In bold, the defaults "
        f"({settings_text(defaults)}): {cell(defaults)}. Meeting the target most often: {settings_text(most)}: "
        f"{cell(most)}.\n")


def decision_targets_table(all_evals, seeds, defaults):
    """The decision targets on the switching experiments, per sensor set and
    bank: the decision with its default settings changes at most once per
    true switch (median), loses no switch the most likely mode detected, and
    settles within 1 s of the most likely mode's first detection (medians);
    fixed-interval smoothing raises accuracy wherever the filter is below
    99%."""
    rows = ["| sensors | scenario | bank | decision: changes per switch (median) | decision: switches lost "
            "against the most likely | decision settled / most likely first (median) | decision target | "
            "accuracy: filter -> smoothed | smoothing target |",
            "|---|---|---|---|---|---|---|---|---|"]
    decision_met = decision_total = smoothing_met = smoothing_total = 0
    for experiment in ("ltc_switching", "stc_switching"):
        for sensors, bank, data, smoothed in all_evals.get(experiment, []):
            for group, g in data["groups"].items():
                met, changes, lost, settled, first = decision_target(g)
                decision_met += met
                decision_total += 1
                filtered = g["accuracy_per_log"]["mean"]
                smooth_cell, smooth_verdict = "-", "-"
                if smoothed:
                    s = smoothed["groups"][group]["accuracy_per_log"]["mean"]
                    smooth_cell = f"{fmt(filtered, 3)} -> {fmt(s, 3)}"
                    if filtered < TARGET_SMOOTHING_BELOW:
                        smoothing_total += 1
                        smoothing_met += s > filtered
                        smooth_verdict = verdict(s > filtered)
                    else:
                        smooth_verdict = "filter already >= 99%"
                rows.append(f"| {SENSOR_LABEL[sensors]} | {group} | {bank} | {fmt(changes, 1)} | {lost} | "
                            f"{fmt(settled)} s / {fmt(first)} s | {verdict(met)} | {smooth_cell} | "
                            f"{smooth_verdict} |")
    return "\n".join(rows) + (
        f"\n\nThe decision target is met on {decision_met} of {decision_total} sensor set and bank pairs; "
        f"smoothing raises accuracy on {smoothing_met} of the {smoothing_total} where the filter is below "
        f"{TARGET_SMOOTHING_BELOW:.0%}. {seeds} seeds each. *Lost*: switches the most likely mode was ever the new "
        "mode after and the decision never was. *Settled*: the decision is the new mode from then until the next "
        "switch; *first*: the most likely mode is the new mode for the first time; a dash where it never happened "
        "(then the target is not met). "
        f"The decision uses its default settings ({settings_text(defaults)}).\n")


def kinematics_table(directory, window=5.0, duration=30.0):
    """Per configuration and window of the spiral: yaw efficiency (omega over
    the wheels' r (phi_R - phi_L) / b) and speed efficiency (v_x over
    r (phi_L + phi_R) / 2), from the truth columns."""
    r, b = 0.165, 0.555
    files = sorted(glob.glob(os.path.join(directory, "*.csv")))
    if not files:
        return None
    starts = [window * i for i in range(int(duration / window))]
    rows = ["| configuration | " + " | ".join(f"{s:.0f}-{s + window:.0f} s" for s in starts) + " |",
            "|---" * (len(starts) + 1) + "|"]
    order = sorted(files, key=lambda p: (len(os.path.basename(p)), os.path.basename(p)))
    for path in order:
        sums = [[0.0, 0.0, 0.0, 0.0] for _ in starts]  # omega, requested yaw, v_x, requested speed
        with open(path) as f:
            for row in csv.DictReader(f):
                t = float(row["t"])
                i = int(t // window)
                if i >= len(starts):
                    continue
                left, right = float(row["true_phi_dot_L"]), float(row["true_phi_dot_R"])
                sums[i][0] += float(row["true_omega"])
                sums[i][1] += r * (right - left) / b
                sums[i][2] += float(row["true_V"])
                sums[i][3] += r * (left + right) / 2.0
        cells = [f"{fmt(s[0] / s[1])} / {fmt(s[2] / s[3])}" if s[1] and s[3] else "-" for s in sums]
        rows.append(f"| {os.path.basename(path)[:-4]} | " + " | ".join(cells) + " |")
    return "\n".join(rows) + (
        "\n\nEach cell: yaw efficiency / speed efficiency, the body's yaw rate and forward speed over what the "
        "measured wheel speeds would give an ideal differential drive, averaged over the window (truth columns of "
        "one run per configuration; the spiral's radius grows from 0.6 m to 4.2 m).\n")


def model_selection_table(directory, selection_seeds, all_evals, seeds):
    """The traction banks on the spirals kept for choices about their model
    (model_selection_seeds), next to the same banks on the scored seeds."""
    scored = {bank: data for sensors, bank, data, _ in all_evals.get("stc_singular", []) if sensors == "realistic"}
    rows = [f"| bank | scenario | accuracy on the model-selection seeds {selection_seeds[0]}-{selection_seeds[-1]} "
            f"(mean ± sd) | accuracy on the scored seeds (mean ± sd) | difference |", "|---|---|---|---|---|"]
    for path in sorted(glob.glob(os.path.join(directory, "*.json")), key=lambda p: BANK_ORDER.index(
            os.path.basename(p)[:-5].split("__")[2])):
        bank = os.path.basename(path)[:-5].split("__")[2]
        with open(path) as f:
            data = json.load(f)
        for group, g in data["groups"].items():
            if bank not in scored or group not in scored[bank]["groups"]:
                sys.exit(f"{path}: no scored result of {bank} on {group} to compare with")
            a, b = g["accuracy_per_log"], scored[bank]["groups"][group]["accuracy_per_log"]
            rows.append(f"| {bank} | {group} | {fmt(a['mean'], 3)} ± {fmt(a['std'], 3)} | "
                        f"{fmt(b['mean'], 3)} ± {fmt(b['std'], 3)} | {a['mean'] - b['mean']:+.3f} |")
    return "\n".join(rows) + (
        f"\n\nMost likely mode, a Husky's sensors; {len(selection_seeds)} model-selection seeds and {seeds} scored "
        "seeds per scenario (the same scenarios, `configs/scenarios/realistic/`).\n")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("eval_dir")
    parser.add_argument("results")
    parser.add_argument("seeds")
    parser.add_argument("kinematics_dir", nargs="?")
    parser.add_argument("--decision-defaults", metavar="DIR")
    parser.add_argument("--compiled-defaults", metavar="ENTER,LEAVE,HOLD", default="0.9,0.05,1",
                        help="skidimm's decision defaults (DecisionConfig), as a run's summary names them")
    parser.add_argument("--model-selection", metavar="DIR",
                        help="eval outputs of the traction banks on the model-selection seeds")
    parser.add_argument("--model-selection-seeds", metavar="SEEDS", help="those seeds, space-separated")
    args = parser.parse_args()
    defaults = tuple(float(x) for x in args.compiled_defaults.split(","))
    if len(defaults) != 3:
        sys.exit("--compiled-defaults: expected ENTER,LEAVE,HOLD")
    evals = load_evals(args.eval_dir)
    seeds = args.seeds
    blocks = {experiment: block(e, seeds, experiment, defaults) for experiment, e in evals.items()}
    if "stc_singular" in evals and "stc_switching" in evals:
        blocks["stc_targets"] = targets_table(evals, seeds)
    if "ltc_switching" in evals and "stc_switching" in evals:
        blocks["decision_targets"] = decision_targets_table(evals, seeds, defaults)
    if args.decision_defaults:
        blocks["decision_defaults"] = decision_defaults_table(args.decision_defaults, defaults)
    if args.model_selection:
        blocks["model_selection"] = model_selection_table(
            args.model_selection, [int(x) for x in args.model_selection_seeds.split()], evals, seeds)
    if args.kinematics_dir:
        table = kinematics_table(args.kinematics_dir)
        if table:
            blocks["stc_kinematics"] = table
    with open(args.results) as f:
        text = f.read()
    for name, content in blocks.items():
        pattern = re.compile(r"(<!-- results:%s -->\n).*?(<!-- end -->)" % re.escape(name), re.S)
        if not pattern.search(text):
            sys.exit(f"{args.results}: no <!-- results:{name} --> block")
        text = pattern.sub(lambda m: m.group(1) + content + m.group(2), text)
    with open(args.results, "w") as f:
        f.write(text)


if __name__ == "__main__":
    main()
