#!/usr/bin/env bash
# What a newcomer does after building: install into a prefix and use the
# installed tool. Every installed bank validates with the installed skidimm
# (its bundled plugins found next to it), the documentation its --help points
# at is installed there, `skidimm` alone prints the usage, every command's
# --help ends with examples that run as printed; and a build tree that is not
# fully built (./scripts/demo.sh builds only what it runs) refuses to install,
# saying to run ./scripts/build.sh first.
#   install_test.sh <build dir> <source dir> <work dir>
set -euo pipefail
build=$1
source=$2
work=$3
prefix="$work/prefix"
fail() { echo "FAIL: $*" >&2; exit 1; }
step() { echo "== $*"; }
rm -rf "$work"
mkdir -p "$work"

step "install into $prefix"
cmake --install "$build" --prefix "$prefix" >"$work/install.log" 2>&1 || { cat "$work/install.log"; fail "install"; }
skidimm="$prefix/bin/skidimm"

step "every installed bank validates with the installed skidimm"
banks=0
while IFS= read -r bank; do
  "$skidimm" validate "$bank" >"$work/validate.txt" 2>&1 || { cat "$work/validate.txt"; fail "validate $bank"; }
  grep -q "$prefix/lib" "$work/validate.txt" || fail "$bank: its plugins are not the installed ones: $(cat "$work/validate.txt")"
  banks=$((banks + 1))
done < <(find "$prefix/share/skidimm/configs" -name '*.yaml' -not -path '*/scenarios/*' | sort)
source_banks=$(find "$source/configs" -name '*.yaml' -not -path '*/scenarios/*' | wc -l)
[ "$banks" -eq "$source_banks" ] || fail "$banks banks installed, $source_banks in configs/"
for plugin in "$build"/lib/skidimm/plugins/*.so; do
  [ -f "$prefix/lib/skidimm/plugins/$(basename "$plugin")" ] || fail "bundled plugin not installed: $(basename "$plugin")"
done

step "the documentation is installed"
for page in README.md docs/cli.md docs/bank-format.md docs/images/ltc_switching.png; do
  [ -f "$prefix/share/doc/skidimm/$page" ] || fail "not installed: share/doc/skidimm/$page"
done

step "skidimm alone prints the usage"
"$skidimm" >"$work/usage.txt" 2>&1 || fail "skidimm alone exits $?"
grep -q "^Usage:" "$work/usage.txt" || fail "no usage: $(cat "$work/usage.txt")"
grep -q "Subcommands:" "$work/usage.txt" || fail "the usage lists no commands"
grep -q "$prefix/share/doc/skidimm/README.md" "$work/usage.txt" || fail "the usage does not say where the docs are"

# In the order their examples run: each may use what an earlier one wrote.
commands=(simulate run eval plot fit tune validate plugins new-plugin)
step "each command's --help points at installed files and ends with examples"
for command in "${commands[@]}" bag; do  # bag's examples name a recording: no bag is bundled
  "$skidimm" "$command" --help >"$work/help_$command.txt" || fail "$command --help"
  grep -q "^Examples:" "$work/help_$command.txt" || fail "$command --help has no examples"
  tail -n 1 "$work/help_$command.txt" | grep -q "^More: $prefix/share/doc/skidimm/docs/cli.md#skidimm-$command$" ||
    fail "$command --help does not end with where to read more: $(tail -n 1 "$work/help_$command.txt")"
  while IFS= read -r path; do
    [ -e "${path%%#*}" ] || fail "$command --help names $path, which is not installed"
  done < <(grep -oE "$prefix/[^ ,;)]+" "$work/help_$command.txt")
  if grep -oE "(^|[ (])(docs|configs)/[^ ]*" "$work/help_$command.txt" | grep -v "$prefix" | grep -q .; then
    fail "$command --help names a source-tree path: $(grep -oE "(^|[ (])(docs|configs)/[^ ]*" "$work/help_$command.txt")"
  fi
done

step "the examples run as printed, in a fresh directory"
mkdir -p "$work/examples"
for command in "${commands[@]}"; do
  sed -n '/^Examples:/,/^More:/p' "$work/help_$command.txt" | sed -n 's/^  skidimm /skidimm /p' >"$work/examples_$command.txt"
  [ -s "$work/examples_$command.txt" ] || fail "$command: no example"
  while IFS= read -r example; do
    (cd "$work/examples" && PATH="$prefix/bin:$PATH" bash -c "$example" >"$work/example.out" 2>&1) ||
      { tail -n 20 "$work/example.out"; fail "example '$example' failed"; }
  done <"$work/examples_$command.txt"
done

step "an unbuilt tree refuses to install and says what to do"
unbuilt="$work/unbuilt"
cmake -S "$source" -B "$unbuilt" -DCMAKE_BUILD_TYPE=Release -DSKIDIMM_BUILD_TESTS=OFF -DSKIDIMM_BUILD_BENCHMARKS=OFF \
  >"$work/unbuilt_configure.log" 2>&1 || { cat "$work/unbuilt_configure.log"; fail "configure"; }
if cmake --install "$unbuilt" --prefix "$work/unbuilt_prefix" >"$work/unbuilt_install.log" 2>&1; then
  fail "an unbuilt tree installed"
fi
grep -q "Run ./scripts/build.sh first" "$work/unbuilt_install.log" ||
  fail "the refusal does not say what to do: $(cat "$work/unbuilt_install.log")"
grep -q "bin/skidimm" "$work/unbuilt_install.log" || fail "the refusal does not name what is missing"
[ ! -e "$work/unbuilt_prefix" ] || [ -z "$(find "$work/unbuilt_prefix" -type f)" ] || fail "a partial install was left"
echo "installed skidimm works"
