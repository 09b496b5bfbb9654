#!/bin/sh
# tritrace against Blender Cycles on cornell-area, side by side in one session: for each of REPS
# rounds, tritrace (its own BVH), tritrace with Embree (--accel embree) and Cycles at each spp,
# interleaved so that a change in the machine's load falls on all three. Wall and CPU (user +
# system) seconds by /usr/bin/time, the load average before every run, the render time each
# renderer reports; at the end the medians of wall and CPU time per renderer and spp, and Cycles'
# medians over tritrace's (both builds). Writes OUTDIR/log.txt and the images (PFM; Cycles also EXR).
#
#   bench/blender/side_by_side.sh OUTDIR [REPS] [SPP...]     (defaults: 3 rounds, 256 and 1024 spp)
#
# Then: /usr/bin/python3 bench/blender/compare.py --ref REF.pfm OUTDIR/*_r1.pfm
# Needs: build/tritrace (tritrace_cli target), Debian's blender (3.4), /usr/bin/time.
set -eu
out=${1:?usage: side_by_side.sh OUTDIR [REPS] [SPP...]}
reps=${2:-3}
[ $# -ge 2 ] && shift 2 || shift $#
spps=${*:-256 1024}
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
mkdir -p "$out"
log="$out/log.txt"
size=256
threads=2
bounces=128

note() { echo "$*" | tee -a "$log"; }
load() { cut -d' ' -f1-3 /proc/loadavg; }

note "# $(date -u '+%Y-%m-%d %H:%M:%S UTC') $(uname -n), $(nproc) cpus; $(blender --version 2>/dev/null | head -1)"
note "# tritrace $(git -C "$root" rev-parse --short HEAD)"
# Blender's start-up alone: factory settings, no scene, quit.
for i in 1 2 3; do
  l=$(load)
  /usr/bin/time -f 'wall_s %e cpu_s %U+%S' -o "$out/startup.time" blender -b --factory-startup \
    --python-expr 'import bpy' >/dev/null 2>&1
  note "blender-startup rep $i load $l $(cat "$out/startup.time")"
done
for r in $(seq "$reps"); do
  for spp in $spps; do
    f="$out/tritrace_${spp}_r$r"
    l=$(load)
    /usr/bin/time -f 'wall_s %e cpu_s %U+%S' -o "$f.time" "$root/build/tritrace" render --scene cornell-area \
      --width $size --height $size --spp "$spp" --max-depth $bounces --threads $threads \
      -o "$f.pfm" >"$f.out" 2>&1
    note "tritrace spp $spp rep $r load $l $(cat "$f.time") | $(grep rendered "$f.out")"

    f="$out/tritrace-embree_${spp}_r$r"
    l=$(load)
    /usr/bin/time -f 'wall_s %e cpu_s %U+%S' -o "$f.time" "$root/build/tritrace" render --scene cornell-area \
      --width $size --height $size --spp "$spp" --max-depth $bounces --threads $threads \
      --accel embree -o "$f.pfm" >"$f.out" 2>&1
    note "tritrace-embree spp $spp rep $r load $l $(cat "$f.time") | $(grep rendered "$f.out")"

    f="$out/cycles_${spp}_r$r"
    l=$(load)
    /usr/bin/time -f 'wall_s %e cpu_s %U+%S' -o "$f.time" blender -b --factory-startup \
      --python "$here/cornell_area.py" -- --spp "$spp" --out "$f.exr" --threads $threads \
      --size $size --bounces $bounces >"$f.out" 2>&1
    note "cycles spp $spp rep $r load $l $(cat "$f.time") | $(grep Finished "$f.out" | tail -1 | \
      sed 's/.*| Time:\([0-9:.]*\) |.*/reported Time:\1/') | $(grep '^cycles:' "$f.out")"
  done
done
# Medians over the rounds (lower median for an even count) and the ratios Cycles / tritrace.
note "# medians over $reps rounds: wall s, CPU s (user + system); Cycles / tritrace wall, CPU"
for spp in $spps; do
  grep -E "^(tritrace|tritrace-embree|cycles) spp $spp rep" "$log" | awk -v spp="$spp" '
    { split($13, t, "+"); name = $1; n[name]++; wall[name, n[name]] = $11; cpu[name, n[name]] = t[1] + t[2] }
    function median(a, name, k,   i, j, s, v) {
      for (i = 1; i <= k; i++) v[i] = a[name, i]
      for (i = 2; i <= k; i++) for (j = i; j > 1 && v[j - 1] > v[j]; j--) { s = v[j]; v[j] = v[j - 1]; v[j - 1] = s }
      return v[int((k + 1) / 2)]
    }
    END {
      cw = median(wall, "cycles", n["cycles"]); cc = median(cpu, "cycles", n["cycles"])
      for (r = 1; r <= 2; r++) {
        name = r == 1 ? "tritrace" : "tritrace-embree"
        w = median(wall, name, n[name]); c = median(cpu, name, n[name])
        printf "median spp %s %s wall %.2f cpu %.2f | cycles wall %.2f cpu %.2f | ratio wall %.2fx cpu %.2fx\n", spp, name, w, c, cw, cc, cw / w, cc / c
      }
    }' | tee -a "$log"
done
