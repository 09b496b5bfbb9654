#!/usr/bin/env python3
# Speed of the Python module's Accel.intersect on 1M rays against the same rays traced by C++
# (build/bench/tritrace_ray_batch: the library's batch queries on every core, no Python), against
# the lab frame of `tritrace bench` on the same scene, and against Embree through the module, for
# coherent (camera) and incoherent (random) rays. Results: docs/PERFORMANCE.md.
#
#   PYTHONPATH=build/python /usr/bin/python3 bench/python_rays.py [--reps 11] [--scene NAME ...]
import argparse
import json
import os
import pathlib
import platform
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

import tritrace

BUILD = pathlib.Path(__file__).resolve().parents[1] / "build"


def camera_rays(scene, side):
    """The scene's camera rays through a side x side image, row by row, one origin per ray."""
    origin, directions = scene.camera_rays(width=side, height=side)
    directions = np.ascontiguousarray(directions.reshape(-1, 3))
    return np.ascontiguousarray(np.broadcast_to(origin, directions.shape)), directions


def random_rays(scene, n, seed=1):
    """Origins uniform in the middle 90% of the scene's box, directions uniform on the sphere."""
    lo, hi = (b.astype(np.float64) for b in scene.bounds)
    pad = 0.05 * (hi - lo)
    rng = np.random.default_rng(seed)
    origins = rng.uniform(lo + pad, hi - pad, (n, 3)).astype(np.float32)
    directions = rng.normal(size=(n, 3)).astype(np.float32)
    return origins, directions


def time_python(accel, origins, directions, reps):
    accel.intersect(origins, directions)  # warm-up
    times = []
    for _ in range(reps):
        start = time.perf_counter()
        hits = accel.intersect(origins, directions)
        times.append(time.perf_counter() - start)
        del hits
    return statistics.median(times) * 1e3, min(times) * 1e3, max(times) * 1e3


def time_cpp(scene_name, kind, origins, directions, reps, coherent):
    with tempfile.NamedTemporaryFile(suffix=".bin") as f:
        np.concatenate([origins, directions], axis=1).astype("<f4").tofile(f.name)
        out = subprocess.run(
            [str(BUILD / "bench" / "tritrace_ray_batch"), scene_name, kind, f.name, str(reps),
             "coherent" if coherent else "incoherent"],
            check=True, capture_output=True, text=True).stdout
    return json.loads(out)


def lab_bench(scene_name, side, reps):
    with tempfile.NamedTemporaryFile(suffix=".json") as f:
        subprocess.run([str(BUILD / "tritrace"), "bench", "--scene", scene_name, "--accel", "bvh",
                        "--width", str(side), "--height", str(side), "--reps", str(reps), "-q",
                        "--json", f.name], check=True, capture_output=True)
        return json.load(open(f.name))[0]


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--scene", action="append", help="built-in scenes (default: cornell, "
                        "terrain:1m)")
    parser.add_argument("--side", type=int, default=1000, help="camera image side: side^2 rays "
                        "(default 1000: 1M rays)")
    parser.add_argument("--reps", type=int, default=11)
    args = parser.parse_args()
    scenes = args.scene or ["cornell", "terrain:1m"]
    n = args.side * args.side
    embree = "embree" in tritrace.accels
    print(f"# {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}, NumPy {np.__version__}, tritrace "
          f"{tritrace.__version__}; {n} rays, median of {args.reps} after a warm-up")
    header = ("scene", "rays", "python bvh Mrays/s", "C++ batch Mrays/s", "python/C++",
              "python embree Mrays/s", "bvh/embree")
    print(" | ".join(header))
    for scene_name in scenes:
        scene = tritrace.Scene.builtin(scene_name)
        bvh = tritrace.Accel(scene, "bvh")
        fast_embree = tritrace.Accel(scene, "embree") if embree else None
        for label, (origins, directions), coherent in (
                ("camera", camera_rays(scene, args.side), True),
                ("random", random_rays(scene, n), False)):
            ms, ms_min, ms_max = time_python(bvh, origins, directions, args.reps)
            cpp = time_cpp(scene_name, "bvh", origins, directions, args.reps, coherent)
            py_rate = n / (ms * 1e3)
            row = [scene_name, label, f"{py_rate:.1f} ({ms:.1f} ms, {ms_min:.1f}-{ms_max:.1f})",
                   f"{cpp['mrays_per_s']:.1f} ({cpp['median_ms']:.1f} ms)",
                   f"{py_rate / cpp['mrays_per_s']:.3f}"]
            if fast_embree:
                ems, _, _ = time_python(fast_embree, origins, directions, args.reps)
                e_rate = n / (ems * 1e3)
                row += [f"{e_rate:.1f} ({ems:.1f} ms)", f"{py_rate / e_rate:.2f}x"]
            print(" | ".join(row), flush=True)
        lab = lab_bench(scene_name, args.side, args.reps)
        print(f"{scene_name} | tritrace bench (lab frame {args.side}x{args.side}, primary + "
              f"shadow rays, shading) | {lab['mrays_per_s']:.1f} Mrays/s "
              f"({lab['frame_ms_median']:.1f} ms)", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
