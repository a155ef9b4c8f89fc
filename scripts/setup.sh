#!/usr/bin/env bash
# Installs skidimm's build and test dependencies from Debian packages.
# Idempotent: when every package is already installed it returns in well
# under a second without touching apt.
set -euo pipefail

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
  clang libclang-rt-14-dev llvm-14  # the sanitizer stage (scripts/check.sh): ASan, UBSan, TSan, libFuzzer, llvm-symbolizer
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi

echo "skidimm setup: installing ${missing[*]}" >&2
sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then
  sudo_cmd=(sudo)
fi
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -qq
"${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
