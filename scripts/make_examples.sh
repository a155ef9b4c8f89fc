#!/usr/bin/env bash
# Regenerates the bundled example logs in configs/examples/ (deterministic, seed 1).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${SKIDIMM_BUILD_DIR:-$root/build}
cmake --build "$build" --target skidimm_make_example_log >/dev/null
"$build/bin/skidimm_make_example_log" ltc "$root/configs/ltc_terrains.yaml" "$root/configs/examples/ltc_switching.csv" 1
"$build/bin/skidimm_make_example_log" stc "$root/configs/stc_slip4.yaml" "$root/configs/examples/stc_switching.csv" 1
echo "wrote $root/configs/examples/{ltc,stc}_switching.csv"
