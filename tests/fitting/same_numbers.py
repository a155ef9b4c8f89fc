#!/usr/bin/env python3
"""same_numbers.py A B RELATIVE: whether two texts are the same but for numbers
within RELATIVE of each other (relative to the larger magnitude; numbers both
below 1e-12 in size are equal). Prints each line that differs more and exits 1.
"""
import re
import sys

NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


def split(line):
    return NUMBER.split(line), [float(x) for x in NUMBER.findall(line)]


def close(a, b, relative):
    return abs(a - b) <= relative * max(abs(a), abs(b)) or max(abs(a), abs(b)) < 1e-12


def main():
    a_path, b_path, relative = sys.argv[1], sys.argv[2], float(sys.argv[3])
    a_lines = [l for l in open(a_path) if not l.startswith("#")]
    b_lines = [l for l in open(b_path) if not l.startswith("#")]
    if len(a_lines) != len(b_lines):
        print(f"{a_path}: {len(a_lines)} lines, {b_path}: {len(b_lines)}")
        return 1
    status = 0
    for k, (a, b) in enumerate(zip(a_lines, b_lines), 1):
        (a_text, a_numbers), (b_text, b_numbers) = split(a), split(b)
        if a_text != b_text or len(a_numbers) != len(b_numbers) or not all(
                close(x, y, relative) for x, y in zip(a_numbers, b_numbers)):
            print(f"line {k}:\n< {a.rstrip()}\n> {b.rstrip()}")
            status = 1
    return status


if __name__ == "__main__":
    sys.exit(main())
