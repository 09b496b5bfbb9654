#!/usr/bin/env bash
# The cost of writing the AOVs (issue 24: under 5% of a path render): `tritrace render` of
# cornell-area, 256 x 256, 64 spp, without and with --aovs albedo,normal,depth,variance, runs
# alternating so that a loaded machine slows both alike. Prints each run, then the medians of the
# whole command's wall time and of the render time its summary line reports, and the median of the
# per-pair ratios. Usage: bench/aov_cost.sh [TRITRACE] [PAIRS] (defaults: build/tritrace, 9).
set -euo pipefail
bin=${1:-build/tritrace}
pairs=${2:-9}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
args=(render --scene cornell-area --integrator path --width 256 --height 256 --spp 64)
median() { sort -g | awk '{v[NR] = $1} END {print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}'; }
: >"$out/runs"
for i in $(seq 1 "$pairs"); do
  for mode in plain aovs; do
    extra=()
    [ "$mode" = aovs ] && extra=(--aovs albedo,normal,depth,variance)
    start=$(date +%s%N)
    line=$("$bin" "${args[@]}" "${extra[@]}" -o "$out/$mode.exr" 2>&1 | tail -1)
    end=$(date +%s%N)
    wall=$(((end - start) / 1000000))
    render=$(echo "$line" | sed -n 's/.* in \([0-9.]*\) ms .*/\1/p')
    echo "$i $mode $wall $render" | tee -a "$out/runs"
  done
done
for mode in plain aovs; do
  w=$(awk -v m="$mode" '$2 == m {print $3}' "$out/runs" | median)
  r=$(awk -v m="$mode" '$2 == m {print $4}' "$out/runs" | median)
  echo "$mode: median wall $w ms, median render $r ms"
done
awk '{v[$1, $2] = $3; r[$1, $2] = $4; n = $1}
     END {for (i = 1; i <= n; ++i) print v[i, "aovs"] / v[i, "plain"], r[i, "aovs"] / r[i, "plain"]}' \
  "$out/runs" >"$out/ratios"
echo "median ratio aovs/plain: wall $(cut -d' ' -f1 "$out/ratios" | median), render $(cut -d' ' -f2 "$out/ratios" | median)"
