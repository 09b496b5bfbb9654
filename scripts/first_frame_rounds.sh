#!/usr/bin/env bash
# Time to first pixel of tritrace against the minimal Embree program (bench/embree_first_frame.cpp),
# in alternating rounds: wall time and peak RSS of each run (/usr/bin/time), then the medians.
#   scripts/first_frame_rounds.sh [ROUNDS] [TRITRACE] [EMBREE_PROGRAM] [SCENE] [MESH]
# Defaults: 9 rounds of build/tritrace render scenes/benchmarks/sphere10m_first_frame.json against
# build/bench/tritrace_embree_first_frame /tmp/sphere10m.ply (make it first with
# /usr/bin/python3 scripts/make_displaced_sphere_ply.py --triangles 10000000 -o /tmp/sphere10m.ply).
set -euo pipefail
top=$(cd "$(dirname "$0")/.." && pwd)
rounds=${1:-9}
tritrace=${2:-$top/build/tritrace}
embree=${3:-$top/build/bench/tritrace_embree_first_frame}
scene=${4:-$top/scenes/benchmarks/sphere10m_first_frame.json}
mesh=${5:-/tmp/sphere10m.ply}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
for ((i = 1; i <= rounds; i++)); do
  /usr/bin/time -f "%e %M" -o "$out/t" "$tritrace" render "$scene" -o "$out/frame.png" -q
  echo "tritrace $(cat "$out/t")" | tee -a "$out/all"
  /usr/bin/time -f "%e %M" -o "$out/t" "$embree" "$mesh" > /dev/null
  echo "embree $(cat "$out/t")" | tee -a "$out/all"
done
/usr/bin/python3 - "$out/all" <<'PY'
import statistics, sys
runs = {}
for line in open(sys.argv[1]):
    name, wall, rss = line.split()
    runs.setdefault(name, []).append((float(wall), int(rss)))
for name, v in runs.items():
    print(f"{name}: median {statistics.median(w for w, _ in v):.2f} s "
          f"(min {min(w for w, _ in v):.2f}, max {max(w for w, _ in v):.2f}), "
          f"peak RSS median {statistics.median(r for _, r in v) / 2**20:.3f} GiB")
t, e = (statistics.median(w for w, _ in runs[k]) for k in ("tritrace", "embree"))
print(f"tritrace / embree: {t / e:.2f}")
PY
