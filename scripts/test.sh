#!/usr/bin/env bash
# The test command: installs dependencies, builds everything, runs every test.
#   ./scripts/test.sh
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${SKIDIMM_BUILD_DIR:-$root/build}
"$root/scripts/setup.sh"
"$root/scripts/build.sh"
cd "$build"
ctest --output-on-failure -j "${SKIDIMM_JOBS:-$(nproc 2>/dev/null || echo 2)}"
