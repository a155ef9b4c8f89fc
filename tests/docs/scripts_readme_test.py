#!/usr/bin/env python3
"""scripts/README.md lists every script in scripts/, once, and the run bits
say how each is used.

Usage: scripts_readme_test.py SOURCE_DIR

* every file in scripts/ (but the README) is named in a table row of the
  README as `name`, exactly once, and every name there exists;
* a script with a #! line is executable; a script without one (sourced,
  like seeds.sh) is not.

Each problem is named; the exit status is 1 if there is any.
"""
import os
import re
import sys
from pathlib import Path


def main():
    scripts = Path(sys.argv[1]) / "scripts"
    readme = (scripts / "README.md").read_text()
    listed = re.findall(r"^\| `([^`]+)` \|", readme, flags=re.MULTILINE)
    files = sorted(p.name for p in scripts.iterdir() if p.is_file() and p.name != "README.md")
    problems = []
    for name in files:
        count = listed.count(name)
        if count != 1:
            problems.append(f"scripts/{name}: listed {count} times in scripts/README.md's tables "
                            "(expected once: add a row under Entry points or Maintenance tools)")
    for name in sorted(set(listed) - set(files)):
        problems.append(f"scripts/README.md lists `{name}`, which is not in scripts/")
    for name in files:
        path = scripts / name
        with open(path, "rb") as f:
            shebang = f.read(2) == b"#!"
        executable = os.access(path, os.X_OK)
        if shebang and not executable:
            problems.append(f"scripts/{name}: has a #! line but is not executable (git update-index --chmod=+x)")
        if not shebang and executable:
            problems.append(f"scripts/{name}: executable without a #! line (a sourced file is not executable)")
    for problem in problems:
        print(problem, file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
