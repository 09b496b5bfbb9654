#!/usr/bin/env python3
"""tritrace against pbrt-v4 on the same scene: path and bdpt, equal spp, equal threads.

  bench/pbrt/side_by_side.py --pbrt /path/to/pbrt [--scene cornell-area] [--rounds 3]
      [--threads 2] [--size 256] [--path-spp 256] [--bdpt-spp 64 [--bdpt-spp 256]]
      [--maxdepth 5] [--out-dir DIR]

pbrt-v4 is not part of tritrace and CI never runs this script. Build pbrt (CPU only) with
bench/pbrt/build_pbrt.sh (see its header), then pass the binary with --pbrt or $PBRT.

What it does:
1. Writes the scene as pbrt-v4 files (json_to_pbrt.py: path and bdpt, the same max depth, box
   filter of radius 0.5, zsobol sampler) and checks that tritrace renders the written file as the
   scene itself (byte for byte for cornell-area; image means within 1e-4 for scene files, whose OBJ
   vertices are transformed in double here and in float in tritrace), so the two renderers get the
   same triangles, materials, light and camera.
2. Renders each configuration (pbrt path, tritrace path, pbrt bdpt, tritrace bdpt at each
   --bdpt-spp) once per round, the order reversed every other round, each process timed alone:
   wall time and CPU time (user + system of the process, from wait4).
3. Prints medians, the ratios pbrt / tritrace, and the images' agreement: per-channel means and
   Rec. 709 luminance, and the 16 x 16 block means' relative differences, pbrt against tritrace.
"""

import argparse
import array
import os
import shutil
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
BUILD_HINT = ("build pbrt-v4 with bench/pbrt/build_pbrt.sh and pass its binary with --pbrt or "
              "$PBRT")


def die(message):
    sys.exit("side_by_side.py: " + message)


def read_pfm(path):
    """(width, height, rows top to bottom of [r, g, b, r, g, b, ...]) from a colour PFM."""
    with open(path, "rb") as f:
        kind = f.readline().strip()
        width, height = (int(t) for t in f.readline().split())
        scale = float(f.readline())
        data = array.array("f")
        data.frombytes(f.read())
    if kind != b"PF" or len(data) != 3 * width * height:
        die("%s: not a colour PFM of %d x %d" % (path, width, height))
    if (scale < 0) != (sys.byteorder == "little"):
        data.byteswap()
    rows = [data[3 * width * y:3 * width * (y + 1)] for y in range(height)]
    return width, height, rows[::-1]  # PFM stores the bottom row first


def channel_means(image):
    width, height, rows = image
    sums = [0.0, 0.0, 0.0]
    for row in rows:
        for c in range(3):
            sums[c] += sum(row[c::3])
    return [s / (width * height) for s in sums]


def luminance(rgb):
    return 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]


def block_luminances(image, block=16):
    width, height, rows = image
    out = []
    for by in range(0, height - block + 1, block):
        for bx in range(0, width - block + 1, block):
            s = [0.0, 0.0, 0.0]
            for y in range(by, by + block):
                row = rows[y]
                for c in range(3):
                    s[c] += sum(row[3 * bx + c:3 * (bx + block):3])
            out.append(luminance(s) / (block * block))
    return out


def run_timed(cmd, log):
    """(wall seconds, CPU seconds) of one process run to completion; exits on failure."""
    with open(log, "w") as out:
        start = time.perf_counter()
        proc = subprocess.Popen(cmd, stdout=out, stderr=subprocess.STDOUT)
        _, status, usage = os.wait4(proc.pid, 0)
        wall = time.perf_counter() - start
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        die("%s failed (exit %d), see %s" % (" ".join(cmd), proc.returncode, log))
    return wall, usage.ru_utime + usage.ru_stime


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--pbrt", default=os.environ.get("PBRT"),
                   help="pbrt-v4's pbrt binary (default: $PBRT)")
    p.add_argument("--tritrace", default=os.path.join(REPO, "build", "tritrace"))
    p.add_argument("--scene", default="cornell-area",
                   help="cornell-area or a tritrace .json scene file (scenes/caustics.json)")
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--size", type=int, default=256, help="image width and height")
    p.add_argument("--path-spp", type=int, default=256, help="0: no path renders")
    p.add_argument("--bdpt-spp", type=int, action="append",
                   help="repeatable; default 64; 0: no bdpt renders")
    p.add_argument("--maxdepth", type=int, default=5,
                   help="both renderers (pbrt's bdpt has no Russian roulette, so not 1024)")
    p.add_argument("--grey", action="store_true", help="diffuse albedos replaced by their mean")
    p.add_argument("--out-dir", default="pbrt_side_by_side")
    args = p.parse_args()
    if not args.pbrt:
        die("no pbrt binary given: " + BUILD_HINT)
    if not (os.path.isfile(args.pbrt) and os.access(args.pbrt, os.X_OK)):
        die("--pbrt %s: not an executable file; %s" % (args.pbrt, BUILD_HINT))
    if not (os.path.isfile(args.tritrace) and os.access(args.tritrace, os.X_OK)):
        die("--tritrace %s: not an executable file (cmake --build build --target tritrace_cli)" %
            args.tritrace)
    if args.rounds < 1 or args.threads < 1 or args.size < 16 or args.path_spp < 0:
        die("--rounds and --threads must be at least 1, --size at least 16, --path-spp at least 0")
    bdpt_spp = [s for s in (args.bdpt_spp or [64]) if s > 0]
    if args.path_spp == 0 and not bdpt_spp:
        die("nothing to render: --path-spp 0 and no --bdpt-spp above 0")
    os.makedirs(args.out_dir, exist_ok=True)
    out = os.path.abspath(args.out_dir)
    tt = os.path.abspath(args.tritrace)
    scene_arg = args.scene if args.scene == "cornell-area" else os.path.abspath(args.scene)

    def tritrace_scene():
        return ["--scene", "cornell-area"] if args.scene == "cornell-area" else [scene_arg]

    # 1. The pbrt files, and tritrace's reading of them against the scene itself.
    configs = []  # (label, renderer, integrator, spp)
    if args.path_spp > 0:
        configs += [("path", "pbrt", "path", args.path_spp), ("path", "tritrace", "path",
                                                               args.path_spp)]
    for spp in bdpt_spp:
        configs += [("bdpt", "pbrt", "bdpt", spp), ("bdpt", "tritrace", "bdpt", spp)]
    pbrt_files = {}
    for _, renderer, integ, spp in configs:
        if renderer != "pbrt":
            continue
        name = os.path.join(out, "%s_%d.pbrt" % (integ, spp))
        cmd = [sys.executable, os.path.join(HERE, "json_to_pbrt.py"), scene_arg, name,
               "--integrator", integ, "--maxdepth", str(args.maxdepth), "--spp", str(spp),
               "--width", str(args.size), "--height", str(args.size)]
        subprocess.run(cmd + (["--grey"] if args.grey else []), check=True)
        pbrt_files[(integ, spp)] = name
    if not args.grey:
        check = os.path.join(out, "check.pbrt")
        subprocess.run([sys.executable, os.path.join(HERE, "json_to_pbrt.py"), scene_arg, check,
                        "--spp", "4", "--maxdepth", str(args.maxdepth), "--width", "64",
                        "--height", "64"], check=True)
        common = ["--width", "64", "--height", "64", "--spp", "4", "--max-depth",
                  str(args.maxdepth), "--integrator", "path", "--threads", str(args.threads), "-q"]
        a, b = os.path.join(out, "check_scene.pfm"), os.path.join(out, "check_file.pfm")
        subprocess.run([tt, "render"] + tritrace_scene() + common + ["-o", a], check=True)
        subprocess.run([tt, "render", check] + common + ["-o", b], check=True)
        with open(a, "rb") as fa, open(b, "rb") as fb:
            same = fa.read() == fb.read()
        ma, mb = luminance(channel_means(read_pfm(a))), luminance(channel_means(read_pfm(b)))
        drift = abs(ma - mb) / ma
        if args.scene == "cornell-area" and not same or drift > 1e-4:
            die("the written pbrt file is not tritrace's scene any more (tritrace renders it with "
                "luminance %.6g against %.6g): update json_to_pbrt.py" % (mb, ma))
        print("scene check: tritrace renders the written .pbrt file %s" %
              ("byte for byte as the scene" if same else
               "with mean luminance within %.1e of the scene's" % drift))

    # 2. Alternating timed rounds.
    times = {c: [] for c in configs}
    images = {}
    for r in range(args.rounds):
        order = configs if r % 2 == 0 else configs[::-1]
        for c in order:
            label, renderer, integ, spp = c
            image = os.path.join(out, "%s_%s_%d.pfm" % (renderer, integ, spp))
            log = os.path.join(out, "%s_%s_%d.log" % (renderer, integ, spp))
            if renderer == "pbrt":
                cmd = [args.pbrt, "--nthreads", str(args.threads), "--outfile", image,
                       pbrt_files[(integ, spp)]]
            else:
                scene = tritrace_scene() if not args.grey else [pbrt_files[(integ, spp)]]
                cmd = [tt, "render"] + scene + [
                    "--integrator", integ, "--spp", str(spp), "--width", str(args.size),
                    "--height", str(args.size), "--max-depth", str(args.maxdepth), "--threads",
                    str(args.threads), "-q", "-o", image]
            wall, cpu = run_timed(cmd, log)
            times[c].append((wall, cpu))
            images[c] = image
            print("round %d  %-8s %-4s %4d spp  wall %8.2f s  cpu %8.2f s" %
                  (r + 1, renderer, integ, spp, wall, cpu), flush=True)

    # 3. Medians, ratios and image agreement.
    try:
        load = os.getloadavg()
    except OSError:
        load = (float("nan"),) * 3
    print("\n%s, %d x %d, max depth %d, %d threads, %d rounds (load average now %.1f %.1f %.1f)" %
          (args.scene + (" (grey)" if args.grey else ""), args.size, args.size, args.maxdepth,
           args.threads, args.rounds, *load))
    print("| integrator | spp | pbrt wall s | tritrace wall s | wall ratio | pbrt CPU s | "
          "tritrace CPU s | CPU ratio |")
    print("|---|---|---|---|---|---|---|---|")
    for i in range(0, len(configs), 2):
        pc, tc = configs[i], configs[i + 1]
        pw = statistics.median(t[0] for t in times[pc])
        tw = statistics.median(t[0] for t in times[tc])
        pu = statistics.median(t[1] for t in times[pc])
        tu = statistics.median(t[1] for t in times[tc])
        print("| %s | %d | %.2f | %.2f | %.2fx | %.2f | %.2f | %.2fx |" %
              (pc[2], pc[3], pw, tw, pw / tw, pu, tu, pu / tu))
    print("\nimage agreement (pbrt against tritrace, the last round's images):")
    for i in range(0, len(configs), 2):
        pc, tc = configs[i], configs[i + 1]
        pi, ti = read_pfm(images[pc]), read_pfm(images[tc])
        pm, tm = channel_means(pi), channel_means(ti)
        pb, tb = block_luminances(pi), block_luminances(ti)
        rel = sorted(abs(x - y) / y for x, y in zip(pb, tb) if y > 0)
        print("  %s %d spp: means pbrt (%.5f %.5f %.5f) tritrace (%.5f %.5f %.5f); luminance "
              "%.5f / %.5f = %.4f; per channel %s; 16x16 block luminance |diff|: median %.2f%%, "
              "99th percentile %.2f%%, max %.2f%% (%d blocks)" %
              (pc[2], pc[3], *pm, *tm, luminance(pm), luminance(tm), luminance(pm) / luminance(tm),
               " ".join("%.4f" % (x / y) for x, y in zip(pm, tm)),
               100 * statistics.median(rel), 100 * rel[int(0.99 * (len(rel) - 1))],
               100 * rel[-1], len(rel)))


if __name__ == "__main__":
    main()
