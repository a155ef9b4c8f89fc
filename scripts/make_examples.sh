#!/usr/bin/env bash
# Regenerates the bundled example logs in configs/examples/ with the
# simulator, from the paper's switching scenarios (deterministic: each
# scenario's own seed).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
skidimm=${SKIDIMM:-$root/build/bin/skidimm}
for name in ltc_switching stc_switching; do
  "$skidimm" simulate -q --scenario "$root/configs/scenarios/$name.yaml" --output "$root/configs/examples/$name.csv"
done
echo "wrote $root/configs/examples/{ltc,stc}_switching.csv"
