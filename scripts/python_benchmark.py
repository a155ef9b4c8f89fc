#!/usr/bin/env python3
"""Times skidimm's Python routes against the C++ loop (docs/python.md, "Speed").

  PYTHONPATH=build/lib/python3.11/dist-packages /usr/bin/python3 scripts/python_benchmark.py [--rows N]

1. Imm.run over N rows (default 1,000,000: the example log tiled) against
   the bare C++ loop of Imm::step over the same arrays, in the same module
   (Imm._step_loop: no outputs, no decisions). Prints the ratio.
2. The cost of a Python motion model: the same bank with its three
   ltc_linear modes as a Python class (python/tests/ltc_python.py), per step
   and per model call.
Best of --repeat runs each. Nothing is asserted: timings are machine facts.
"""

import argparse
import pathlib
import sys
import time

import numpy as np

import skidimm

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "python" / "tests"))
from ltc_python import PythonLtc  # noqa: E402


def best(function, repeat):
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return min(times)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--rows", type=int, default=1_000_000)
    parser.add_argument("--python-rows", type=int, default=20_000)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()

    bank = skidimm.Bank(ROOT / "configs" / "ltc_terrains.yaml")
    log = skidimm.read_csv(ROOT / "configs" / "examples" / "ltc_switching.csv")
    period = log["t"][-1] + 0.02
    copies = -(-args.rows // len(log["t"]))
    t = np.concatenate([log["t"] + period * k for k in range(copies)])[:args.rows]
    u = np.tile(np.column_stack([log[c] for c in bank.inputs]), (copies, 1))[:args.rows]
    z = np.tile(np.column_stack([log[c] for c in bank.measurements]), (copies, 1))[:args.rows]

    imm = skidimm.Imm(bank)
    loop = best(lambda: imm._step_loop(t, u, z), args.repeat)
    run = best(lambda: imm.run(t, u, z), args.repeat)
    print(f"bank {bank.name} ({len(bank.modes)} modes), {args.rows} rows")
    print(f"  C++ loop of Imm::step       {loop:.3f} s  ({1e6 * loop / args.rows:.3f} us/row)")
    print(f"  Imm.run from Python         {run:.3f} s  ({1e6 * run / args.rows:.3f} us/row)")
    print(f"  ratio run / C++ loop        {run / loop:.3f}")

    n = args.python_rows
    lines = (ROOT / "configs" / "ltc_terrains.yaml").read_text().replace("model: ltc_linear", "model: py_ltc")
    bank_file = pathlib.Path("/tmp/skidimm_benchmark_python_bank.yaml")
    bank_file.write_text(lines)
    python = skidimm.Imm(skidimm.Bank(bank_file, models={"py_ltc": PythonLtc}))
    compiled = skidimm.Imm(bank)
    slow = best(lambda: python.run(t[:n], u[:n], z[:n]), args.repeat)
    fast = best(lambda: compiled.run(t[:n], u[:n], z[:n]), args.repeat)
    calls = 2 * len(bank.modes)  # predict and jacobian per mode per step
    print(f"Python motion models: {len(bank.modes)} modes, {n} rows")
    print(f"  compiled ltc_linear         {1e6 * fast / n:.2f} us/step")
    print(f"  Python PythonLtc            {1e6 * slow / n:.2f} us/step "
          f"({1e6 * (slow - fast) / (n * calls):.2f} us per predict or jacobian call, {slow / fast:.0f}x)")


if __name__ == "__main__":
    main()
