#!/usr/bin/env bash
# Installs skidimm's build and test dependencies from Debian packages.
# Idempotent: when every package is already installed it returns in well
# under a second without touching apt.
#   scripts/setup.sh                what the build and the gate need
#   scripts/setup.sh --sanitizers   and clang's sanitizers and libFuzzer (scripts/check.sh)
set -euo pipefail
sanitizers=0
for arg in "$@"; do
  case "$arg" in
    --sanitizers) sanitizers=1 ;;
    *) echo "setup.sh: unknown argument '$arg' (--sanitizers or nothing)" >&2; exit 2 ;;
  esac
done

packages=(
  build-essential cmake
  libeigen3-dev libboost-dev libyaml-cpp-dev libceres-dev
  libgtest-dev libgmock-dev libbenchmark-dev libcli11-dev
  libmuparser-dev  # expressions of log columns in banks
  gnuplot-nox  # figures (skidimm plot)
  python3      # scripts/results_tables.py and scripts/derive_physical_configs.py (standard library only)
  pybind11-dev python3-pybind11  # the Python package (python/, docs/python.md)
  python3-numpy python3-pandas   # ... its arrays and data frames
  python3-pytest                 # ... its tests (run by ctest)
  python3-dask python3-distributed  # ... fleet-scale eval and fit (skidimm.dask)
  python3-matplotlib             # ... the figure of docs/python.md
  libzstd-dev liblz4-dev libsqlite3-dev  # ROS 2 bags (docs/ros2.md): MCAP chunks, .db3 storage
)
# The sanitizer stage (scripts/check.sh): ASan, UBSan, TSan, libFuzzer,
# llvm-symbolizer. Not in the gate, so not installed for it.
if [ "$sanitizers" -eq 1 ]; then
  packages+=(clang libclang-rt-14-dev llvm-14)
fi
# Node and npm run the ROS 2 tests' independent MCAP, CDR and Foxglove
# implementations (tests only). A machine that has Node already (from
# another source than Debian) keeps it.
if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
  packages+=(nodejs npm)
fi

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -gt 0 ]; then
  echo "skidimm setup: installing ${missing[*]}" >&2
  sudo_cmd=()
  if [ "$(id -u)" -ne 0 ]; then
    sudo_cmd=(sudo)
  fi
  export DEBIAN_FRONTEND=noninteractive
  "${sudo_cmd[@]}" apt-get update -qq
  "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

# The npm packages of the ROS 2 tests, from tests/ros/package-lock.json, into
# a cache outside the source tree (a no-op once installed).
"$(dirname "$0")/node_packages.sh" --install >/dev/null
