#!/usr/bin/env bash
# ./scripts/demo.sh as a newcomer runs it: it says up front how long the
# first run takes, shows the build's progress, and prints the evaluation the
# README quotes. Reruns scripts/readme_demo.py on a copy of the README and
# compares.
#   readme_demo_test.sh <source dir> <build dir> <work dir>
set -euo pipefail
source=$1
build=$2
work=$3
fail() { echo "FAIL: $*" >&2; exit 1; }
rm -rf "$work"
mkdir -p "$work"
cp "$source/README.md" "$work/README.md"
SKIDIMM_BUILD_DIR="$build" /usr/bin/python3 "$source/scripts/readme_demo.py" "$work/README.md" 2>"$work/demo.err" ||
  { cat "$work/demo.err" >&2; fail "the demo failed"; }
first_line=$(head -n 1 "$work/demo.err")
[[ $first_line == *minutes* ]] || fail "the demo's first line does not say how long it takes: '$first_line'"
grep -qE '^\[ *[0-9]+%\] ' "$work/demo.err" || fail "the demo shows no build progress: $(head -n 5 "$work/demo.err")"
grep -q "cmake --install" "$work/demo.err" || fail "the demo does not say how to install after it"
if ! diff "$source/README.md" "$work/README.md" >"$work/readme.diff"; then
  echo "FAIL: README.md's demo excerpt is not what ./scripts/demo.sh prints now (scripts/readme_demo.py):" >&2
  cat "$work/readme.diff" >&2
  exit 1
fi
echo "README's demo excerpt reproduced"
