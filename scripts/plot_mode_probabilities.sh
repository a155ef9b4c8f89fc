#!/usr/bin/env bash
# Draws mode probabilities over time from a `skidimm run` output CSV, the
# paper's figure: one line per mode, the true mode (if the output has a
# truth_mode column) as shaded bands with dashed lines at the switches.
#   scripts/plot_mode_probabilities.sh estimates.csv figure.png|figure.svg [title]
set -euo pipefail
if [ $# -lt 2 ]; then
  echo "usage: $0 estimates.csv figure.png|figure.svg [title]" >&2
  exit 2
fi
in=$1
out=$2
title=${3:-$(basename "$in")}
if ! command -v gnuplot >/dev/null 2>&1; then
  echo "$0: gnuplot is not installed (scripts/setup.sh installs gnuplot-nox); no figure drawn" >&2
  exit 1
fi
[ -r "$in" ] || { echo "$0: cannot read $in" >&2; exit 1; }
case "$out" in
  *.png) terminal="pngcairo size 1100,420 font 'sans,10'" ;;
  *.svg) terminal="svg size 1100,420 font 'sans,10'" ;;
  *) echo "$0: the figure must end in .png or .svg" >&2; exit 2 ;;
esac

header=$(head -n 1 "$in")
IFS=, read -r -a columns <<<"$header"
mu_columns=()
truth=0
for i in "${!columns[@]}"; do
  case "${columns[$i]}" in
    mu_*) mu_columns+=("$((i + 1)):${columns[$i]#mu_}") ;;
    truth_mode) truth=$((i + 1)) ;;
  esac
done
[ ${#mu_columns[@]} -gt 0 ] || { echo "$0: $in has no mu_<mode> columns" >&2; exit 1; }

script=$(mktemp)
trap 'rm -f "$script"' EXIT
{
  echo "set terminal $terminal"
  echo "set output '$out'"
  echo "set datafile separator ','"
  echo "set title \"$title\" noenhanced"
  echo "set xlabel 'time (s)'; set ylabel 'mode probability'; set yrange [-0.02:1.05]"
  echo "set key outside right noenhanced; set grid ytics lc rgb '#dddddd'"
  if [ "$truth" -gt 0 ]; then
    # Shaded band per true-mode interval, coloured like that mode's line.
    awk -F, -v col="$truth" -v modes="$(printf '%s\n' "${mu_columns[@]}" | cut -d: -f2 | paste -sd, -)" '
      BEGIN { n = split(modes, m, ","); for (i = 1; i <= n; ++i) index_of[m[i]] = i }
      NR == 1 { next }
      { t = $1; mode = $col
        if (mode != current) {
          if (current != "") { print_band(start, t, current); printf "set arrow from %s, graph 0 to %s, graph 1 nohead dt 2 lc rgb \"#444444\"\n", t, t }
          current = mode; start = t }
        last = t }
      END { if (current != "") print_band(start, last, current) }
      function print_band(a, b, mode,   i) {
        i = (mode in index_of) ? index_of[mode] : 0
        if (i > 0) printf "set object rect from %s, graph 0 to %s, graph 1 back fc lt %d fs transparent solid 0.12 noborder\n", a, b, i
      }' "$in"
  fi
  printf 'plot '
  sep=""
  k=1
  for entry in "${mu_columns[@]}"; do
    printf "%s'%s' using 1:%s with lines lt %d lw 2 title '%s'" "$sep" "$in" "${entry%%:*}" "$k" "${entry#*:}"
    sep=", "
    k=$((k + 1))
  done
  echo
} >"$script"
gnuplot "$script"
