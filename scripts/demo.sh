#!/usr/bin/env bash
# The main job: installs dependencies, builds skidimm, and identifies the
# terrain of a bundled example log (crushed concrete -> grass -> asphalt,
# 10 s each, outward spiral), printing the dominant-mode timeline and
# drawing the mode probabilities.
#   ./scripts/demo.sh
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${SKIDIMM_BUILD_DIR:-$root/build}
out="$build/demo"

"$root/scripts/setup.sh"
echo "== building skidimm" >&2
"$root/scripts/build.sh" --target skidimm skidimm_ltc_linear skidimm_ltc_shared skidimm_stc_kinematic >/dev/null
mkdir -p "$out"
skidimm="$build/bin/skidimm"

echo "== bundled plugins" >&2
"$skidimm" plugins | grep -E '^[a-z_]+ [0-9]' >&2
echo "== checking the bank" >&2
"$skidimm" validate "$root/configs/ltc_terrains.yaml" >&2
echo "== running the IMM over configs/examples/ltc_switching.csv" >&2
"$skidimm" run --bank "$root/configs/ltc_terrains.yaml" \
  --input "$root/configs/examples/ltc_switching.csv" \
  --output "$out/ltc_switching_estimates.csv"

if "$root/scripts/plot_mode_probabilities.sh" "$out/ltc_switching_estimates.csv" "$out/ltc_switching.png" \
  "LTC terrains, switching every 10 s (bundled example)"; then
  echo "== figure: $out/ltc_switching.png" >&2
fi
echo "== per-row estimates: $out/ltc_switching_estimates.csv" >&2
