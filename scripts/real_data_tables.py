#!/usr/bin/env python3
"""Fills the <!-- real:NAME --> ... <!-- end --> blocks of docs/real-data.md
from the outputs of scripts/reproduce_real_data.sh. Standard library only.

    real_data_tables.py <work dir> <real-data.md> <borealtc data dir>

It also checks that the nested scores `skidimm tune` printed and those
`skidimm eval --estimates` computed from tune's held-out outputs agree: the
page's numbers are the same whichever tool is asked.
"""
import csv
import functools
import glob
import json
import os
import re
import sys

import borealtc_splices

TERRAINS = borealtc_splices.TERRAINS

# What each protocol holds out, by the slug tune's table and estimate folders use.
HELD_OUT = {
    "logs": "each development run",
    "sessions": "each session (neighbouring run numbers)",
    "extrapolation-speed": "per terrain, the fastest-driven runs",
    "extrapolation-turn": "per terrain, the runs turning the most",
    "lockbox": "**the lockbox**: 10 runs no fit, setting or choice used",
}
# The protocols on the development runs: every one but the lockbox.
DEVELOPMENT = tuple(slug for slug in HELD_OUT if slug != "lockbox")
# The first design and the physics-shaped form are compared with the design on (reproduce_real_data.sh,
# `compared`): every one that holds out several runs at a time, not each run alone.
COMPARED = tuple(slug for slug in DEVELOPMENT if slug != "logs")
COUNT = {1: "one", 2: "two", 3: "three", 4: "four", 5: "five"}
# The same, short, inside a sentence.
SHORT = {
    "logs": "each run",
    "sessions": "each session",
    "extrapolation-speed": "the fastest-driven runs",
    "extrapolation-turn": "the runs turning the most",
    "lockbox": "the lockbox",
}
TITLES = {
    "logs": "logs",
    "sessions": "sessions",
    "extrapolation in speed": "extrapolation-speed",
    "extrapolation in turn": "extrapolation-turn",
}


def fmt(x, digits=3):
    return "-" if x is None else f"{x:.{digits}f}"


def pct(x):
    return "-" if x is None else f"{100 * x:.1f}%"


def read(path):
    with open(path) as f:
        return f.read()


def decision_settings(bank):
    """The decision layer's settings as the bank states them (`decision: {enter: .., leave: .., min_hold: ..}`
    on one line), else the engine's defaults (bank.h, DecisionConfig)."""
    settings = {"enter": 0.9, "leave": 0.05, "min_hold": 1.0}
    with open(bank) as f:
        for line in f:
            if line.startswith("decision:"):
                for key, value in re.findall(r"(enter|leave|min_hold):\s*([0-9.e+-]+)", line):
                    settings[key] = float(value)
    return f"enter {settings['enter']:g}, leave {settings['leave']:g}, hold {settings['min_hold']:g} s"


def husky(work):
    rows = ["| objective | fitted on runs 01-09: innovation or one-step RMSE (V m/s, omega rad/s) | "
            "held out run 10: one-step RMSE V, omega | held out run 11 | held-out NLL per measured row (10, 11) |",
            "|---|---|---|---|---|"]
    for objective in ("window", "likelihood"):
        text = read(os.path.join(work, "husky", objective + ".report"))
        fitted = re.search(r"(?:one-step|innovation) RMSE: V ([0-9.e+-]+), omega ([0-9.e+-]+)", text)
        held = re.findall(r"held out (TSyn_1[01])\.csv\S* \(ice\): one-step RMSE V ([0-9.e+-]+), omega ([0-9.e+-]+)"
                          r"[^;\n]*(?:; negative log-likelihood per measured row ([0-9.e+-]+))?", text)
        if not fitted or len(held) != 2:
            sys.exit(f"husky/{objective}.report: unexpected format")
        nll = ", ".join(h[3] for h in held) if all(h[3] for h in held) else "-"
        rows.append(f"| {objective} | {fitted.group(1)}, {fitted.group(2)} | {held[0][1]}, {held[0][2]} | "
                    f"{held[1][1]}, {held[1][2]} | {nll} |")
    base = re.findall(r"no-change baseline V ([0-9.e+-]+), omega ([0-9.e+-]+)", text)
    rows.append(f"| no change (z<sub>k+1</sub> = z<sub>k</sub>) | | {base[0][0]}, {base[0][1]} | "
                f"{base[1][0]}, {base[1][1]} | |")
    return "\n".join(rows) + "\n"


def tune_blocks(path):
    """tune's stdout as {slug: {"classes": {name: (accuracy, log p)}, "mean": .., "log_p": .., "verdict": ..}},
    with "chosen" the settings chosen on every development log."""
    text = read(path)
    out = {"chosen": text.splitlines()[0][len("chosen: "):]}
    parts = re.split(r"\n(?=nested assessment, protocol |lockbox \(|cross-validation with)", text)
    for part in parts[1:]:
        title = part.splitlines()[0]
        if title.startswith("nested assessment, protocol "):
            name = re.match(r"nested assessment, protocol (.*?) \(", title).group(1)
            slug = TITLES[name]
        elif title.startswith("lockbox"):
            slug = "lockbox"
        else:
            slug = "selection"
        classes = {c: (float(a), float(lp)) for c, a, lp in
                   re.findall(r" (\w+) ([0-9.]+) \((-?[0-9.]+)\)", part.split("per class (mean over its logs):")[1]
                              .split("\n")[0])}
        mean = re.search(r"mean over classes: accuracy ([0-9.]+), mean log p\(truth\) (-?[0-9.]+)", part)
        lines = part.rstrip("\n").splitlines()
        verdict = lines[-1].strip() if slug != "selection" else ""
        # The share of held-out steps outside the true class's fitted ranges, and the accuracy there and elsewhere.
        # (tune names only the sides that have steps: "A of those and B of the others", "A of those", "B of the steps")
        outside = re.search(r"inputs outside the ranges the true class was fitted on: ([0-9.]+%) of the labelled "
                            r"steps; the most likely class right on (?:([0-9.]+%) of those)?(?: and )?"
                            r"(?:([0-9.]+%) of the (?:others|steps))?\n", part)
        out[slug] = {"classes": classes, "mean": float(mean.group(1)), "log_p": float(mean.group(2)),
                     "verdict": verdict, "outside": outside.groups() if outside else None}
    return out


def scores_by_kind(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    out = {}
    for r in rows:
        out.setdefault(r["kind"], []).append(r)
    return out


def run_number(log):
    # tune names a run "pro_NN.csv+imu_NN.csv", or "TERRAIN/pro_NN.csv+..." where another terrain has a run NN.
    return re.match(r"(?:.*/)?pro_(\d+)\.csv", log).group(1)


def verdict_word(verdict):
    """The separability verdict in a word (evaluation::separability's describe())."""
    if verdict.startswith("the classes are told apart ("):
        return "told apart"
    if "worse than" in verdict:
        return "**worse than a uniform guess**"
    if "cannot be told apart" in verdict:
        return "**not told apart**"
    if "no more clearly than by chance" in verdict:
        worst = re.search(r"no better than the guess: (.*)$", verdict)
        return "unclear" + (f" (no better than a guess: {worst.group(1)})" if worst else "")
    return verdict


def assessed(work, prefix="", slugs=tuple(HELD_OUT)):
    """A design's scores on the protocols `slugs` (every one and the lockbox by default; {prefix}tune.txt,
    {prefix}scores.csv and {prefix}eval_<slug>.json), by slug: tune's block, eval's overall metrics and the
    table's rows; and tune's blocks."""
    blocks = tune_blocks(os.path.join(work, "borealtc", f"{prefix}tune.txt"))
    kinds = scores_by_kind(os.path.join(work, "borealtc", f"{prefix}scores.csv"))
    summary = {}
    for slug in slugs:
        evaluation = json.load(open(os.path.join(work, "borealtc", f"{prefix}eval_{slug}.json")))["overall"]
        tuned = blocks[slug]
        mean = evaluation["mean_over_classes"]["accuracy"]
        if f"{tuned['mean']:.3f}" != f"{mean:.3f}":
            sys.exit(f"{prefix}{slug}: tune's mean over classes {tuned['mean']:.3f} differs from eval's {mean:.3f}")
        for c, (a, _) in tuned["classes"].items():
            if f"{a:.3f}" != f"{evaluation['mean_over_classes']['per_class'][c]['accuracy']:.3f}":
                sys.exit(f"{prefix}{slug}, {c}: tune's accuracy differs from eval's")
        summary[slug] = {"tune": tuned, "eval": evaluation, "rows": kinds[slug]}
    return summary, blocks


# The held-back split's runs per terrain (reproduce_real_data.sh, held_back_split).
HELD_BACK_SPLIT = {"ASPHALT": 2, "FLOORING": 2, "ICE": 4, "SANDY_LOAM": 4, "SNOW": 9}


def held_back_range(evaluation):
    """The range of the mean over terrains a set of runs counted as the held-back split's would score, drawn as
    these runs were (eval --range-for), as a table cell; '-' where eval could not say."""
    r = evaluation["mean_over_classes"]["range"]
    if r.get("logs_per_class") != HELD_BACK_SPLIT or r.get("level") != 0.9:
        sys.exit(f"eval's range is not for the held-back split's counts at 9 in 10: {r}")
    if r["low"] is None:
        return "- (too few runs of each terrain)"
    return f"{pct(r['low'])}-{pct(r['high'])}"


def held_back_sentence(summary, order):
    """How far 21 runs counted as the held-back split's may fall from each protocol's mean."""
    ranges = [(slug, summary[slug]["eval"]["mean_over_classes"]["range"]) for slug in order]
    half = [r["half_width"] for _, r in ranges if r["half_width"] is not None]
    errors = ", ".join(f"{SHORT[slug]} {100 * r['standard_error']:.1f}" for slug, r in ranges
                       if r["standard_error"] is not None)
    split = ", ".join(f"{t} {n}" for t, n in HELD_BACK_SPLIT.items())
    return (f"*21 runs like these*: where the mean over terrains of {sum(HELD_BACK_SPLIT.values())} runs counted "
            f"as the data set's held-back split ({split}) would fall, were they drawn as the protocol's held-out runs "
            f"were: the 90% prediction interval from the spread of held-out runs about their terrain's mean, pooled "
            f"over terrains (Student's t, `skidimm eval --range-for`, [cli.md](cli.md#skidimm-eval)), clamped to "
            f"0-100%. Before clamping, the half-widths run from {100 * min(half):.1f} to {100 * max(half):.1f} points: "
            f"with so few runs of a terrain, and runs that are read right nearly throughout or wrong nearly "
            f"throughout, a set of 21 runs scores well away from any estimate made on others, however honest. The "
            f"standard errors of the protocols' own means, in points: {errors}.")


def protocols(work):
    """The headline table (every protocol, the most pessimistic first), the per-terrain table, and the
    protocols' summaries for the other blocks."""
    summary, blocks = assessed(work)

    order = sorted(HELD_OUT, key=lambda s: summary[s]["tune"]["mean"])
    lines = ["| held out | runs scored | mean over terrains | 21 runs like these: 90% range | "
             "worst terrain | runs below 50% | mean log p(truth) | "
             "time at p >= 0.9: share, right | calibration error | the terrains told apart? |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for slug in order:
        s = summary[slug]
        classes = s["tune"]["classes"]
        worst = min(classes, key=lambda c: classes[c][0])
        below = sum(float(r["accuracy"]) < 0.5 for r in s["rows"])
        cal = s["eval"]["calibration"]
        lines.append(f"| {HELD_OUT[slug]} | {len(s['rows'])} | **{pct(s['tune']['mean'])}** | "
                     f"{held_back_range(s['eval'])} | "
                     f"{worst} {pct(classes[worst][0])} | {below} | {fmt(s['tune']['log_p'], 2)} | "
                     f"{pct(cal['confident_fraction'])}, {pct(cal['confident_accuracy'])} | "
                     f"{fmt(cal['expected_calibration_error'])} | {verdict_word(s['tune']['verdict'])} |")
    pessimistic = order[0]
    development = [s for s in order if s != "lockbox"]
    text = "\n".join(lines) + (
        f"\n\nThe most pessimistic protocol: {HELD_OUT[pessimistic].replace('**', '')}, "
        f"{pct(summary[pessimistic]['tune']['mean'])}. Of the protocols on the development runs, the most "
        f"pessimistic is {HELD_OUT[development[0]]} ({pct(summary[development[0]]['tune']['mean'])}) and the most "
        f"optimistic {HELD_OUT[development[-1]]} ({pct(summary[development[-1]]['tune']['mean'])}); the lockbox "
        f"scored {pct(summary['lockbox']['tune']['mean'])}. Chosen on the development runs (the bank that scored the "
        f"lockbox): {blocks['chosen']}.\n\n{held_back_sentence(summary, order)}\n")

    terrain_lines = ["| terrain | development runs | " + " | ".join(
        HELD_OUT[s].split(":")[0].replace("**", "") for s in HELD_OUT) + " |", "|---" * (len(HELD_OUT) + 2) + "|"]
    for t in TERRAINS:
        runs = sum(r["truth"] == t for r in summary["logs"]["rows"])
        cells = []
        for slug in HELD_OUT:
            scored = [r for r in summary[slug]["rows"] if r["truth"] == t]
            cells.append(f"{pct(summary[slug]['tune']['classes'][t][0])} ({len(scored)})" if scored else "-")
        terrain_lines.append(f"| {t} | {runs} | " + " | ".join(cells) + " |")
    terrain_lines.append("| **mean over terrains** | | " + " | ".join(
        f"**{pct(summary[s]['tune']['mean'])}**" for s in HELD_OUT) + " |")
    terrain_text = "\n".join(terrain_lines) + (
        "\n\nEach cell: the terrain's accuracy, the mean over its runs scored by that protocol (how many in "
        "brackets). A terrain's runs that no protocol fold holds out (its runs on the spot, for the extrapolation "
        "protocols) are not scored there.\n")
    return summary, text, terrain_text


def calibration(summary):
    lines = ["| probability of the most likely terrain | " + " | ".join(
        f"{name}: share of time, right" for name in ("each run held out", "lockbox")) + " |", "|---|---|---|"]
    bins = {slug: summary[slug]["eval"]["calibration"]["bins"] for slug in ("logs", "lockbox")}
    totals = {slug: sum(b["seconds"] for b in bins[slug]) or 1.0 for slug in bins}
    for k in range(10):
        cells = []
        for slug in ("logs", "lockbox"):
            b = bins[slug][k]
            cells.append(f"{pct(b['seconds'] / totals[slug])}, {pct(b['accuracy'])}" if b["seconds"] > 0 else "-")
        if any(c != "-" for c in cells):
            lines.append(f"| {k / 10:.1f}-{(k + 1) / 10:.1f} | " + " | ".join(cells) + " |")
    rows = []
    for slug, name in (("logs", "each run held out"), ("lockbox", "lockbox")):
        e = summary[slug]["eval"]
        d = e["decision"]
        rows.append(f"{name}: Brier score {fmt(e['brier'])}; the decision is right {pct(d['accuracy'])} of the time "
                    f"(`unknown` {pct(d['unknown_fraction'])}), and when its terrain's probability is 0.9 or more "
                    f"({pct(d['calibration']['confident_fraction'])} of the time) right "
                    f"{pct(d['calibration']['confident_accuracy'])}")
    return "\n".join(lines) + "\n\n" + "; ".join(rows) + ".\n"


def confusion(summary, work):
    data = summary["logs"]["eval"]
    table = data["confusion_seconds"]
    conf = ["| true \\ estimated | " + " | ".join(TERRAINS) + " |", "|---" * (len(TERRAINS) + 1) + "|"]
    for t in TERRAINS:
        row = table.get(t, {})
        total = sum(row.values()) or 1.0
        conf.append(f"| {t} | " + " | ".join(
            (f"**{pct(row.get(e, 0.0) / total)}**" if e == t else pct(row.get(e, 0.0) / total)) for e in TERRAINS) + " |")
    decision = data["decision"]
    return "\n".join(conf) + (
        f"\n\nShare of each terrain's time (its development runs, each held out) by the most probable terrain. Over "
        f"all their time the most probable terrain is right {pct(data['accuracy'])} of the time; the decision layer "
        f"({decision_settings(os.path.join(work, 'borealtc', 'development.yaml'))}) {pct(decision['accuracy'])}, "
        f"counting `unknown` as wrong ({pct(decision['unknown_fraction'])} of the time `unknown`).\n")


def mean_over_classes(rows):
    """A table's rows as tune summarises them: per class the mean over its logs, then the mean over classes
    (accuracy, mean log p(truth))."""
    by_class = {}
    for r in rows:
        by_class.setdefault(r["truth"], []).append((float(r["accuracy"]), float(r["mean_log_probability"])))
    means = [(sum(a for a, _ in v) / len(v), sum(lp for _, lp in v) / len(v)) for v in by_class.values()]
    return sum(a for a, _ in means) / len(means), sum(lp for _, lp in means) / len(means)


def chosen_per_fold(ours, theirs, slug):
    """Per held-out set of protocol `slug`, the rows of the design whose inner cross-validation scored
    better (`selection_score`: chosen without the set; a tie keeps ours), and how many sets each won."""
    def folds(rows):
        out = {}
        for r in rows:
            out.setdefault(int(r["fold"]), []).append(r)
        return out
    a, b = folds(ours), folds(theirs)
    if sorted(a) != sorted(b):
        sys.exit(f"{slug}: the two designs' tables hold out different sets")
    rows, won = [], [0, 0]
    for fold in sorted(a):
        # By run: a log's name in a tune's table depends on the other logs given (distinct_names)
        logs = lambda rs: sorted((r["truth"], run_number(r["log"])) for r in rs)
        if logs(a[fold]) != logs(b[fold]):
            sys.exit(f"{slug}, held-out set {fold}: the two designs hold out different logs")
        take_theirs = float(b[fold][0]["selection_score"]) > float(a[fold][0]["selection_score"])
        rows += b[fold] if take_theirs else a[fold]
        won[take_theirs] += 1
    return rows, won


def check_table_agrees(rows, block, what):
    """Exits unless a --table's rows give the mean over classes its tune printed (`block`)."""
    if f"{mean_over_classes(rows)[0]:.3f}" != f"{block['mean']:.3f}":
        sys.exit(f"{what}'s table disagrees with its tune's mean over classes")


def physics(work, design):
    """The design's form against the physics-shaped one, both with each mode's parameter uncertainty; the
    rule the bank's form was kept by (the better worst case over the protocols) on them; and the rule that
    chooses between them inside each fold by the fold's inner cross-validation."""
    other = tune_blocks(os.path.join(work, "borealtc", "physics_tune.txt"))
    other_rows = scores_by_kind(os.path.join(work, "borealtc", "physics_scores.csv"))
    design_rows = scores_by_kind(os.path.join(work, "borealtc", "scores.csv"))
    lines = ["| held out | straight lines in speed and turn (the design) | physics-shaped inputs | "
             "the form each fold's inner cross-validation chose | folds that chose the physics-shaped form |",
             "|---|---|---|---|---|"]
    slugs = COMPARED
    chosen_means = []
    for slug in slugs:
        ours, theirs = design[slug]["tune"], other[slug]
        check_table_agrees(design_rows[slug], ours, f"{slug}: the bank's form")
        check_table_agrees(other_rows[slug], theirs, f"{slug}: the physics-shaped form")
        rows, won = chosen_per_fold(design_rows[slug], other_rows[slug], slug)
        accuracy, log_p = mean_over_classes(rows)
        chosen_means.append(accuracy)
        lines.append(f"| {HELD_OUT[slug]} | {pct(ours['mean'])} ({fmt(ours['log_p'], 2)}) | "
                     f"{pct(theirs['mean'])} ({fmt(theirs['log_p'], 2)}) | {pct(accuracy)} ({fmt(log_p, 2)}) | "
                     f"{won[1]} of {sum(won)} |")
    ours = {s: design[s]["tune"]["mean"] for s in slugs}
    theirs = {s: other[s]["mean"] for s in slugs}
    n = len(slugs)
    worst_ours, worst_theirs = min(slugs, key=ours.get), min(slugs, key=theirs.get)
    better = [HELD_OUT[s] for s in slugs if theirs[s] > ours[s]]
    mean_ours, mean_theirs = sum(ours.values()) / n, sum(theirs.values()) / n
    if ours[worst_ours] >= theirs[worst_theirs]:
        verdict = ("the bank's form keeps the better worst case, and by that rule the bank keeps its form"
                   + (", though the physics-shaped form has the better mean" if mean_theirs > mean_ours else ""))
    else:
        verdict = ("**the physics-shaped form has the better worst case: by the rule that kept the bank's form, "
                   "the bank should take the physics-shaped form**")
    worst = (f"for both {HELD_OUT[worst_ours]}, {pct(ours[worst_ours])} against {pct(theirs[worst_theirs])}"
             if worst_ours == worst_theirs else
             f"{pct(ours[worst_ours])} ({HELD_OUT[worst_ours]}) against {pct(theirs[worst_theirs])} "
             f"({HELD_OUT[worst_theirs]})")
    selection = [float(design_rows["selection"][0]["selection_score"]),
                 float(other_rows["selection"][0]["selection_score"])]
    rule = "the physics-shaped form" if selection[1] > selection[0] else "the bank's form"
    r = printed
    rule_mean, rule_worst = sum(chosen_means) / n, min(chosen_means)
    fixed_means, fixed_worsts = (mean_ours, mean_theirs), (ours[worst_ours], theirs[worst_theirs])
    if r(rule_mean) <= r(min(fixed_means)) and r(rule_worst) <= r(min(fixed_worsts)):
        rule_verdict = "no better than either form kept fixed, on the mean or on the worst protocol"
    elif r(rule_mean) >= r(max(fixed_means)) and r(rule_worst) >= r(max(fixed_worsts)):
        rule_verdict = "better than either form kept fixed, on the mean and on the worst protocol"
    else:
        rule_verdict = "between the two forms kept fixed"
    return "\n".join(lines) + (
        "\n\nMean over terrains, the mean held-out log p(truth) in brackets; the same development runs, folds and "
        f"searched settings, both forms with parameter uncertainty and partial pooling. Mean over the {COUNT[n]} protocols: "
        f"{pct(mean_ours)} for the bank's form, {pct(mean_theirs)} for the physics-shaped form; the worst "
        f"protocol, {worst}: {verdict}. The physics-shaped form is better "
        f"{'on: ' + '; '.join(better) if better else 'on none of them'}. Chosen for it on every development run: "
        f"{other['chosen']}. Chosen inside each fold (the form whose inner cross-validation, without the fold, "
        f"scored the better mean log p(truth)): mean over the {COUNT[n]} protocols {pct(rule_mean)}, the worst "
        f"{pct(rule_worst)}, {rule_verdict}; on every development run, that rule chooses {rule} "
        f"(cross-validated mean log p(truth) {fmt(selection[0], 3)} for the bank's form, {fmt(selection[1], 3)} for "
        "the physics-shaped form).\n")


FIRST = "without (the first design)"


def comparison_rows(base, variant, slugs, column, base_name, with_name):
    """Two designs' scores on the held-out sets `slugs` (each: slug -> (tune block, eval overall, table rows)):
    the table's rows, and the lists of what got better and worse from the first to the second."""
    lines = [f"| held out | {column} | mean over terrains | mean log p(truth) | "
             "time at p >= 0.9: share, right | calibration error | the two worst runs |", "|---|---|---|---|---|---|---|"]
    better, worse = [], []
    for slug in slugs:
        forms = {base_name: base[slug], with_name: variant[slug]}
        for name, (tuned, ev, rows) in forms.items():
            cal = ev["calibration"]
            worst = sorted(rows, key=lambda r: float(r["accuracy"]))[:2]
            worst_text = ", ".join(f"{r['truth']} {run_number(r['log'])} {pct(float(r['accuracy']))}" for r in worst)
            lines.append(f"| {HELD_OUT[slug]} | {name} | {pct(tuned['mean'])} | {fmt(tuned['log_p'], 2)} | "
                         f"{pct(cal['confident_fraction'])}, {pct(cal['confident_accuracy'])} | "
                         f"{fmt(cal['expected_calibration_error'])} | {worst_text} |")
        without, with_ = forms[base_name], forms[with_name]
        for label, a, b, higher in (
                ("accuracy", without[0]["mean"], with_[0]["mean"], True),
                ("mean log p(truth)", without[0]["log_p"], with_[0]["log_p"], True),
                ("share right at p >= 0.9", without[1]["calibration"]["confident_accuracy"],
                 with_[1]["calibration"]["confident_accuracy"], True),
                ("calibration error", without[1]["calibration"]["expected_calibration_error"],
                 with_[1]["calibration"]["expected_calibration_error"], False)):
            # No step at p >= 0.9 on one side: there is nothing to compare.
            if a is None or b is None or round(a, 3) == round(b, 3):
                continue
            (better if (b > a) == higher else worse).append(f"{label} ({SHORT[slug]})")
    return lines, better, worse


def as_forms(summary, slugs):
    return {slug: (summary[slug]["tune"], summary[slug]["eval"], summary[slug]["rows"]) for slug in slugs}


def extrapolation_rows(work, first, prefix, column, with_name, base_name=FIRST):
    """The first design (or `first`, another design named base_name) against one variant of it (its tune and
    eval files named by prefix), on the extrapolation protocols: the table's rows, the lists of what got better
    and worse, and the variant's tune blocks."""
    slugs = ("extrapolation-speed", "extrapolation-turn")
    other = tune_blocks(os.path.join(work, "borealtc", f"{prefix}_tune.txt"))
    kinds = scores_by_kind(os.path.join(work, "borealtc", f"{prefix}_scores.csv"))
    variant = {}
    for slug in slugs:
        evaluation = json.load(open(os.path.join(work, "borealtc", f"{prefix}_eval_{slug}.json")))["overall"]
        if f"{other[slug]['mean']:.3f}" != f"{evaluation['mean_over_classes']['accuracy']:.3f}":
            sys.exit(f"{prefix}, {slug}: tune's mean over classes differs from eval's")
        variant[slug] = (other[slug], evaluation, kinds[slug])
    lines, better, worse = comparison_rows(as_forms(first, slugs), variant, slugs, column, base_name, with_name)
    return lines, better, worse, other


def extrapolation_comparison(work, first, prefix, column, with_name, intro):
    """The first design against one variant of it on the extrapolation protocols, and the verdict."""
    lines, better, worse, other = extrapolation_rows(work, first, prefix, column, with_name)
    return "\n".join(lines) + (
        f"\n\nThe same development runs, folds and searched settings; the lockbox does not score this. {intro} "
        f"the scores are better in {len(better)} and worse in {len(worse)} of the {len(better) + len(worse)} "
        f"that differ: better: {'; '.join(better) if better else 'none'}; worse: {'; '.join(worse) if worse else 'none'}. "
        f"Chosen with it on every development run: {other['chosen']}.")


def printed(x):
    """A share as the tables print it (tenths of a percent), for comparing two of them: tune's blocks give three
    decimals, the rows more."""
    return round(x, 3)


def against_design(base, summary, named_blocks, change, names, words, rule=False):
    """One design (`base`) against another (`summary`) on the compared protocols of the development runs, then the
    lockbox, which scored each: the table (its column `change`, the two designs' `names`), the means and worst
    protocols (the designs as `words`), with `rule` what the rule the design's choices were made by says of taking
    `summary` over `base`, what got better and worse, the lockbox runs that moved by five points or more, and the
    settings of the design words[3] names (its tune blocks, `named_blocks`)."""
    development = COMPARED
    base_name, design_name = names
    lines, better, worse = comparison_rows(as_forms(base, development), as_forms(summary, development), development,
                                           change, base_name, design_name)
    box, box_better, box_worse = comparison_rows(as_forms(base, ("lockbox",)), as_forms(summary, ("lockbox",)),
                                                 ("lockbox",), change, base_name, design_name)
    mean = lambda s: sum(s[slug]["tune"]["mean"] for slug in development) / len(development)
    worst = lambda s: min(s[slug]["tune"]["mean"] for slug in development)
    verdict = ""
    if rule:
        taken = (printed(worst(summary)) > printed(worst(base)) and printed(mean(summary)) >= printed(mean(base)))
        verdict = (": a better worst case and a mean no worse: by the rule the design's choices were made by, it is "
                   "taken" if taken else
                   ": not a better worst case with a mean no worse: by the rule the design's choices were made by, it "
                   "is not taken")
    before = {r["log"]: float(r["accuracy"]) for r in base["lockbox"]["rows"]}
    moved = [(r["truth"], run_number(r["log"]), before[r["log"]], float(r["accuracy"]))
             for r in summary["lockbox"]["rows"] if abs(float(r["accuracy"]) - before[r["log"]]) >= 0.05]
    moved_text = ("; ".join(f"{t} {n} {pct(a)} -> {pct(b)}" for t, n, a, b in moved) if moved else "none")
    return "\n".join(lines + box[2:]) + (
        f"\n\nOn the development runs, the same folds and searched settings: mean over the "
        f"{COUNT[len(development)]} protocols "
        f"{pct(mean(base))} {words[0]}, {pct(mean(summary))} {words[1]}; the worst protocol {pct(worst(base))} "
        f"against {pct(worst(summary))}{verdict}. {words[2]} the development scores are better in {len(better)} and "
        f"worse in {len(worse)} of the {len(better) + len(worse)} that differ: better: "
        f"{'; '.join(better) if better else 'none'}; worse: {'; '.join(worse) if worse else 'none'}. On the lockbox, "
        f"better: {'; '.join(x.split(' (')[0] for x in box_better) if box_better else 'none'}; worse: "
        f"{'; '.join(x.split(' (')[0] for x in box_worse) if box_worse else 'none'}; its runs that moved by five "
        f"points or more: {moved_text}. {words[3]}'s settings, chosen on every development run: "
        f"{named_blocks['chosen']}.\n")


def uncertainty(first, second, first_blocks):
    """The first design against the second, which adds each mode's parameter uncertainty."""
    return against_design(first, second, first_blocks, "parameter uncertainty", (FIRST, "with (the second design)"),
                          ("without", "with", "With parameter uncertainty", "The first design"))


def per_log(second, third, third_blocks):
    """The second design (each mode's parameter uncertainty, its rows counted independent) against the third design
    (each log's rows counted as correlated), and what the rule the design's choices are made by says of it. The
    script keeps the second design's way; a rule that took the third design would make its tables untrue, and stops
    it."""
    text = against_design(second, third, third_blocks, "the rows of a log",
                          ("independent (the second design)", "correlated (the third design)"),
                          ("with the rows counted independent", "with each log's counted as correlated",
                           "Counted as correlated,", "The third design"), rule=True)
    if ", it is taken" in text:
        sys.exit("per_log: the rule takes the third design (each log's rows counted as correlated), which "
                 "scripts/reproduce_real_data.sh does not use")
    return text


def pooling(second, summary, second_blocks):
    """The second design against the design, which pools the fits of each regime's modes partially, and what the
    rule the design's choices are made by says of it. A rule that did not take it would make the page untrue: the
    script stops."""
    text = against_design(second, summary, second_blocks, "partial pooling",
                          ("without (the second design)", "with (the design)"),
                          ("without", "with", "With partial pooling,", "The second design"), rule=True)
    if ", it is taken" not in text:
        sys.exit("pooling: the rule does not take partial pooling, which scripts/reproduce_real_data.sh uses")
    return text


def unknown(work, first):
    """The design with and without an unknown hypothesis, on the extrapolation protocols, and how much of the
    held-out time the unknown hypothesis held."""
    text = extrapolation_comparison(work, first, "unknown", "unknown hypothesis", "with",
                                    "With the unknown hypothesis")
    held = []
    for slug in ("extrapolation-speed", "extrapolation-turn"):
        rows = total = most_likely = 0
        for path in sorted(glob.glob(os.path.join(work, "borealtc", "unknown_held_out", slug, "*.csv"))):
            with open(path) as f:
                for r in csv.DictReader(f):
                    rows += 1
                    total += float(r["unknown_probability"])
                    most_likely += r["mode"] == "unknown"
        held.append(f"{HELD_OUT[slug].split(', ')[1]}: mean probability {fmt(total / rows)}, the most likely "
                    f"{pct(most_likely / rows)} of the steps")
    return text + " The unknown hypothesis on the held-out runs: " + "; ".join(held) + ".\n"


def discount(work, first, summary):
    """The first design and the design, each with and without the extrapolation discount, on the extrapolation
    protocols; what each fold chose; and what the rule the design's choices were made by says of it."""
    slugs = ("extrapolation-speed", "extrapolation-turn")
    first_lines, first_better, first_worse, first_other = extrapolation_rows(
        work, first, "discount_first", "extrapolation discount", "with (the first design)")
    lines, better, worse, other = extrapolation_rows(work, summary, "discount", "extrapolation discount",
                                                     "with (the design)", "without (the design)")
    chosen = {}
    for prefix in ("discount_first", "discount"):
        # Each held-out log's row of a nested assessment ends with the settings its fold chose.
        for line in read(os.path.join(work, "borealtc", f"{prefix}_tune.txt")).splitlines():
            if not (re.match(r"  (?:\S*/)?pro_", line) and " objective " in line):
                continue
            scale = re.search(r"extrapolation scale (\S+?)(?:,|$)", line)
            if not scale:
                sys.exit(f"{prefix}: a fold's settings name no extrapolation scale: {line}")
            chosen.setdefault(prefix, set()).add(scale.group(1))
    folds = lambda prefix: ", ".join(sorted(chosen[prefix], key=lambda s: (s != "off", float(s) if s != "off" else 0)))
    worst = lambda design: min(design[slug][0]["mean"] for slug in slugs)
    mean = lambda design: sum(design[slug][0]["mean"] for slug in slugs) / len(slugs)
    design = {slug: (summary[slug]["tune"],) for slug in slugs}
    variant = {slug: (tune_blocks(os.path.join(work, "borealtc", "discount_tune.txt"))[slug],) for slug in slugs}
    adopted = worst(variant) > worst(design) and mean(variant) >= mean(design)
    verdict = (f"With the design, the worst of the two protocols is {pct(worst(variant))} with the discount against "
               f"{pct(worst(design))} without, the mean {pct(mean(variant))} against {pct(mean(design))}. By the rule "
               "parameter uncertainty was taken and the physics-shaped form was not by (a better worst case, and a "
               "mean no worse), " + ("the bank would take it." if adopted else "the bank does without it."))
    design_blocks = tune_blocks(os.path.join(work, "borealtc", "tune.txt"))
    if any(design_blocks[slug]["outside"] is None for slug in HELD_OUT):
        sys.exit("discount: the design's tune names no held-out steps outside the fitted ranges")
    shares = {slug: design_blocks[slug]["outside"] for slug in HELD_OUT}
    def accuracies(right, elsewhere):
        return ", ".join(([f"right on {right} of it"] if right else []) + ([f"{elsewhere} elsewhere"] if elsewhere else []))
    outside = "; ".join(f"{SHORT[slug]} {share} ({accuracies(right, elsewhere)})"
                        for slug, (share, right, elsewhere) in shares.items())
    # The held-out runs a quarter or more of whose steps lie outside their terrain's ranges, by protocol.
    kinds = scores_by_kind(os.path.join(work, "borealtc", "scores.csv"))
    far = []
    for slug in HELD_OUT:
        runs = [r for r in kinds[slug] if float(r["outside_fitted_inputs"]) >= 0.25]
        runs.sort(key=lambda r: (r["truth"], run_number(r["log"])))
        far.append(f"{SHORT[slug]}: " + (", ".join(
            f"{r['truth']} {run_number(r['log'])} ({pct(float(r['outside_fitted_inputs']))} of it, read right "
            f"{pct(float(r['accuracy']))})" for r in runs) if runs else "none"))
    return "\n".join(first_lines + lines[2:]) + (
        f"\n\nThe share of the held-out steps whose inputs lie outside the ranges the true terrain's modes were "
        f"fitted on in their fold, and the design's accuracy on them and elsewhere (step B1, every step of every "
        f"held-out run together): {outside}. The held-out runs with a quarter of their steps or more outside: "
        f"{'; '.join(far)}."
        f"\n\nThe same development runs, folds and searched settings; the lockbox does not score this. With the "
        f"discount, the first design's scores are better in {len(first_better)} and worse in {len(first_worse)} of "
        f"the {len(first_better) + len(first_worse)} that differ (better: "
        f"{'; '.join(first_better) if first_better else 'none'}; worse: "
        f"{'; '.join(first_worse) if first_worse else 'none'}); the design's, better in {len(better)} and worse in "
        f"{len(worse)} of {len(better) + len(worse)} (better: {'; '.join(better) if better else 'none'}; worse: "
        f"{'; '.join(worse) if worse else 'none'}). The scales the folds chose, in range widths: the first design "
        f"{folds('discount_first')}; the design {folds('discount')}. Chosen on every development run: the first "
        f"design {first_other['chosen']}; the design {other['chosen']}. {verdict}\n")


def correlation(work, first):
    """The design with and without correlated innovations: the extrapolation protocols, and development runs
    spliced end to end scored by each development bank."""
    lines, _, _, other = extrapolation_rows(work, first, "correlation", "correlated innovations", "with")
    rhos = [float(x) for x in re.findall(r"^    residual_correlation: (\S+)$",
                                         read(os.path.join(work, "borealtc", "correlation_development.yaml")), re.M)]
    if not rhos:
        sys.exit("correlation: the development bank has no residual_correlation")
    splice_lines = ["| development runs spliced (fitted on them) | without (the first design) | with |", "|---|---|---|"]
    spliced = {}
    for bank in ("first_development", "correlation_development"):
        spliced[bank] = json.load(open(os.path.join(work, "splices", f"{bank}_eval.json")))["overall"]
    def row(label, cell):
        splice_lines.append(f"| {label} | {cell(spliced['first_development'])} | {cell(spliced['correlation_development'])} |")
    row("accuracy (most likely terrain)", lambda d: pct(d["accuracy"]))
    row("changes of terrain", lambda d: str(d["latency"]["switches"]))
    row("new terrain first most likely: median, never", lambda d: f"{fmt(d['first_latency']['median'], 1)} s, never "
        f"{d['latency']['switches'] - d['first_latency']['detected']}")
    row("decision follows: median, never", lambda d: f"{fmt(d['decision']['first_median'], 1)} s, never "
        f"{d['decision']['switches'] - d['decision']['first_detected']}")
    row(f"changes of the most likely terrain per minute (truth: "
        f"{fmt(spliced['first_development']['changes_per_minute']['truth'], 2)})",
        lambda d: fmt(d["changes_per_minute"]["most_likely"], 2))
    return "\n".join(lines) + "\n\n" + "\n".join(splice_lines) + (
        "\n\nThe same development runs, folds and searched settings; the lockbox does not score this. Each fold fits "
        "every mode's residual correlation on its training runs; fitted on every development run they range from "
        f"{min(rhos):.2f} to {max(rhos):.2f} (median {sorted(rhos)[len(rhos) // 2]:.2f}). Chosen with them on every "
        f"development run: {other['chosen']}.\n")


def changes_not_followed(work, summary, data):
    """The lockbox splices' changes of terrain the most likely terrain never followed, and those it followed
    slowest, named by the runs on either side (the rotations borealtc_splices.py drives); how many of those
    never followed lead onto a run driven faster than every development run of its terrain."""
    lockbox_runs = [f"{r['truth']}/{run_number(r['log'])}" for r in summary["lockbox"]["rows"]]
    fastest = fastest_development_runs(summary, data)
    onto_faster = 0
    driven = borealtc_splices.rotations(lockbox_runs)
    logs = json.load(open(os.path.join(work, "splices", "eval.json")))["logs"]
    never, followed = {}, {}
    for name, result in logs.items():
        k = int(re.search(r"rotation_(\d+)\.csv$", name).group(1))
        for i, change in enumerate(result["switches"]):
            before, after = driven[k][i], driven[k][i + 1]
            if (change["from"], change["to"]) != (before.split("/")[0], after.split("/")[0]):
                sys.exit(f"{name}: change {i} is {change['from']} -> {change['to']}, not {before} -> {after}")
            label = f"{before.replace('/', ' ')} -> {after.replace('/', ' ')}"
            if change["first_latency"] is None:
                never[label] = never.get(label, 0) + 1
                terrain, number = after.split("/")
                onto_faster += driving(data, terrain, number)[0] > fastest[terrain]
            else:
                followed.setdefault(label, []).append(change["first_latency"])
    times = lambda n: "" if n == 1 else f" ({n} times)"
    slowest = sorted(followed.items(), key=lambda item: -max(item[1]))[:3]
    return ("Changes the most likely terrain never followed: "
            + ("; ".join(f"{label}{times(n)}" for label, n in sorted(never.items())) if never else "none")
            + (f", {onto_faster} of {sum(never.values())} onto a run driven faster than every development run of "
               "its terrain" if never else "")
            + ". Followed slowest: "
            + "; ".join(f"{label} after {', '.join(fmt(t, 1) for t in sorted(ts, reverse=True))} s"
                        for label, ts in slowest) + ".")


def splices(work, summary, data_dir):
    data = json.load(open(os.path.join(work, "splices", "eval.json")))["overall"]
    latency, first, decision = data["latency"], data["first_latency"], data["decision"]
    switches = latency["switches"]
    settings = decision_settings(os.path.join(work, "borealtc", "development.yaml"))
    lines = [f"| measure | most likely terrain | decision ({settings}) |", "|---|---|---|",
             f"| accuracy | {pct(data['accuracy'])} | {pct(decision['accuracy'])} |",
             f"| changes of terrain | {switches} | {decision['switches']} |",
             f"| new terrain first chosen: median, never | {fmt(first['median'], 1)} s, never {switches - first['detected']} | "
             f"{fmt(decision['first_median'], 1)} s, never {decision['switches'] - decision['first_detected']} |",
             f"| new terrain held until the next change: median, never | {fmt(latency['median'], 1)} s, "
             f"never {switches - latency['followed']} | {fmt(decision['settled_median'], 1)} s, "
             f"never {decision['switches'] - decision['settled']} |",
             f"| changes of estimate per change of terrain (median) | {fmt(latency['median_changes_per_switch'], 1)} | "
             f"{fmt(decision['median_changes_per_switch'], 1)} |",
             f"| changes of estimate per minute (truth: {fmt(data['changes_per_minute']['truth'], 2)}) | "
             f"{fmt(data['changes_per_minute']['most_likely'], 2)} | {fmt(data['changes_per_minute']['decision'], 2)} |",
             f"| time at p >= 0.9: share, right | {pct(data['calibration']['confident_fraction'])}, "
             f"{pct(data['calibration']['confident_accuracy'])} | "
             f"{pct(decision['calibration']['confident_fraction'])}, {pct(decision['calibration']['confident_accuracy'])} |",
             f"| time `unknown` | - | {pct(decision['unknown_fraction'])} |"]
    return "\n".join(lines) + "\n\n" + changes_not_followed(work, summary, data_dir) + "\n"


REACTION_FACTORS = (2, 4, 8)


def bank_weight(path):
    return float(re.search(r"^likelihood_weight: (\S+)$", read(path), re.M).group(1))


def reaction(work):
    """The lockbox splices scored by the development bank at its tuned likelihood weight and at multiples of it,
    and the weight a splice-scored search chooses on the development runs."""
    runs = {1: json.load(open(os.path.join(work, "splices", "eval.json")))["overall"]}
    weights = {1: bank_weight(os.path.join(work, "borealtc", "development.yaml"))}
    for factor in REACTION_FACTORS:
        runs[factor] = json.load(open(os.path.join(work, "splices", f"eval_x{factor}.json")))["overall"]
        weights[factor] = float(read(os.path.join(work, "borealtc", f"weight_x{factor}.txt")))
    order = (1,) + REACTION_FACTORS
    lines = ["| likelihood weight | " + " | ".join(
                 f"{fmt(weights[f], 4)} (tuned)" if f == 1 else f"{fmt(weights[f], 4)} (x {f})" for f in order) + " |",
             "|---" * (len(order) + 1) + "|"]

    def row(label, cell):
        lines.append(f"| {label} | " + " | ".join(cell(runs[f]) for f in order) + " |")

    row("accuracy: most likely terrain, decision", lambda d: f"{pct(d['accuracy'])}, {pct(d['decision']['accuracy'])}")
    row("mean log p(truth)", lambda d: fmt(d["mean_truth_log_probability"], 3))
    row("new terrain first most likely: median, never", lambda d: f"{fmt(d['first_latency']['median'], 1)} s, "
        f"never {d['latency']['switches'] - d['first_latency']['detected']}")
    row("decision follows: median, never", lambda d: f"{fmt(d['decision']['first_median'], 1)} s, "
        f"never {d['decision']['switches'] - d['decision']['first_detected']}")
    row("decision holds the new terrain until the next change: median, never",
        lambda d: f"{fmt(d['decision']['settled_median'], 1)} s, never {d['decision']['switches'] - d['decision']['settled']}")
    row("changes of the decision per minute (truth: "
        f"{fmt(runs[1]['changes_per_minute']['truth'], 2)})", lambda d: fmt(d["changes_per_minute"]["decision"], 2))
    row("time at p >= 0.9: share, right", lambda d: f"{pct(d['calibration']['confident_fraction'])}, "
        f"{pct(d['calibration']['confident_accuracy'])}")
    row("calibration error", lambda d: fmt(d["calibration"]["expected_calibration_error"], 3))
    chosen = read(os.path.join(work, "borealtc", "splice_tune.txt")).splitlines()[0][len("chosen: "):]
    searched = bank_weight(os.path.join(work, "borealtc", "splice_development.yaml"))
    doubled, tuned = runs[2], runs[1]
    better = doubled["mean_truth_log_probability"] > tuned["mean_truth_log_probability"]
    return "\n".join(lines) + (
        f"\n\nThe {tuned['latency']['switches']} changes of terrain of the lockbox splices above, scored by the "
        f"development bank with only its likelihood weight changed; nothing was chosen by these scores. On them, twice "
        f"the tuned weight scores {'better' if better else 'worse'} on mean log p(truth) "
        f"({fmt(doubled['mean_truth_log_probability'], 3)} against {fmt(tuned['mean_truth_log_probability'], 3)}). "
        f"A search that scores spliced development runs (`tune --splice --inner-folds 5`, so that each held-out set "
        f"holds several terrains) chose likelihood weight {fmt(searched, 4)}, {fmt(searched / weights[1], 2)} times "
        f"the tuned one (all its settings: {chosen}).\n")


def wheels(work):
    blocks = tune_blocks(os.path.join(work, "borealtc", "wheels_tune.txt"))
    evaluated = {held: json.load(open(os.path.join(work, "borealtc", f"wheels_eval_{held}.json")))["overall"]
                 for held in ("logs", "lockbox")}
    for held, evaluation in evaluated.items():
        if f"{blocks[held]['mean']:.3f}" != f"{evaluation['mean_over_classes']['accuracy']:.3f}":
            sys.exit(f"wheels: tune's {held} score differs from eval's")
    lines = ["| terrain | each development run held out | lockbox |", "|---|---|---|"]
    for t in TERRAINS:
        lines.append(f"| {t} | {pct(blocks['logs']['classes'][t][0])} | {pct(blocks['lockbox']['classes'][t][0])} |")
    lines.append(f"| **mean over terrains** | **{pct(blocks['logs']['mean'])}** ({fmt(blocks['logs']['log_p'], 2)}) | "
                 f"**{pct(blocks['lockbox']['mean'])}** ({fmt(blocks['lockbox']['log_p'], 2)}) |")
    lines.append(f"| 21 runs like these: 90% range | {held_back_range(evaluated['logs'])} | "
                 f"{held_back_range(evaluated['lockbox'])} |")
    cal = evaluated["lockbox"]["calibration"]
    return "\n".join(lines) + (
        f"\n\nMean log p(truth) in brackets; the last row as under the headline table. On the lockbox, the most "
        f"likely terrain has probability 0.9 or more {pct(cal['confident_fraction'])} of the time and is then right "
        f"{pct(cal['confident_accuracy'])}. Chosen on the development runs: {blocks['chosen']}.\n")


@functools.lru_cache(maxsize=None)
def wheel_file(data, terrain, number):
    """A run's wheel file, read once: its rows."""
    with open(os.path.join(data, terrain, "pro_%s.csv" % number), newline="") as f:
        return list(csv.DictReader(f))


def driving(data, terrain, number):
    """How a run was driven: mean |speed| and mean |velR - velL| (m/s) from its wheel file."""
    rows = wheel_file(data, terrain, number)
    speed = sum(abs(float(r["velL"]) + float(r["velR"])) / 2 for r in rows) / len(rows)
    turn = sum(abs(float(r["velR"]) - float(r["velL"])) for r in rows) / len(rows)
    return speed, turn


def fastest_development_runs(summary, data):
    """Per terrain, the mean speed (m/s) of its fastest development run."""
    fastest = {}
    for r in summary["logs"]["rows"]:
        speed, _ = driving(data, r["truth"], run_number(r["log"]))
        fastest[r["truth"]] = max(fastest.get(r["truth"], 0.0), speed)
    return fastest


def how_driven(speed, turn):
    """A run by its mean speed and turn (m/s): on the spot, turning or straight."""
    return "on the spot" if speed < 0.05 else ("turning" if turn > 0.08 else "straight")


def summed_current(data, terrain, number):
    """A run's mean summed motor current curL + curR (A) from its wheel file."""
    rows = wheel_file(data, terrain, number)
    return sum(float(r["curL"]) + float(r["curR"]) for r in rows) / len(rows)


def most_often_read_as(work, slug, terrain, number):
    """The terrain a held-out run's most likely mode belonged to most often, and the share of its steps, from the
    protocol's held-out estimates."""
    paths = glob.glob(os.path.join(work, "borealtc", "held_out", slug, "*_%s_pro_%s.csv" % (terrain, number)))
    if len(paths) != 1:
        sys.exit(f"{slug}: expected one held-out estimate file of {terrain} {number}, found {len(paths)}")
    counts = {}
    with open(paths[0]) as f:
        for r in csv.DictReader(f):
            read_as = next(t for t in TERRAINS if r["mode"] == t or r["mode"].startswith(t + "_"))
            counts[read_as] = counts.get(read_as, 0) + 1
    read_as = max(counts, key=counts.get)
    return read_as, counts[read_as] / sum(counts.values())


def pivots(summary, work, data):
    """The development runs driven on the spot (how_driven()): how fast each turned, the summed
    current it drew and its held-out accuracy, by terrain; and per terrain how the current follows the turn."""
    turn_held = {(r["truth"], run_number(r["log"])): float(r["accuracy"])
                 for r in summary["extrapolation-turn"]["rows"]}
    by_terrain = {}
    for r in summary["logs"]["rows"]:
        number = run_number(r["log"])
        speed, turn = driving(data, r["truth"], number)
        if how_driven(speed, turn) != "on the spot":
            continue
        by_terrain.setdefault(r["truth"], []).append(
            (turn, summed_current(data, r["truth"], number), number, float(r["accuracy"]),
             (r["truth"], number) in turn_held))
    lines = ["| terrain | run | mean turn (m/s) | mean summed current (A) | each run held out | "
             "held out by extrapolation in turn: accuracy, most often read as |", "|---|---|---|---|---|---|"]
    for terrain in TERRAINS:
        for turn, current, number, accuracy, held in sorted(by_terrain.get(terrain, [])):
            extrapolated = ""
            if held:
                read_as, share = most_often_read_as(work, "extrapolation-turn", terrain, number)
                extrapolated = f"{pct(turn_held[(terrain, number)])}, {read_as} ({pct(share)} of its steps)"
            lines.append(f"| {terrain} | {number} | {turn:.2f} | {current:.1f} | {pct(accuracy)} | {extrapolated} |")
    mean = lambda xs: sum(xs) / len(xs)
    slopes, split = [], []
    for terrain in TERRAINS:
        runs = by_terrain.get(terrain, [])
        if len(runs) >= 3:
            turn0, current0 = mean([x[0] for x in runs]), mean([x[1] for x in runs])
            slope = (sum((x[0] - turn0) * (x[1] - current0) for x in runs) /
                     sum((x[0] - turn0) ** 2 for x in runs))
            slopes.append(f"{terrain} {slope:+.0f} A per m/s ({len(runs)} runs)")
        held = [x for x in runs if x[4]]
        if held and len(held) < len(runs):
            rest = [x for x in runs if not x[4]]
            split.append(f"{terrain}: the {len(held)} held out turn at {mean([x[0] for x in held]):.2f} m/s and draw "
                         f"{mean([x[1] for x in held]):.1f} A, the {len(rest)} it is fitted on turn at "
                         f"{mean([x[0] for x in rest]):.2f} m/s and draw {mean([x[1] for x in rest]):.1f} A")
    return ("\n".join(lines) + "\n\nHow a terrain's current follows the turn on the spot (the least-squares slope of a "
            "run's mean summed current on its mean turn, terrains with three runs on the spot or more): "
            + "; ".join(slopes) + ". The runs on the spot that extrapolation in turn holds out, against those of "
            "their terrain it fits on: " + ("; ".join(split) if split else "none") + ".\n")


def confidently_wrong(work, slug):
    """Per (terrain, run) scored by protocol `slug`: the share of its time the most likely terrain had p >= 0.9
    and was wrong (`skidimm eval`'s per-log calibration of the held-out outputs)."""
    logs = json.load(open(os.path.join(work, "borealtc", f"eval_{slug}.json")))["logs"]
    out = {}
    for name, result in logs.items():
        terrain, number = re.search(r"\d+_(\w+?)_pro_(\d+)\.csv$", name).groups()
        calibration = result["calibration"]
        right = calibration["confident_accuracy"]  # none when never that sure
        out[(terrain, number)] = 0.0 if right is None else calibration["confident_fraction"] * (1.0 - right)
    return out


def per_run(summary, work, data):
    wheel_rows = scores_by_kind(os.path.join(work, "borealtc", "wheels_scores.csv"))
    sure_and_wrong = {**confidently_wrong(work, "logs"), **confidently_wrong(work, "lockbox")}
    wheel = {(r["truth"], run_number(r["log"])): float(r["accuracy"])
             for kind in ("logs", "lockbox") for r in wheel_rows[kind]}
    extrapolated = {(r["truth"], run_number(r["log"])): slug
                    for slug in ("extrapolation-speed", "extrapolation-turn") for r in summary[slug]["rows"]}
    lines = ["| terrain | run | set | driven | mean speed (m/s) | mean turn (m/s) | held-out accuracy | "
             "time sure of a wrong terrain (p >= 0.9) | held out for extrapolation in | wheels only |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    counts = {}
    rows = [(r, "development") for r in summary["logs"]["rows"]] + [(r, "lockbox") for r in summary["lockbox"]["rows"]]
    rows.sort(key=lambda x: (x[0]["truth"], run_number(x[0]["log"])))
    for r, kind_of_set in rows:
        number = run_number(r["log"])
        speed, turn = driving(data, r["truth"], number)
        kind = how_driven(speed, turn)
        acc = float(r["accuracy"])
        counts.setdefault(kind, []).append(acc)
        bold = lambda a: "**" + pct(a) + "**" if a < 0.5 else pct(a)
        held = extrapolated.get((r["truth"], number), "")
        held = {"extrapolation-speed": "speed", "extrapolation-turn": "turn"}.get(held, "")
        w = wheel.get((r["truth"], number))
        wrong = sure_and_wrong[(r["truth"], number)]
        lines.append(f"| {r['truth']} | {number} | {kind_of_set} | {kind} | {speed:.2f} | {turn:.2f} | {bold(acc)} | "
                     f"{'**' + pct(wrong) + '**' if wrong >= 0.25 else pct(wrong)} | {held} | "
                     f"{bold(w) if w is not None else '-'} |")
    # Lockbox runs driven faster than every development run of their terrain: the next run a user drives
    # faster than their fitting runs.
    development_speed = fastest_development_runs(summary, data)
    faster, others = [], []
    for r in summary["lockbox"]["rows"]:
        speed, _ = driving(data, r["truth"], run_number(r["log"]))
        (faster if speed > development_speed[r["truth"]] else others).append(
            (r["truth"], run_number(r["log"]), speed, float(r["accuracy"])))
    def mean(runs, of=lambda run: run[3]):
        return pct(sum(of(run) for run in runs) / len(runs)) if runs else "-"

    def wheels_only(run):
        return wheel[(run[0], run[1])]

    beyond = (f"\n\nLockbox runs driven faster than every development run of their terrain: "
              + ("; ".join(f"{t} {n} at {v:.2f} m/s (its development runs at most {development_speed[t]:.2f}): "
                           f"{pct(a)}, wheels only {pct(wheel[(t, n)])}" for t, n, v, a in faster)
                 if faster else "none")
              + f". Mean held-out accuracy of those: {mean(faster)}, wheels only {mean(faster, wheels_only)}; "
              f"of the other lockbox runs: {mean(others)}, wheels only {mean(others, wheels_only)}.")
    summary_text = "; ".join(f"{kind}: {len(a)} runs, mean {pct(sum(a) / len(a))}, {sum(x < 0.5 for x in a)} below 50%"
                             for kind, a in sorted(counts.items()))
    sure = sorted((w, key) for key, w in sure_and_wrong.items() if w >= 0.25)
    sure_text = ("Runs sure of a wrong terrain (p >= 0.9) for a quarter of their time or more: "
                 + ("; ".join(f"{t} {n} ({pct(w)})" for w, (t, n) in reversed(sure)) if sure else "none") + ". ")
    return "\n".join(lines) + (f"\n\n{sure_text}By how the run was driven (held-out accuracy): "
                               f"{summary_text}.{beyond}\n")


def main():
    work, doc, data = sys.argv[1], sys.argv[2], sys.argv[3]
    summary, headline, terrains = protocols(work)
    first, first_blocks = assessed(work, "first_", COMPARED + ("lockbox",))
    third, third_blocks = assessed(work, "correlated_", COMPARED + ("lockbox",))
    second, second_blocks = assessed(work, "unpooled_", COMPARED + ("lockbox",))
    blocks = {"husky": husky(work), "headline": headline, "terrains": terrains, "calibration": calibration(summary),
              "confusion": confusion(summary, work), "physics": physics(work, summary),
              "uncertainty": uncertainty(first, second, first_blocks),
              "per_log": per_log(second, third, third_blocks), "pooling": pooling(second, summary, second_blocks),
              "unknown": unknown(work, first),
              "discount": discount(work, first, summary),
              "correlation": correlation(work, first),
              "splices": splices(work, summary, data), "reaction": reaction(work),
              "wheels": wheels(work), "runs": per_run(summary, work, data), "pivots": pivots(summary, work, data)}
    text = read(doc)
    for name, block in blocks.items():
        pattern = re.compile(r"(<!-- real:%s -->\n).*?(<!-- end -->)" % re.escape(name), re.S)
        if not pattern.search(text):
            sys.exit(f"{doc}: no <!-- real:{name} --> block")
        text = pattern.sub(lambda m: m.group(1) + block + m.group(2), text)
    with open(doc, "w") as f:
        f.write(text)


if __name__ == "__main__":
    main()
