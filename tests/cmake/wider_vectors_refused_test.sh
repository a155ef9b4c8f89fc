#!/bin/bash
# Configuring with AVX turned on (-march=native, -mavx2, in CMAKE_CXX_FLAGS or
# the build type's flags) fails at once, saying why and what to do: Debian's
# static Ceres is built for the baseline vector width, and a skidimm built
# wider corrupted the heap in every fit. The escape hatch passes the check.
#   wider_vectors_refused_test.sh SOURCE_DIR WORK_DIR
set -u
source=$1
work=$2
rm -rf "$work"
mkdir -p "$work"
fail() { echo "FAIL: $*" >&2; exit 1; }

if ! grep -q avx /proc/cpuinfo; then
  echo "this machine has no AVX: -march=native turns nothing on, only -mavx2 is checked"
fi
for flags in "-DCMAKE_CXX_FLAGS=-march=native" "-DCMAKE_CXX_FLAGS=-mavx2" \
             "-DCMAKE_CXX_FLAGS_RELEASE=-O3 -DNDEBUG -mavx2"; do
  [ "$flags" = "-DCMAKE_CXX_FLAGS=-march=native" ] && ! grep -q avx /proc/cpuinfo && continue
  dir=$work/$(echo "$flags" | tr -c 'a-zA-Z0-9' '_')
  if cmake -S "$source" -B "$dir" -DCMAKE_BUILD_TYPE=Release "$flags" >"$dir.log" 2>&1; then
    fail "configured with $flags"
  fi
  grep -q "The compiler flags turn on AVX" "$dir.log" || { cat "$dir.log" >&2; fail "no reason given for $flags"; }
  grep -q "SKIDIMM_ALLOW_WIDER_VECTORS=ON" "$dir.log" || fail "no way out named for $flags"
done

# Told that Ceres matches, the check stands aside (the configure itself may
# go on to fail or not; only the refusal is checked).
dir=$work/allowed
cmake -S "$source" -B "$dir" -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_FLAGS=-mavx2 -DSKIDIMM_ALLOW_WIDER_VECTORS=ON \
  -DSKIDIMM_BUILD_TESTS=OFF >"$dir.log" 2>&1
if grep -q "The compiler flags turn on AVX" "$dir.log"; then fail "refused with SKIDIMM_ALLOW_WIDER_VECTORS=ON"; fi
echo "ok"
