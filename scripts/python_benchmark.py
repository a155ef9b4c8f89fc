#!/usr/bin/env python3
"""Times skidimm's Python routes against the C++ loop (docs/python.md, "Speed").

  PYTHONPATH=build/lib/python3.11/dist-packages /usr/bin/python3 scripts/python_benchmark.py [--rows N] [--json]

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
taken in one pair is steadier than either time). Nothing is asserted: timings are machine facts.

--json prints one JSON object instead of text (for scripts that write docs):
  {"bank": str, "modes": int, "repeat": int,
   "imm_run": {"rows": int, "loop_seconds": float, "run_seconds": float,
               "ratio": float, "ratios": [float, ...]},
   "python_model": {"rows": int, "compiled_us_per_step": float,
                    "python_us_per_step": float, "us_per_call": float,
                    "ratio": float, "ratios": [float, ...]}}
Seconds (CPU) and microseconds are the medians of the --repeat runs of each side;
"ratio" is the median of the per-pair ratios listed in "ratios" (in run order).
"""

import argparse
import json
import pathlib
import statistics
import sys
import tempfile
import time

import numpy as np

import skidimm

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "python" / "tests"))
from ltc_python import PythonLtc  # noqa: E402


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


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--rows", type=int, default=1_000_000)
    parser.add_argument("--python-rows", type=int, default=20_000)
    parser.add_argument("--repeat", type=int, default=9)
    parser.add_argument("--json", action="store_true", help="print the results as one JSON object (format above)")
    args = parser.parse_args()
    if args.rows < 1 or args.python_rows < 1 or args.repeat < 1:
        parser.error("--rows, --python-rows and --repeat must be at least 1")

    bank = skidimm.Bank(ROOT / "configs" / "ltc_terrains.yaml")
    log = skidimm.read_csv(ROOT / "configs" / "examples" / "ltc_switching.csv")
    period = log["t"][-1] + 0.02
    copies = -(-args.rows // len(log["t"]))
    t = np.concatenate([log["t"] + period * k for k in range(copies)])[:args.rows]
    u = np.tile(np.column_stack([log[c] for c in bank.inputs]), (copies, 1))[:args.rows]
    z = np.tile(np.column_stack([log[c] for c in bank.measurements]), (copies, 1))[:args.rows]

    imm = skidimm.Imm(bank)
    loop, run, run_ratio, run_ratios = paired(lambda: imm._step_loop(t, u, z), lambda: imm.run(t, u, z), args.repeat)

    n = min(args.python_rows, args.rows)
    text = (ROOT / "configs" / "ltc_terrains.yaml").read_text().replace("model: ltc_linear", "model: py_ltc")
    with tempfile.TemporaryDirectory(prefix="skidimm_benchmark_") as directory:
        bank_file = pathlib.Path(directory) / "python_bank.yaml"
        bank_file.write_text(text)
        python = skidimm.Imm(skidimm.Bank(bank_file, models={"py_ltc": PythonLtc}))
    compiled = skidimm.Imm(bank)
    fast, slow, model_ratio, model_ratios = paired(lambda: compiled.run(t[:n], u[:n], z[:n]),
                                                   lambda: python.run(t[:n], u[:n], z[:n]), args.repeat)
    calls = 2 * len(bank.modes)  # predict and jacobian per mode per step

    result = {
        "bank": bank.name,
        "modes": len(bank.modes),
        "repeat": args.repeat,
        "imm_run": {"rows": args.rows, "loop_seconds": loop, "run_seconds": run, "ratio": run_ratio,
                    "ratios": run_ratios},
        "python_model": {"rows": n, "compiled_us_per_step": 1e6 * fast / n, "python_us_per_step": 1e6 * slow / n,
                         "us_per_call": 1e6 * (slow - fast) / (n * calls), "ratio": model_ratio,
                         "ratios": model_ratios},
    }
    if args.json:
        print(json.dumps(result, indent=2))
        return
    r, p = result["imm_run"], result["python_model"]
    print(f"bank {bank.name} ({len(bank.modes)} modes); medians of {args.repeat} interleaved runs")
    print(f"Imm.run against the C++ loop, {r['rows']} rows")
    print(f"  C++ loop of Imm::step       {loop:.3f} s  ({1e6 * loop / args.rows:.3f} us/row)")
    print(f"  Imm.run from Python         {run:.3f} s  ({1e6 * run / args.rows:.3f} us/row)")
    print(f"  ratio run / C++ loop        {run_ratio:.3f}  (pairs: {' '.join(f'{x:.2f}' for x in run_ratios)})")
    print(f"Python motion models, {p['rows']} rows")
    print(f"  compiled ltc_linear         {p['compiled_us_per_step']:.2f} us/step")
    print(f"  Python PythonLtc            {p['python_us_per_step']:.2f} us/step "
          f"({p['us_per_call']:.2f} us per predict or jacobian call, {model_ratio:.0f}x)")


if __name__ == "__main__":
    main()
