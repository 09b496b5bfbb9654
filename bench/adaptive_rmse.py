#!/usr/bin/env python3
"""Adaptive sampling (--noise-threshold) against uniform sampling at equal wall time.

For each scene: a long uniform reference render, then adaptive renders (threshold T, --spp the
most) and uniform renders, alternating, each timed by the render's own summary line (render time
only, no load or accel build). RMSE is over all pixels and channels of the linear radiance
against the reference; uniform's RMSE is also scaled to the adaptive render's time as
RMSE x sqrt(t_uniform / t_adaptive) (Monte Carlo error falls as 1 / sqrt(time)), by the render
time of the summary line and by the process's CPU time (steadier on a shared machine). Each
configuration ends with the medians of its rounds.

Usage: bench/adaptive_rmse.py TRITRACE [--size 128] [--ref-spp 8192] [--rounds 2]
       [--integrator bdpt] [--ref-integrator path]
No NumPy: PFM files are read with the standard library.
"""
import argparse
import array
import math
import os
import re
import statistics
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
SCENES = {
    "glass": ["%s/../scenes/glass.json" % HERE],
    "cornell-area": ["--scene", "cornell-area", "--integrator", "path"],
}


def read_pfm(path):
    with open(path, "rb") as f:
        kind = f.readline().strip()
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        data = array.array("f")
        data.frombytes(f.read())
    if scale > 0:
        data.byteswap()
    assert kind == b"PF" and len(data) == w * h * 3
    return data


def rmse(a, b):
    return math.sqrt(sum((x - y) ** 2 for x, y in zip(a, b)) / len(a))


def srgb(v):
    v = min(max(v, 0.0), 1.0)
    return 12.92 * v if v <= 0.0031308 else 1.055 * v ** (1 / 2.4) - 0.055


def display_rmse(a, b):
    """RMSE of the 8-bit PNG's values (clamped to [0, 1], sRGB curve), on a 0..1 scale: the
    error a viewer of the PNG sees (a light's pixels at 9.4 or 9.7 both show white)."""
    return math.sqrt(sum((srgb(x) - srgb(y)) ** 2 for x, y in zip(a, b)) / len(a))


def relmse(a, ref):
    """Relative MSE, mean of (x - r)^2 / (r^2 + 0.01): the error relative to each pixel's value
    (the denoiser tables' measure), which weights dark pixels as the noise threshold does."""
    return sum((x - r) ** 2 / (r * r + 0.01) for x, r in zip(a, ref)) / len(a)


def render(tritrace, scene, size, extra, out):
    """Runs one render: (render ms from the summary line, the process's CPU ms, mean spp or None,
    the command). CPU time (user + system of the process and its threads) is the steadier clock
    on a machine shared with other work: wall time there depends on what else runs."""
    base = list(SCENES[scene])
    if "--integrator" in extra and "--integrator" in base:  # the caller's choice replaces it
        i = base.index("--integrator")
        del base[i:i + 2]
    cmd = [tritrace, "render", *base, "--width", str(size), "--height", str(size),
           "-o", out, *extra]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, text=True)
    text = proc.stdout.read()
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        raise subprocess.CalledProcessError(proc.returncode, cmd)
    cpu_ms = (usage.ru_utime + usage.ru_stime) * 1e3
    ms = float(re.search(r" in ([0-9.]+) ms", text).group(1))
    mean = re.search(r"mean ([0-9.]+) spp", text)
    return ms, cpu_ms, (float(mean.group(1)) if mean else None), " ".join(cmd)


def main():
    p = argparse.ArgumentParser()
    p.add_argument("tritrace")
    p.add_argument("--size", type=int, default=128)
    p.add_argument("--ref-spp", type=int, default=8192)
    p.add_argument("--rounds", type=int, default=2)
    p.add_argument("--first-seed", type=int, default=0, help="round r uses seed first-seed + r + 1")
    p.add_argument("--ref-dir", default=None, help="reuse <scene>_ref.pfm from here")
    p.add_argument("--integrator", default=None,
                   help="--integrator for the adaptive and uniform renders (default: the scene's)")
    p.add_argument("--ref-integrator", default=None,
                   help="--integrator for the reference (default: the scene's)")
    p.add_argument("--configs", default="glass:0.05:1024:128,cornell-area:0.05:1024:128",
                   help="scene:threshold:max_spp:uniform_spp,...")
    a = p.parse_args()
    tmp = tempfile.mkdtemp()
    chosen = ["--integrator", a.integrator] if a.integrator else []
    ref_chosen = ["--integrator", a.ref_integrator] if a.ref_integrator else []
    for config in a.configs.split(","):
        scene, t, most, uni = config.split(":")
        ref_path = os.path.join(a.ref_dir or tmp, scene + "_ref.pfm")
        if not os.path.exists(ref_path):
            ms, _, _, cmd = render(a.tritrace, scene, a.size,
                                   ["--spp", str(a.ref_spp), "--seed", "99", *ref_chosen],
                                   ref_path)
            print("reference: %s (%.0f ms)" % (cmd, ms))
        ref = read_pfm(ref_path)
        ratios, cpu_ratios, mean_diffs, uniform_diffs = [], [], [], []
        ref_mean = sum(ref) / len(ref)
        for r in range(a.rounds):
            seed = str(r + 1 + a.first_seed)
            out = os.path.join(tmp, "x.pfm")
            ta, ca, mean, cmd_a = render(a.tritrace, scene, a.size,
                                         ["--spp", most, "--noise-threshold", t, "--seed", seed,
                                          *chosen], out)
            img = read_pfm(out)
            ea, ra, da = rmse(img, ref), relmse(img, ref), display_rmse(img, ref)
            mean_diffs.append(sum(img) / len(img) - ref_mean)
            tu, cu, _, cmd_u = render(a.tritrace, scene, a.size,
                                      ["--spp", uni, "--seed", seed, *chosen], out)
            img = read_pfm(out)
            eu, ru, du = rmse(img, ref), relmse(img, ref), display_rmse(img, ref)
            uniform_diffs.append(sum(img) / len(img) - ref_mean)
            # At equal time: RMSE scales as 1 / sqrt(time), relMSE (a squared error) as 1 / time.
            eu_eq, ru_eq, du_eq = eu * math.sqrt(tu / ta), ru * tu / ta, du * math.sqrt(tu / ta)
            cpu_ratio = ea / (eu * math.sqrt(cu / ca))
            ratios.append(ea / eu_eq)
            cpu_ratios.append(cpu_ratio)
            print("%s round %d: adaptive T=%s max %s spp: %.0f ms (CPU %.0f), mean %.1f spp, "
                  "RMSE %.5f, relMSE %.3g | uniform %s spp: %.0f ms (CPU %.0f), RMSE %.5f "
                  "(%.5f at adaptive's time), relMSE %.3g (%.3g) | RMSE ratio %.2f (CPU time "
                  "%.2f), relMSE ratio %.2f, display RMSE %.5f vs %.5f, ratio %.2f"
                  % (scene, r, t, most, ta, ca, mean, ea, ra, uni, tu, cu, eu, eu_eq, ru, ru_eq,
                     ea / eu_eq, cpu_ratio, ra / ru_eq, da, du_eq, da / du_eq))
            if r == 0:
                print("  " + cmd_a + "\n  " + cmd_u)
        print("%s T=%s: median RMSE ratio %.2f (render time), %.2f (CPU time) over %d rounds"
              % (scene, t, statistics.median(ratios), statistics.median(cpu_ratios), a.rounds))
        if a.rounds > 1:
            # Bias check: the images' mean minus the reference's, against the standard error of
            # that mean over the rounds (seeds), for adaptive and, as a control, uniform sampling
            # (a heavy-tailed scene's low-spp images fall short of the mean most of the time, and
            # a few seeds then understate the standard error, for both).
            for name, diffs in (("adaptive", mean_diffs), ("uniform", uniform_diffs)):
                d = statistics.mean(diffs)
                se = statistics.stdev(diffs) / math.sqrt(len(diffs))
                print("%s T=%s: %s image mean - reference mean = %.3g (reference %.5g), "
                      "standard error over seeds %.2g, %.1f standard errors"
                      % (scene, t, name, d, ref_mean, se, abs(d) / se if se > 0 else 0.0))
            # Adaptive minus uniform, paired by seed: free of the reference's own noise (its
            # mean is one more Monte Carlo estimate), against the spread of the differences.
            pairs = [x - y for x, y in zip(mean_diffs, uniform_diffs)]
            d = statistics.mean(pairs)
            se = statistics.stdev(pairs) / math.sqrt(len(pairs))
            print("%s T=%s: adaptive - uniform image mean, paired by seed = %.3g (%.3g%%), "
                  "standard error %.2g, %.1f standard errors"
                  % (scene, t, d, 100.0 * d / ref_mean, se, abs(d) / se if se > 0 else 0.0))
    return 0


if __name__ == "__main__":
    sys.exit(main())
