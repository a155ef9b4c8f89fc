#!/usr/bin/env bash
# The main job: installs dependencies, builds skidimm, and runs the paper's
# terrain-switching experiment end to end: simulate a Husky-class robot on
# crushed concrete, grass and asphalt (10 s each, outward spiral), identify
# the terrain with the bundled fitted bank, print the evaluation and draw the
# mode probabilities.
#   ./scripts/demo.sh
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${SKIDIMM_BUILD_DIR:-$root/build}
out="$build/demo"

echo "== skidimm demo: about 10 minutes the first time on a fresh two-core machine (Debian packages, then the" >&2
echo "   build, whose progress shows below); later runs rebuild only what changed and take seconds." >&2
"$root/scripts/setup.sh"
echo "== building skidimm (the tool and the plugins the demo uses; full log: $build/demo_build.log)" >&2
mkdir -p "$build"
# Only make's progress lines on the terminal; on a failure, the end of the log.
if ! "$root/scripts/build.sh" --target skidimm skidimm_ltc_linear skidimm_ltc_shared skidimm_stc_kinematic 2>&1 |
  tee "$build/demo_build.log" | { grep --line-buffered -E '^\[ *[0-9]+%\]' || true; } >&2; then
  tail -n 40 "$build/demo_build.log" >&2
  echo "demo: the build failed (full log: $build/demo_build.log)" >&2
  exit 1
fi
mkdir -p "$out"
skidimm="$build/bin/skidimm"
bank="$root/configs/ltc_terrains.yaml"

echo "== bundled plugins" >&2
"$skidimm" plugins | grep -E '^[a-z_]+ [0-9]' >&2
echo "== the bank" >&2
"$skidimm" validate "$bank" >&2
echo "== simulating configs/scenarios/ltc_switching.yaml" >&2
"$skidimm" simulate --scenario "$root/configs/scenarios/ltc_switching.yaml" --output "$out/ltc_switching_log.csv"
echo "== identifying the terrain" >&2
"$skidimm" run --bank "$bank" --input "$out/ltc_switching_log.csv" --output "$out/ltc_switching_estimates.csv" \
  --plot "$out/ltc_switching.png"
echo "== evaluation against the simulator's truth" >&2
"$skidimm" eval --bank "$bank" --input "$out/ltc_switching_log.csv"
echo >&2
echo "== figure: $out/ltc_switching.png" >&2
echo "   per-row estimates: $out/ltc_switching_estimates.csv" >&2
echo "   to install (the demo built only what it runs): ./scripts/build.sh && cmake --install $build --prefix ~/.local" >&2
