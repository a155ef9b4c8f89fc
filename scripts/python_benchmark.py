#!/usr/bin/env python3
"""Times skidimm's Python routes against the C++ loop (docs/python.md, "Speed").

  PYTHONPATH=build/lib/python3.11/dist-packages /usr/bin/python3 scripts/python_benchmark.py [--rows N] [--json]
  ... scripts/python_benchmark.py --store    # run, store docs/python/benchmark.json, write the page's table
  ... scripts/python_benchmark.py --render   # write the page's table from the stored run alone
  ... scripts/python_benchmark.py --check    # the page's table is what the stored run gives (the test; no timing)

1. Imm.run over N rows (default 1,000,000: the example log tiled) against
   the bare C++ loop of Imm::step over the same arrays, in the same module
   (Imm._step_loop: no outputs, no decisions). The ratio run / loop is the
   figure of merit.
2. The cost of a Python motion model: the same bank with its three
   ltc_linear modes as a Python class (python/tests/ltc_python.py), per step
   and per model call, against the compiled plugin.

Each comparison runs its two sides one after the other, --repeat times, in
this one process, timed in CPU seconds of the process; each pair gives a
ratio, and the medians are reported (on a shared, loaded machine a ratio
taken in one pair is steadier than either time). Nothing is asserted:
timings are machine facts.

--json prints one JSON object instead of text (for scripts that write docs):
  {"bank": str, "modes": int, "repeat": int,
   "imm_run": {"rows": int, "loop_seconds": float, "run_seconds": float,
               "ratio": float, "ratios": [float, ...]},
   "python_model": {"rows": int, "compiled_us_per_step": float,
                    "python_us_per_step": float, "us_per_call": float,
                    "ratio": float, "ratios": [float, ...]},
   "machine": {"cpu": str, "cores": int, "python": str, "numpy": str},
   "load": [float, float]}
Seconds (CPU) and microseconds are the medians of the --repeat runs of each
side; "ratio" is the median of the per-pair ratios listed in "ratios" (in
run order); "load" is the 1-minute load average when the run started and
when it ended. --store keeps that object in docs/python/benchmark.json.
"""

import argparse
import json
import os
import pathlib
import platform
import re
import statistics
import sys
import tempfile
import time

import machine_info

ROOT = pathlib.Path(__file__).resolve().parents[1]
STORED = ROOT / "docs" / "python" / "benchmark.json"
PAGE = ROOT / "docs" / "python.md"
BLOCK = re.compile(r"(<!-- python_benchmark -->\n).*?(<!-- end -->)", re.S)


def seconds(function):
    """CPU seconds of this process (page faults' kernel time included): on a shared machine, unlike wall time,
    they do not count the time other processes held the cores."""
    start = time.process_time()
    function()
    return time.process_time() - start


def paired(reference, measured, repeat):
    """Medians of `repeat` interleaved timings of both, and the ratios measured / reference."""
    references, measures, ratios = [], [], []
    for _ in range(repeat):
        references.append(seconds(reference))
        measures.append(seconds(measured))
        ratios.append(measures[-1] / references[-1])
    return statistics.median(references), statistics.median(measures), statistics.median(ratios), ratios


def machine():
    import numpy as np

    cpu = machine_info.cpu_model()
    return {"cpu": cpu, "cores": os.cpu_count(), "python": platform.python_version(), "numpy": np.__version__}


def measure(rows, python_rows, repeat):
    import numpy as np

    import skidimm

    sys.path.insert(0, str(ROOT / "python" / "tests"))
    from ltc_python import PythonLtc

    load_start = os.getloadavg()[0]
    bank = skidimm.Bank(ROOT / "configs" / "ltc_terrains.yaml")
    log = skidimm.read_csv(ROOT / "configs" / "examples" / "ltc_switching.csv")
    period = log["t"][-1] + 0.02
    copies = -(-rows // len(log["t"]))
    t = np.concatenate([log["t"] + period * k for k in range(copies)])[:rows]
    u = np.tile(np.column_stack([log[c] for c in bank.inputs]), (copies, 1))[:rows]
    z = np.tile(np.column_stack([log[c] for c in bank.measurements]), (copies, 1))[:rows]

    imm = skidimm.Imm(bank)
    loop, run, run_ratio, run_ratios = paired(lambda: imm._step_loop(t, u, z), lambda: imm.run(t, u, z), repeat)

    n = min(python_rows, rows)
    text = (ROOT / "configs" / "ltc_terrains.yaml").read_text().replace("model: ltc_linear", "model: py_ltc")
    with tempfile.TemporaryDirectory(prefix="skidimm_benchmark_") as directory:
        bank_file = pathlib.Path(directory) / "python_bank.yaml"
        bank_file.write_text(text)
        python = skidimm.Imm(skidimm.Bank(bank_file, models={"py_ltc": PythonLtc}))
    compiled = skidimm.Imm(bank)
    fast, slow, model_ratio, model_ratios = paired(lambda: compiled.run(t[:n], u[:n], z[:n]),
                                                   lambda: python.run(t[:n], u[:n], z[:n]), repeat)
    calls = 2 * len(bank.modes)  # predict and jacobian per mode per step
    return {
        "bank": bank.name,
        "modes": len(bank.modes),
        "repeat": repeat,
        "imm_run": {"rows": rows, "loop_seconds": loop, "run_seconds": run, "ratio": run_ratio, "ratios": run_ratios},
        "python_model": {"rows": n, "compiled_us_per_step": 1e6 * fast / n, "python_us_per_step": 1e6 * slow / n,
                         "us_per_call": 1e6 * (slow - fast) / (n * calls), "ratio": model_ratio,
                         "ratios": model_ratios},
        "machine": machine(),
        "load": [load_start, os.getloadavg()[0]],
    }


def text(result):
    r, p = result["imm_run"], result["python_model"]
    rows = r["rows"]
    return "\n".join([
        f"bank {result['bank']} ({result['modes']} modes); medians of {result['repeat']} interleaved runs",
        f"Imm.run against the C++ loop, {rows} rows",
        f"  C++ loop of Imm::step       {r['loop_seconds']:.3f} s  ({1e6 * r['loop_seconds'] / rows:.3f} us/row)",
        f"  Imm.run from Python         {r['run_seconds']:.3f} s  ({1e6 * r['run_seconds'] / rows:.3f} us/row)",
        f"  ratio run / C++ loop        {r['ratio']:.3f}  (pairs: {' '.join(f'{x:.2f}' for x in r['ratios'])})",
        f"Python motion models, {p['rows']} rows",
        f"  compiled ltc_linear         {p['compiled_us_per_step']:.2f} us/step",
        f"  Python PythonLtc            {p['python_us_per_step']:.2f} us/step "
        f"({p['us_per_call']:.2f} us per predict or jacobian call, {p['ratio']:.0f}x)",
    ])


def table(result):
    """docs/python.md's block: the stored run's figures."""
    r, p, m = result["imm_run"], result["python_model"], result["machine"]
    return "\n".join([
        f"| {result['bank']} ({result['modes']} modes), medians of {result['repeat']} interleaved pairs | |",
        "|---|---|",
        f"| bare C++ loop of `Imm::step`, {r['rows']} rows | {r['loop_seconds']:.3f} s |",
        f"| `imm.run` over the same arrays, into its columns | {r['run_seconds']:.3f} s |",
        f"| **`imm.run` / C++ loop** | **{r['ratio']:.2f}** (pairs: {', '.join(f'{x:.2f}' for x in r['ratios'])}) |",
        f"| compiled `ltc_linear`, per step ({p['rows']} rows) | {p['compiled_us_per_step']:.2f} us |",
        f"| `PythonLtc` (Python), per step | {p['python_us_per_step']:.2f} us ({p['ratio']:.0f} times) |",
        f"| per `predict` or `jacobian` call into Python | {p['us_per_call']:.2f} us |",
        "",
        f"CPU seconds of one process on {m['cpu']} ({m['cores']} cores, shared), 1-minute load average "
        f"{result['load'][0]:.1f} when the run started and {result['load'][1]:.1f} when it ended; "
        f"Python {m['python']}, NumPy {m['numpy']}.",
        "",
    ])


def page_with(result):
    page = PAGE.read_text()
    if not BLOCK.search(page):
        sys.exit(f"{PAGE}: no <!-- python_benchmark --> ... <!-- end --> block")
    return BLOCK.sub(lambda m: m.group(1) + table(result) + m.group(2), page)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--rows", type=int, default=1_000_000)
    parser.add_argument("--python-rows", type=int, default=20_000)
    parser.add_argument("--repeat", type=int, default=9)
    parser.add_argument("--json", action="store_true", help="print the results as one JSON object (format above)")
    parser.add_argument("--store", action="store_true",
                        help=f"store the results in {STORED.relative_to(ROOT)} and write the page's table")
    parser.add_argument("--render", action="store_true",
                        help=f"write the page's table from {STORED.relative_to(ROOT)} alone (no run)")
    parser.add_argument("--check", action="store_true",
                        help=f"exit 1 unless {PAGE.relative_to(ROOT)}'s table is what the stored results give")
    args = parser.parse_args()
    if args.rows < 1 or args.python_rows < 1 or args.repeat < 1:
        parser.error("--rows, --python-rows and --repeat must be at least 1")

    if args.render:
        PAGE.write_text(page_with(json.loads(STORED.read_text())))
        return
    if args.check:
        expected = page_with(json.loads(STORED.read_text()))
        if expected != PAGE.read_text():
            sys.exit(f"{PAGE.relative_to(ROOT)}: the <!-- python_benchmark --> block is not what "
                     f"{STORED.relative_to(ROOT)} gives; run scripts/python_benchmark.py --store (or write the "
                     "block from the stored run)")
        return
    result = measure(args.rows, args.python_rows, args.repeat)
    if args.store:
        STORED.parent.mkdir(parents=True, exist_ok=True)
        STORED.write_text(json.dumps(result, indent=2) + "\n")
        PAGE.write_text(page_with(result))
    print(json.dumps(result, indent=2) if args.json else text(result))


if __name__ == "__main__":
    main()
