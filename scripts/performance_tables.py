#!/usr/bin/env python3
"""Writes docs/performance.md from one run of the benchmarks.

  scripts/performance_tables.py                # run skidimm_benchmarks, store docs/performance/results.json, write the page
  scripts/performance_tables.py --render       # write the page from the stored results only
  scripts/performance_tables.py --check BENCH  # the page is what the stored results give, and they cover every
                                               # benchmark family BENCH lists (the test; nothing is timed)

Every figure on the page is taken from docs/performance/results.json: one
run of build/bin/skidimm_benchmarks (Google Benchmark, JSON output,
repetitions in random interleaved order, medians), with the machine (CPU
model, cores, compiler, build type) and its load (load averages when the run
started and ended) stored beside the figures. Absolute times on a shared
machine are noise, so the figures that matter are ratios taken in the same
run: Imm::step against the hand-written fixed-size IMM, `skidimm run` against
its I/O floor (reading and writing alone), the .npy output against CSV.
"""
import argparse
import datetime
import json
import os
import pathlib
import re
import subprocess
import sys
import tempfile

import machine_info

ROOT = pathlib.Path(__file__).resolve().parent.parent
RESULTS = ROOT / "docs" / "performance" / "results.json"
PAGE = ROOT / "docs" / "performance.md"

# The speed targets the page states as met or not.
IMM_STEP_TARGET = 1.3  # Imm::step over the hand-written reference, every bank
PER_MODE_DWELL_TARGET = 1.3  # per-mode dwell times over equal dwell times, every bank of 4 modes or more
RUN_FLOOR_TARGET = 1.5  # skidimm run (CSV) over its I/O floor
NPY_SPEEDUP_TARGET = 2.0  # CSV run time over .npy run time
CORE_SHARE_TARGET = 5.0  # % of one core for 256 modes at 100 Hz
ALLOCATION_ROWS = 1000  # the run loop: fewer than one heap allocation per this many rows

BANKS = [("ltc_terrains", "3 x 2"), ("stc_slip4", "4 x 3"), ("stc_slip16", "16 x 3"), ("ltc16", "16 x 2")]
RUN_BANKS = [("ltc_terrains", "3 x 2, every row measured"), ("stc_slip16", "16 x 3, GPS one row in five")]
FORMS = [("per_step", "per-step matrix"), ("uniform_dwell", "equal dwell times"),
         ("per_mode_dwell", "per-mode dwell times")]

# Name parts Google Benchmark appends that are not part of what is measured.
_SUFFIX = re.compile(r"/(iterations:\d+|repeats:\d+|manual_time|real_time|min_time:[^/]+)")


def benchmark_key(name):
    return _SUFFIX.sub("", name)


def family(name):
    return benchmark_key(name).split("/")[0]


# ---------------------------------------------------------------- running

def machine(build):
    cpu = machine_info.cpu_model()
    cache = {}
    for line in (build / "CMakeCache.txt").read_text().splitlines():
        m = re.match(r"([A-Za-z_]+):[A-Z]+=(.*)", line)
        if m:
            cache[m.group(1)] = m.group(2)
    compiler = cache.get("CMAKE_CXX_COMPILER", "c++")
    version = subprocess.run([compiler, "--version"], capture_output=True, text=True).stdout.splitlines()
    build_type = cache.get("CMAKE_BUILD_TYPE", "")
    flags = " ".join(f for f in [cache.get("CMAKE_CXX_FLAGS", ""),
                                 cache.get("CMAKE_CXX_FLAGS_" + build_type.upper(), "")] if f)
    return {"cpu": cpu, "cores": os.cpu_count(), "compiler": version[0] if version else compiler,
            "build_type": build_type, "flags": flags.strip(),
            "unity_build": cache.get("CMAKE_UNITY_BUILD", "OFF").upper() in ("ON", "TRUE", "1", "YES")}


def run_benchmarks(binary, repetitions, benchmark_filter):
    with tempfile.TemporaryDirectory() as tmp:
        out = pathlib.Path(tmp) / "out.json"
        command = [str(binary), f"--benchmark_repetitions={repetitions}",
                   "--benchmark_enable_random_interleaving=true", "--benchmark_report_aggregates_only=true",
                   f"--benchmark_out={out}", "--benchmark_out_format=json"]
        if benchmark_filter:
            command.append(f"--benchmark_filter={benchmark_filter}")
        print("running:", " ".join(command), file=sys.stderr)
        subprocess.run(command, check=True)
        return json.loads(out.read_text())


# Keys of a Google Benchmark JSON entry that are not user counters.
_NOT_COUNTERS = {"name", "family_index", "per_family_instance_index", "run_name", "run_type", "repetitions",
                 "repetition_index", "threads", "aggregate_name", "aggregate_unit", "iterations", "real_time",
                 "cpu_time", "time_unit", "label", "error_occurred", "error_message"}
_UNIT = {"ns": 1e-9, "us": 1e-6, "ms": 1e-3, "s": 1.0}


def medians(report):
    """{key: {"real_s", "cpu_s", counters...}} from the median aggregates (single runs if not repeated)."""
    figures = {}
    for entry in report["benchmarks"]:
        key = benchmark_key(entry["run_name"])
        median = entry.get("run_type") == "aggregate" and entry.get("aggregate_name") == "median"
        single = entry.get("run_type") == "iteration"
        if entry.get("error_occurred"):
            figures[key] = {"error": entry.get("error_message", "")}
            continue
        if not (median or (single and key not in figures)):
            continue
        unit = _UNIT[entry["time_unit"]]
        figure = {"real_s": entry["real_time"] * unit, "cpu_s": entry["cpu_time"] * unit}
        for name, value in entry.items():
            if name not in _NOT_COUNTERS and isinstance(value, (int, float)):
                figure[name] = value
        figures[key] = figure
    return figures


def listed_benchmarks(binary):
    out = subprocess.run([str(binary), "--benchmark_list_tests=true"], capture_output=True, text=True, check=True)
    return sorted({benchmark_key(line.strip()) for line in out.stdout.splitlines() if line.strip()})


def measure(args):
    build = ROOT / args.build
    binary = build / "bin" / "skidimm_benchmarks"
    start_load = list(os.getloadavg())
    started = datetime.datetime.now(datetime.timezone.utc)
    report = run_benchmarks(binary, args.repetitions, args.filter)
    end_load = list(os.getloadavg())
    # The last commit that changed anything but what this script writes (and
    # the script itself): the code measured. A commit of this page alone,
    # rebased before it lands, would otherwise name a commit main never had.
    own = ["docs/performance.md", "docs/performance", "README.md", "scripts/performance_tables.py"]
    commit = subprocess.run(["git", "-C", str(ROOT), "log", "-1", "--format=%h", "--", "."] +
                            [f":(exclude){path}" for path in own], capture_output=True, text=True).stdout.strip()
    # Changes not committed, outside `own`: the figures are not that commit's.
    changed = subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain", "--untracked-files=no"],
                             capture_output=True, text=True).stdout.splitlines()
    if any(not line[3:].startswith(tuple(own)) for line in changed):
        commit += " with uncommitted changes"
    results = {
        "generated_by": "scripts/performance_tables.py",
        "date": started.strftime("%Y-%m-%d"),
        "commit": commit,
        "machine": machine(build),
        "load": {"start": [round(x, 2) for x in start_load], "end": [round(x, 2) for x in end_load]},
        "repetitions": args.repetitions,
        "rows": int(os.environ.get("SKIDIMM_BENCHMARK_ROWS", "1000000")),
        "families": sorted({family(name) for name in listed_benchmarks(binary)}),
        "benchmarks": medians(report),
    }
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps(results, indent=1, sort_keys=True) + "\n")


# ---------------------------------------------------------------- the page

def ratio(x):
    return f"{x:.2f}x"


def us(seconds):
    value = seconds * 1e6
    return f"{value:,.0f} us" if value >= 100 else f"{value:.2f} us"


def rate(rows_per_second):
    return f"{round(rows_per_second, -3):,.0f} rows/s"


def met(ok):
    return "**met**" if ok else "**not met**"


class Page:
    def __init__(self, results):
        self.r = results
        self.b = results["benchmarks"]
        self.targets = []  # (target, met?, result text)

    def get(self, key):
        figure = self.b.get(key)
        return figure if figure is not None and "error" not in figure else None

    def seconds(self, key):
        figure = self.get(key)
        if figure is None:
            return None
        # Run/ and RunFloor/ are timed by hand (CPU time of the child, of the thread).
        manual = key.startswith("Run/") or key.startswith("RunFloor/")
        return figure["real_s"] if manual else figure["cpu_s"]

    def header(self):
        r, m = self.r, self.r["machine"]
        load = r["load"]
        # Inlining across files differs between the two, and the ratios with it.
        unity = ("the library in unity batches as `scripts/test.sh` compiles it, not the default build"
                 if m.get("unity_build")
                 else "the library a translation unit per source file, as `scripts/build.sh` compiles it by default")
        return f"""# Performance

What one IMM step costs, how it grows with the bank, and how fast
`skidimm run` gets through a log; how to measure it yourself, and what the
engine does to get there without changing a result.

Every figure on this page is written by `scripts/performance_tables.py`
from one run of the benchmarks stored in
[`performance/results.json`](performance/results.json), and a test
(`Performance.PageIsWrittenFromTheStoredResults`) checks that the page is
exactly what the script writes from that file. Absolute times on a shared
machine are noise, so the figures that matter are **ratios taken in the same
run**: the engine's step against a hand-written IMM of the same
mathematics, `skidimm run` against its I/O floor, the `.npy` output against
CSV.

**This run:** {r["date"]}, commit `{r["commit"]}`; {m["cpu"]}, {m["cores"]} cores
shared with other work (load average {load["start"][0]:.2f} when the run started,
{load["end"][0]:.2f} when it ended); {m["compiler"]}, {m["build_type"]} build
(`{m["flags"] or "no extra flags"}`, {unity}); {r["repetitions"]} repetitions of each
benchmark in random interleaved order, medians; logs of {r["rows"]:,} rows.
"""

    def reproducing(self):
        return """## Reproducing the figures

```sh
./scripts/build.sh                          # Release, benchmarks included (SKIDIMM_BUILD_BENCHMARKS, on by default)
scripts/performance_tables.py               # runs every benchmark, stores the results, writes this page
build/bin/skidimm_benchmarks                # the same benchmarks with a summary on the console
build/bin/skidimm_benchmarks --benchmark_filter='Imm/|Reference/'   # only the step against the reference
SKIDIMM_BENCHMARK_ROWS=200000 build/bin/skidimm_benchmarks --benchmark_filter=Run   # shorter logs
```

`skidimm_benchmarks` alone runs every benchmark 5 times in random
interleaved order unless the command line sets `--benchmark_repetitions`,
and prints the same ratios at the end. The reference of `Imm/` is
`tests/core/reference_imm.h`: fixed Eigen sizes throughout, the model's
equations inlined, a hand-written 2x2/3x3 Cholesky, each target mixed
around its heaviest component as the textbook does, fed exactly the same
steps. It is also the oracle of `tests/core/imm_test.cc`, which requires the
engine to agree with it to 1e-10.

The benchmark sources are in `tests/benchmarks/`:

| benchmark | what |
|---|---|
| `Imm/<bank>`, `Reference/<bank>` | one step of the bundled banks `ltc_terrains` (3 modes x 2 states), `stc_slip4` (4 x 3), `stc_slip16` (16 x 3) and a 16 x 2 LTC bank, regular 50 Hz steps, every row measured |
| `Scaling/<form>/<ltc\\|stc>/<modes>` | 1 to 256 modes of 2-state LTC or 3-state STC models (the heading an angle), for a per-step matrix (`stay: 0.99`), equal dwell times and per-mode dwell times (5 to 20 s), at 100 Hz with dt jittered by +-10 %; counters: the heap the `Imm` takes and allocations per step |
| `Run/<bank>[/npy]` | the `skidimm` executable on a log of `SKIDIMM_BENCHMARK_ROWS` rows (default 1,000,000) made by repeating the bank's bundled example log (19 columns as the simulator writes them; for STC, GPS in one row of five); time is the child's CPU time (user + system), so rows/s is per core. `/npy` writes a NumPy array instead of CSV. `SKIDIMM_BENCHMARK_EXECUTABLE=<path>` times another build's `skidimm` |
| `RunFloor/<bank>[/npy]` | the I/O floor of `Run/`, timed the same way (CPU time): the same log read by the same reader (every column the bank reads, parsed) and the same bytes written by the same writer, from estimates computed beforehand; no filter, no decision, no summary |
| `RunLoop/<bank>` | the same loop in process (`write_estimates`, `log_run.h`) with heap allocations per row, counted from the 1024th row |
| `Jacobian/<model>/…`, `Prediction/<model>/…` | a plugin's state Jacobian (and Jacobian + process noise + prediction), generated by jets but for `ltc_linear`'s, against a hand-written analytic one, on the same points |
| `Likelihood/<model>/{nll,gradient,fit}` | fitting by likelihood over 10^4 rows simulated from the model (`ltc_linear`; `linear_features` with 6 states and 42 parameters, A diagonal or full): one NLL, the NLL with its gradient, a whole fit from 20 % off, in NLLs of the same run ([fitting.md](fitting.md)) |
| `bag_read/<storage>` | a ROS 2 bag read into the filter's steps against the same data from CSV, in the same iteration: a synthetic BorealTC-like drive of `SKIDIMM_BENCHMARK_BAG_SECONDS` (default 1800 s: IMU at 100 Hz, wheels at 6.5 Hz) through `LogReader` with `configs/borealtc/terrains.yaml` on the CSV pair and `terrains_ros2.yaml` on the bag (`mcap_zstd`, `mcap` uncompressed); it fails unless both give the same steps bit for bit ([ros2.md](ros2.md)) |
| `live_log/borealtc` | the same drive's rows pushed one message at a time, in time order, into a `LiveLog` with `configs/borealtc/terrains.yaml`, its steps taken after every push, against reading the CSV pair, in the same iteration; CPU time of the whole process (the `LiveLog`'s reader is a thread of its own); it fails unless both give the same steps bit for bit |
"""

    def imm_step(self):
        lines = ["### `Imm::step` against the hand-written fixed-size IMM", "",
                 "| bank | modes x states | `Imm::step` | reference | **ratio** | target |",
                 "|---|---|---|---|---|---|"]
        ratios = []
        for bank, size in BANKS:
            imm, ref = self.seconds("Imm/" + bank), self.seconds("Reference/" + bank)
            if imm is None or ref is None:
                lines.append(f"| `{bank}` | {size} | - | - | not measured | |")
                ratios.append(None)
                continue
            ratios.append(imm / ref)
            lines.append(f"| `{bank}` | {size} | {us(imm)} | {us(ref)} | **{ratio(imm / ref)}** | "
                         f"{'met' if imm / ref <= IMM_STEP_TARGET else 'not met'} |")
        measured = [x for x in ratios if x is not None]
        ok = bool(measured) and len(measured) == len(ratios) and max(measured) <= IMM_STEP_TARGET
        self.targets.append((f"`Imm::step` within {IMM_STEP_TARGET}x of the hand-written fixed-size IMM at every "
                             "size benchmarked", ok,
                             ", ".join(f"{size}: {ratio(x)}" if x is not None else f"{size}: not measured"
                                       for (_, size), x in zip(BANKS, ratios))))
        lines += ["", "From 16 modes on the engine mixes all targets in one product with the transition matrix "
                  "instead of N per-target passes with an angle wrap per pair, which is where it can beat the "
                  "reference; at 3 or 4 modes the fixed costs of a general engine (the virtual calls into the "
                  "plugin, the per-mode health checks) weigh most."]
        return "\n".join(lines) + "\n"

    def scaling(self):
        lines = ["### Share of one core at 100 Hz, every transition form", "",
                 "Time per step (dt jittered +-10 %) and the share of one core it takes at 100 Hz (a step every "
                 "10 ms); absolute times, on the machine and under the load stated above.", "",
                 "| states | modes | " + " | ".join(label for _, label in FORMS) + " | per-mode / equal dwell |",
                 "|---|---|" + "---|" * len(FORMS) + "---|"]
        worst_share = {}
        dwell_ratio = {}
        for states, label in [("ltc", "2 (LTC)"), ("stc", "3 (STC)")]:
            for modes in [1, 4, 16, 64, 256]:
                cells = []
                for form, _ in FORMS:
                    t = self.seconds(f"Scaling/{form}/{states}/{modes}")
                    if t is None:
                        cells.append("-")
                        continue
                    share = t / 0.01 * 100.0
                    cells.append(f"{us(t)} ({share:.2f} %)" if modes == 256 else us(t))
                    if modes == 256:
                        worst_share[(states, form)] = share
                uniform = self.seconds(f"Scaling/uniform_dwell/{states}/{modes}")
                per_mode = self.seconds(f"Scaling/per_mode_dwell/{states}/{modes}")
                dwell = per_mode / uniform if uniform and per_mode else None
                if modes >= 4 and dwell is not None:
                    dwell_ratio[(states, modes)] = dwell
                if all(c == "-" for c in cells):
                    continue
                lines.append(f"| {label} | {modes} | " + " | ".join(cells) + f" | {ratio(dwell) if dwell else '-'} |")
        allocations = [f.get("allocs_per_step") for k, f in self.b.items()
                       if k.startswith("Scaling/") and "error" not in f]
        allocations = [a for a in allocations if a is not None]
        if allocations:
            lines += ["", "Heap allocations per step (`allocs_per_step`, counted over the whole timed loop, the "
                      f"benchmark library's own bookkeeping included): at most {max(allocations):.3f}. "
                      "`tests/core/imm_allocation_test.cc` pins the step itself to none."]
        if worst_share:
            shares = ", ".join(f"{s.upper()} {label}: {worst_share[(s, f)]:.2f} %"
                               for s in ("ltc", "stc") for f, label in FORMS if (s, f) in worst_share)
            self.targets.append((f"256 modes at 100 Hz under {CORE_SHARE_TARGET:g} % of a core, every transition "
                                 "form", max(worst_share.values()) < CORE_SHARE_TARGET, shares))
        if dwell_ratio:
            # The worst bank size of each state count (1 mode has no transition to pay for).
            worst = {}
            for (states, modes), x in dwell_ratio.items():
                if states not in worst or x > worst[states][1]:
                    worst[states] = (modes, x)
            self.targets.append((f"per-mode dwell times within {PER_MODE_DWELL_TARGET}x of equal dwell times at "
                                 "every bank size from 4 to 256 modes",
                                 max(dwell_ratio.values()) <= PER_MODE_DWELL_TARGET,
                                 ", ".join(f"{s.upper()} at worst {ratio(x)} ({m} modes)"
                                           for s, (m, x) in worst.items())))
        return "\n".join(lines) + "\n"

    def runs(self):
        lines = ["### `skidimm run`, end to end, one core", "",
                 "Rows per second of CPU time (user + system); the floor reads the same log with the same reader "
                 "and writes the same bytes with the same writer, and nothing else.", "",
                 "| bank | output | `skidimm run` | its I/O floor | **run / floor** | output size | "
                 "**CSV time / `.npy` time** |",
                 "|---|---|---|---|---|---|---|"]
        floor_ratios, speedups = {}, {}
        for bank, description in RUN_BANKS:
            csv_time = self.seconds(f"Run/{bank}")
            for suffix, output in [("", "CSV"), ("/npy", "`.npy`")]:
                run, floor = self.seconds(f"Run/{bank}{suffix}"), self.seconds(f"RunFloor/{bank}{suffix}")
                if run is None:
                    continue
                rows = self.get(f"Run/{bank}{suffix}").get("rows", 0)
                size = self.get(f"Run/{bank}{suffix}").get("output_bytes")
                cells = [rate(rows / run),
                         rate(rows / floor) if floor else "-",
                         f"**{ratio(run / floor)}**" if floor else "-",
                         f"{size / rows:.0f} bytes/row" if size and rows else "-",
                         "-"]
                if floor:
                    floor_ratios[(bank, output)] = run / floor
                if suffix and csv_time:
                    speedups[bank] = csv_time / run
                    cells[4] = f"**{ratio(csv_time / run)}**"
                lines.append(f"| `{bank}` ({description}) | {output} | " + " | ".join(cells) + " |")
        allocation_lines = []
        for bank, _ in RUN_BANKS:
            loop = self.get(f"RunLoop/{bank}")
            if loop is not None and "allocs_per_row" in loop:
                allocation_lines.append(f"`{bank}` {loop['allocs_per_row']:.1e}")
        if allocation_lines:
            lines += ["", "Heap allocations per row of the run loop (`RunLoop/`, from the 1024th row): " +
                      ", ".join(allocation_lines) + ". What remains over a whole log is the run summary's "
                      "timeline growing by doubling when the most likely mode changes (O(log rows)) and the "
                      "first copy of each truth label; `ImmAllocation.TheRunLoopAllocatesNothingPerRow` pins it."]
        why = []
        for bank, _ in RUN_BANKS:
            run, floor, step = (self.seconds(f"Run/{bank}"), self.seconds(f"RunFloor/{bank}"),
                                self.seconds(f"Imm/{bank}"))
            if run and floor and step:
                rows = self.get(f"Run/{bank}")["rows"]
                why.append(f"`{bank}` {(run - floor) / rows * 1e6:.2f} us per row on top of the floor's "
                           f"{floor / rows * 1e6:.2f} us, where `Imm::step` alone takes {step * 1e6:.2f} us "
                           "(`Imm/` above)")
        if why:
            lines += ["", "What the run adds to its floor is the estimator: " + "; ".join(why) + ". The rest goes to "
                      "the decision, the run summary and handing each row from the reader to the filter and the "
                      "writer. Making reading and writing faster makes the run faster but "
                      "this ratio larger; the ratio falls only with the step, and reaching 1.5x would need the step "
                      "to cost at most half of what reading and writing cost. For the same reason the `.npy` output "
                      "(no number text) cannot be twice as fast as CSV while the step takes more than half of the "
                      "CSV run."]
        csv_floor = {b: x for (b, o), x in floor_ratios.items() if o == "CSV"}
        if csv_floor:
            self.targets.append((f"`skidimm run` (CSV) within {RUN_FLOOR_TARGET}x of its I/O floor",
                                 max(csv_floor.values()) <= RUN_FLOOR_TARGET,
                                 ", ".join(f"`{b}` {ratio(x)}" for b, x in csv_floor.items())))
        if speedups:
            self.targets.append((f"`.npy` output at least {NPY_SPEEDUP_TARGET:g}x faster than CSV",
                                 min(speedups.values()) >= NPY_SPEEDUP_TARGET,
                                 ", ".join(f"`{b}` {ratio(x)}" for b, x in speedups.items())))
        return "\n".join(lines) + "\n"

    def jacobians(self):
        rows = []
        for model in ["ltc_linear", "stc_kinematic", "stc_sided", "stc_traction"]:
            for what, label in [("Jacobian", "`jacobian()`"), ("Prediction", "jacobian + process noise + predict")]:
                generated = self.seconds(f"{what}/{model}/generated")
                analytic = self.seconds(f"{what}/{model}/analytic")
                if generated and analytic:
                    rows.append(f"| `{model}` | {label} | {generated * 1e9:.1f} ns | {analytic * 1e9:.1f} ns | "
                                f"{ratio(generated / analytic)} |")
        if not rows:
            return ""
        return "\n".join(["### State Jacobians of the plugins against hand-written ones", "",
                          "| model | what | the plugin's | hand-written | ratio |", "|---|---|---|---|---|"] + rows +
                         ["", "The plugins' Jacobians are generated by jets, except `ltc_linear`'s: its model "
                          "writes F = I + A dt itself, summed as the jets sum it (bit for bit, "
                          "`LtcJacobian.IsTheJetsJacobianBitForBit`), so its rows compare two hand-written "
                          "Jacobians."]) + "\n"

    def likelihood(self):
        rows = []
        for model in ["ltc_linear", "six_diagonal_a", "six_full_a"]:
            nll = self.seconds(f"Likelihood/{model}/nll")
            gradient = self.seconds(f"Likelihood/{model}/gradient")
            fit_key = f"Likelihood/{model}/fit"
            fit = self.seconds(fit_key)
            if not nll or not gradient:
                continue
            iterations = self.get(fit_key).get("lbfgs_iterations") if fit else None
            rows.append(f"| `{model}` | {ratio(gradient / nll)} | " +
                        (f"{fit / nll:.1f} NLLs | {iterations:.0f} |" if fit else "- | - |"))
        if not rows:
            return ""
        return "\n".join(["### Fitting by likelihood", "",
                          "Over 10^4 rows: the NLL with its gradient, and a whole fit from 20 % off, in NLLs of "
                          "the same run ([fitting.md](fitting.md)).", "",
                          "| model | NLL + gradient / NLL | whole fit | L-BFGS iterations |",
                          "|---|---|---|---|"] + rows) + "\n"

    def bags(self):
        rows = []
        for key, figure in sorted(self.b.items()):
            if key.startswith("bag_read/") and "error" not in figure and "bag_over_csv" in figure:
                rows.append(f"| `{key.split('/', 1)[1]}` | {ratio(figure['bag_over_csv'])} |")
        if not rows:
            return ""
        return "\n".join(["### ROS 2 bags against CSV", "",
                          "CPU time to read the same steps from a bag over reading them from the CSV pair, same "
                          "iteration (below 1: the bag is faster).", "",
                          "| storage | bag / CSV |", "|---|---|"] + rows) + "\n"

    def live_log(self):
        figure = self.get("live_log/borealtc")
        if figure is None or "error" in figure or "live_over_csv" not in figure:
            return ""
        return "\n".join([
            "### A robot's messages through `LiveLog` against CSV", "",
            "The same drive's steps from its messages pushed one at a time into a `LiveLog` (its steps taken after "
            "every push, as a node's callbacks would) over reading them from the CSV pair, CPU time of the whole "
            "process, same iteration ([python.md](python.md#in-a-robots-loop)).", "",
            "| drive | LiveLog / CSV | CPU per message pushed |", "|---|---|---|",
            f"| BorealTC-like (IMU 100 Hz, wheels 6.5 Hz), {figure['steps']:,.0f} steps | "
            f"{ratio(figure['live_over_csv'])} | {figure['us_per_row']:.2f} us |"]) + "\n"

    def errors(self):
        failed = [f"`{k}`: {f['error']}" for k, f in sorted(self.b.items()) if "error" in f]
        if not failed:
            return ""
        return "### Benchmarks that failed in this run\n\n" + "\n".join(f"- {x}" for x in failed) + "\n"

    def target_table(self):
        lines = ["## Speed targets", "", "| target | | this run |", "|---|---|---|"]
        for target, ok, result in self.targets:
            lines.append(f"| {target} | {met(ok)} | {result} |")
        loops = [(b, self.get(f"RunLoop/{b}")) for b, _ in RUN_BANKS]
        loops = [(b, f["allocs_per_row"]) for b, f in loops if f is not None and "allocs_per_row" in f]
        if loops:
            lines.append(f"| no heap allocation per row in the run loop (read, step, write): fewer than one per "
                         f"{ALLOCATION_ROWS:,} rows, from the timeline's amortised growth | " +
                         met(max(a for _, a in loops) < 1.0 / ALLOCATION_ROWS) + " | " +
                         ", ".join(f"`{b}` {a:.1e} per row" for b, a in loops) + " |")
        return "\n".join(lines) + "\n"

    def readme(self):
        """The README's summary, between its <!-- performance:summary --> and <!-- end --> lines."""
        m = self.r["machine"]
        steps = []
        for bank, size in BANKS:
            imm, ref = self.seconds("Imm/" + bank), self.seconds("Reference/" + bank)
            if imm and ref:
                steps.append(f"{ratio(imm / ref)} for `{bank}` ({size})")
        lines = [f"Measured on {m['cpu']} ({m['cores']} cores shared with other work; the machine, its load and "
                 "every figure are in [docs/performance.md](docs/performance.md), which says how to measure them "
                 "yourself):", ""]
        if steps:
            lines.append("- `Imm::step` takes " + ", ".join(steps) + " the time of a hand-written fixed-size IMM "
                         "of the same mathematics, timed in the same run.")
        shares = [self.seconds(f"Scaling/{form}/{states}/256") for form, _ in FORMS for states in ("ltc", "stc")]
        shares = [t / 0.01 * 100.0 for t in shares if t]
        if shares:
            lines.append(f"- 256 modes at 100 Hz take at most {max(shares):.1f} % of one core, whatever the "
                         "transition (a per-step matrix, equal or per-mode dwell times); the step grows as N² and "
                         "never allocates.")
        runs = []
        for bank, _ in RUN_BANKS:
            run, floor, npy = (self.seconds(f"Run/{bank}"), self.seconds(f"RunFloor/{bank}"),
                               self.seconds(f"Run/{bank}/npy"))
            if run and floor and npy:
                rows = self.get(f"Run/{bank}")["rows"]
                runs.append(f"`{bank}`: {rate(rows / run)} to CSV, {ratio(run / floor)} the time of reading "
                            f"the log and writing the same file alone; {rate(rows / npy)} with "
                            "`--output estimates.npy`")
        if runs:
            lines.append("- `skidimm run` on one core, " + "; ".join(runs) + ". `eval` and `fit` spread their "
                         "logs over every core (`SKIDIMM_THREADS` sets how many).")
        return "\n".join(lines) + "\n"

    def render(self):
        sections = [self.header(), self.reproducing(), "## The figures\n", self.imm_step(), self.scaling(),
                    self.runs(), self.jacobians(), self.likelihood(), self.bags(), self.live_log(), self.errors()]
        return "\n".join(s for s in sections if s) + "\n" + self.target_table() + "\n" + ENGINE


ENGINE = """## What the engine does

**Fixed-size kernels.** `Imm` picks, once when it is built, a kernel for the
bank's shape (`core/src/imm_kernel.h`): Eigen fixed-size types for states and
measurements of 1 to 4 components; fixed-size states with any number of
rows up to 12 states (BorealTC's 9 features, `stc_traction`'s 3 states and 6
rows); the dynamic `ExtendedKalmanFilter` for everything else. Each shape is
a compiled copy of the step: a build configured with
`-DSKIDIMM_FIXED_SIZE_KERNELS=bundled` compiles only the bundled banks'
shapes (the sanitizer build does, to compile the engine in a third of the
time), and runs other banks on the dynamic kernel. Partial rows (GPS at 10 Hz in a
50 Hz log) dispatch to a fixed size K for the rows present. The EKF update
uses a hand-written Cholesky for K <= 4 (Eigen's `LLT::solve` goes through its
general triangular solver and packing), forward substitution alone for the
NIS, and one logarithm for log det S; where H is the identity (every state
measured directly, as in the bundled LTC and STC banks) its products with H
are copies and I - K H is I - K, the same numbers to the bit. The kernel of fixed-size states with
any rows updates the covariance as P- - W W' through the half gain
W = P- H' L'^-1 (its lower triangle, about N^2 k / 2 products, where the
Joseph form takes 2 N^3; when every row is measured, k = N, over matrices
of fixed size on the stack with the triangular loops of S's factor and
solves unrolled whole, the same operations in the same order), and
takes the Joseph form where that would cancel
more than half of a variance's digits ([engine.md](engine.md)). The model is still called through the
plugin interface: three virtual calls per mode and step (Jacobian, process
noise, prediction, given one view of the state), or only the prediction for
a model whose Jacobian and process noise depend on dt alone (`ltc_linear`,
`linear_features`: the kernel keeps each mode's F and Qd while dt repeats,
with the same results to the bit); the `SizedMotionModel` trampolines pass arguments through
fixed-size maps (a copy of the n + m doubles the fixed-size signature takes by
value; removing that would change the plugin authoring API). `stc_kinematic`
computes sin and cos of the heading once for the Jacobian and the prediction
of a step (a per-thread cache of a pure function, so models stay shareable
between threads).

**Mixing in one product.** About one common reference (the most probable
mode's state, angles wrapped), the mixed mean and covariance of every target
follow from first and second moments, so `P(dt)' * Y` with
`Y(i, :) = mu_i [1, y_i', vech(P_i + y_i y_i')']` mixes all targets at once
(`gaussian_mixture.h`). This is the per-target form of eq. 6-7 exactly
whenever the modes' headings lie within a half circle of the reference (they
differ otherwise only in which way a wrap goes); in floating point the two
differ by about eps |y|^2 / |P0| relative.

**Transitions in O(N^2).** `ModeTransition::propagate` applies `P(dt)'`
without forming `P(dt)`: the given matrix for per-step transitions; the
closed form for equal dwell times; for per-mode dwell times, the generator is
diagonal plus rank one (`Pi_c = a r 1' - D`), so a product with it costs
O(N C). From 8 modes on, a short step (`2 max r dt <= 0.01`: 10 ms against
dwell times of 2 s or more) applies the Taylor series of `expm(Pi_c dt)'` to the moments
directly, a few O(N C) products one column at a time and no N x N product,
so it costs about what equal dwell times cost. For longer steps,
`P(dt_a)` is computed once per anchor by uniformisation (each term a
structured product, O(N^2)), and every later step reuses it:
`P(dt) = P(dt_a) expm(Pi_c (dt - dt_a))`, the second factor the same
short Taylor series, applied to the moments' C columns or, when there are
fewer modes than columns (4 STC modes carry 10 moments each), to the N
columns of `P(dt)'` before the product. From 16 modes on, the dense product loads each column of `P` once
for four columns of the moments, each entry summed exactly as Eigen's dot
product sums it (`ModeTransition.ManyModesPropagateIsEigensDotProductBitForBit`).
A few anchors serve logs that alternate between rates; gaps much
longer than the fastest mode's dwell time use the eigenvectors of the
symmetric matrix similar to `Pi_c`, computed once at construction, with the
stationary direction set exactly.

**Smoothing on fixed sizes.** Kim's smoother (`eval --smooth`, `run
--smooth`) runs one Rauch-Tung-Striebel step per pair of modes and step,
N^2 of them (256 for the 16-mode STC banks), each with a prediction, an
LDLT solve and products of n x n matrices. For 2 and 3 states (the LTC
and STC banks) the pair step runs on fixed-size matrices on the stack;
other sizes on the smoother's dynamic workspace. The smoothed mode
probabilities are bit for bit those of the dynamic path, the smoothed
states agree to round-off.

**Ties stay ties.** Before the first measurement every mode has its prior
probability, and which one is "most likely" is decided by the last bit of
c = P' mu. For per-step matrices and equal dwell times the engine still
computes c with the same dense product as before, so published results
(`docs/results.md`) are reproduced exactly, ties included
(`Imm.PredictedProbabilitiesAreTheDenseProductBitForBit`). It sums each
entry in the order Eigen's matrix-vector kernel does, in a loop of its own
(`core/src/transposed_product.h`, pinned to Eigen's product bit for bit by
`TransposedProduct.IsEigensMatrixVectorProductBitForBit`): at 3 or 4 modes
the product's dispatch cost more than its arithmetic. Likewise the closed
form for equal dwell times sums each column of the moments as Eigen's
`sum()` does, alignment included
(`ModeTransition.EqualDwellTimesPropagateIsTheClosedFormWithEigensSumBitForBit`).

**The run loop.** `CsvReader::next_row()` splits rows in place in a block
read at once (eight bytes at a time), quoted rows take the original
character-by-character path; numbers are parsed by Clinger's exact fast path
for plain decimals (`std::from_chars` otherwise) and written by Ryu's
shortest digits (`std::to_chars` otherwise), `core/src/number_text.h`.
`CsvWriter` formats into its own buffer and hands it to the file in blocks;
`EstimatesWriter` writes the same bytes as before, or, for an output path
ending in `.npy`, a NumPy record array with the doubles themselves and each
row's reason as a 4-byte code into a table of texts written beside it
(`out.reasons.json`, [cli.md](cli.md#skidimm-run)). `write_estimates`
(`log_run.h`) is the loop `skidimm run` runs.

**Robustness checks.** Every step also checks each mode filter for
divergence (`core/src/filter_health.h`: 3 n comparisons and one sum over the
n^2 covariance entries without a branch per entry), compares each
NIS with the innovation gate (one comparison; the chi-square quantiles are
computed once per bank), applies the exact probability floor (one pass over
the modes, a second only when the floor bites) and checks the combined
estimate (docs/engine.md). None allocates.

**Threads.** `eval` and `fit` read and score their logs on every core
(`core/src/parallel.h`); `SKIDIMM_THREADS=1` runs them on one, with identical
results (`Threads.*` in `skidimm_performance_tests`). `fit`'s optimisation
itself (`fitting::fit_bank`) is one thread.

## What may differ, and what pins it

The engine's speed work changed results only by round-off:

- the IMM's probabilities, states and covariances: relative differences
  below 5e-13 on the bundled banks' example logs; the most likely mode and
  every published table are identical (`PaperResults.AreReproducedByTheirScript`,
  `BundledBanks.AreReproducedByTheirFittingScript`);
- the per-mode dwell-time transition matrix: pinned to the original
  uniformisation to 1e-12, and closer than it to the exact exponential for
  long gaps.

Tests that pin results: `Imm.MatchesIndependentScalarImplementationOverManySteps`
(1e-10), `Imm.TwoStatesMatchAHandWrittenFixedSizeImmForEveryTransitionForm`
and `Imm.ThreeStatesWithAnAngleMatchAHandWrittenFixedSizeImmForEveryTransitionForm`
(1e-10, both kernels, headings across +-pi, partial rows),
`Imm.FixedSizeKernelsAgreeWithTheDynamicOneAtEverySize`,
`FixedSizeFilter.*` (the fixed-size EKF against `ExtendedKalmanFilter`),
`ModeTransition.*`, and in `skidimm_performance_tests` the reader, the writer's
bytes and the number text against what they replaced
(`CsvReader.ReadsEveryRowLikeTheOriginalReader`,
`EstimatesWriter.CsvIsByteForByteTheOriginalFormat`, `NumberText.*`), and the
`.npy` output read by NumPy against the CSV (`NpyOutput.NumpyReadsWhatTheCsvHolds`).

The Python package's routes (a model written in Python, `Imm.run` over
NumPy arrays) against the C++ loop are measured by `scripts/python_benchmark.py`,
which stores its own run and writes [python.md](python.md#speed)'s table.

FilterPy's `IMMEstimator` is not measured here: FilterPy is not packaged for
Debian, so it is not among the project's dependencies.
"""


def render(results):
    return Page(results).render()


README = ROOT / "README.md"
README_BLOCK = re.compile(r"(<!-- performance:summary -->\n)(.*?)(<!-- end -->)", re.DOTALL)


def render_readme(results, readme_text):
    """README.md with its performance summary written from `results`."""
    if not README_BLOCK.search(readme_text):
        raise SystemExit("README.md has no <!-- performance:summary --> ... <!-- end --> block")
    summary = Page(results).readme()
    return README_BLOCK.sub(lambda m: m.group(1) + summary + m.group(3), readme_text, count=1)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--build", default="build", help="the build tree, relative to the repository (build)")
    parser.add_argument("--repetitions", type=int, default=5)
    parser.add_argument("--filter", default="", help="--benchmark_filter, for trying the script out")
    parser.add_argument("--render", action="store_true", help="write the page from the stored results only")
    parser.add_argument("--check", metavar="BENCHMARKS",
                        help="compare the page with what the stored results give, and check that they cover every "
                             "family the benchmark binary lists; exit 1 if not")
    args = parser.parse_args()
    if args.check:
        results = json.loads(RESULTS.read_text())
        failures = []
        if PAGE.read_text() != render(results):
            failures.append(f"{PAGE.relative_to(ROOT)} is not what {RESULTS.relative_to(ROOT)} gives: run "
                            "scripts/performance_tables.py --render (or without --render to measure again)")
        readme = README.read_text()
        if readme != render_readme(results, readme):
            failures.append("README.md's performance summary is not what the stored results give: run "
                            "scripts/performance_tables.py --render")
        measured = {family(key) for key in results["benchmarks"]}
        listed = {family(name) for name in listed_benchmarks(args.check)}
        if listed - measured:
            failures.append("benchmark families the binary lists but the stored results lack: " +
                            ", ".join(sorted(listed - measured)) + " (run scripts/performance_tables.py)")
        for failure in failures:
            print("FAIL:", failure)
        return 1 if failures else 0
    if not args.render:
        measure(args)
    results = json.loads(RESULTS.read_text())
    PAGE.write_text(render(results))
    README.write_text(render_readme(results, README.read_text()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
