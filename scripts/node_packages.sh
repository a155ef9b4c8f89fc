#!/usr/bin/env bash
# Where the npm packages of the ROS 2 tests live (tests/ros/package.json:
# @mcap/core, @foxglove/rosmsg, @foxglove/rosmsg2-serialization,
# @foxglove/ws-protocol and their helpers), outside the source tree: a cache
# directory named after the lock file's hash, so every build directory (the
# Release build, the sanitizer build) finds the same installation and a new
# lock file gets a fresh one. Tests only: skidimm itself never runs Node.
#   scripts/node_packages.sh            prints the node_modules directory
#   scripts/node_packages.sh --install  installs it first if it is missing (npm ci)
# SKIDIMM_NODE_CACHE overrides the cache's parent directory.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
lock=$root/tests/ros/package-lock.json
hash=$(sha256sum "$lock" | cut -c1-16)
cache=${SKIDIMM_NODE_CACHE:-${XDG_CACHE_HOME:-${HOME:-/tmp}/.cache}/skidimm}
dir=$cache/node-$hash
if [ "${1:-}" = "--install" ] && [ ! -f "$dir/.installed" ]; then
  echo "skidimm setup: installing the npm packages of the ROS 2 tests into $dir" >&2
  mkdir -p "$dir"
  cp "$root/tests/ros/package.json" "$lock" "$dir/"
  (cd "$dir" && npm ci --no-audit --no-fund --loglevel=error >&2)
  touch "$dir/.installed"
fi
echo "$dir/node_modules"
