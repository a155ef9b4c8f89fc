#!/usr/bin/env python3
"""Writes the README's excerpt of what ./scripts/demo.sh prints: runs the demo
and puts its evaluation, and a sentence on how fast the most likely mode and
the decision settle after a switch, between <!-- demo:eval --> and
<!-- end --> in README.md. Standard library only.

    scripts/readme_demo.py [README.md]

The demo's own messages (stderr) pass through. A test reruns this on a copy
of the README and compares (tests/cli/readme_demo_test.sh).
"""
import os
import re
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BEGIN, END = "<!-- demo:eval -->", "<!-- end -->"


def settled_medians(table):
    """The median delays after a switch until the most likely mode, and the decision, stay with the new mode."""
    most_likely = re.search(r"and most likely from then on until the next switch: median ([0-9.]+) s", table)
    decision = re.search(r"settled after median ([0-9.]+) s", table)
    if not most_likely or not decision:
        sys.exit("readme_demo.py: the demo's evaluation names no settling delays")
    return most_likely.group(1), decision.group(1)


def excerpt(table):
    most_likely, decision = settled_medians(table)
    return (f"{BEGIN}\n```\n{table.strip(chr(10))}\n```\n\n"
            f"Right after a switch the most likely mode flickers between terrains: over the run's switches it "
            f"settles on the new terrain after a median of {most_likely} s, while the decision a controller acts on "
            f"(hysteresis and a minimum hold, `decision:` in the bank) settles after a median of {decision} s.\n{END}")


def main():
    readme = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "README.md")
    demo = subprocess.run([os.path.join(ROOT, "scripts", "demo.sh")], stdout=subprocess.PIPE, text=True)
    if demo.returncode != 0:
        sys.exit(f"readme_demo.py: scripts/demo.sh failed ({demo.returncode})")
    with open(readme) as f:
        text = f.read()
    start, end = text.find(BEGIN), text.find(END, text.find(BEGIN))
    if start < 0 or end < 0:
        sys.exit(f"readme_demo.py: {readme} has no {BEGIN} ... {END} block")
    text = text[:start] + excerpt(demo.stdout) + text[end + len(END):]
    with open(readme, "w") as f:
        f.write(text)


if __name__ == "__main__":
    main()
