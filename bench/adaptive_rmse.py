#!/usr/bin/env python3
"""Adaptive sampling (--noise-threshold) against uniform sampling at equal wall time.

For each scene: a long uniform reference render, then adaptive renders (threshold T, --spp the
most) and uniform renders, alternating, each timed by the render's own summary line (render time
only, no load or accel build). RMSE is over all pixels and channels of the linear radiance
against the reference; uniform's RMSE is also scaled to the adaptive render's time as
RMSE x sqrt(t_uniform / t_adaptive) (Monte Carlo error falls as 1 / sqrt(time)), by the render
time of the summary line and by the process's CPU time (steadier on a shared machine). Each
configuration ends with the medians of its rounds.

With --ref-halves the reference is two renders of --ref-spp / 2 samples each (seeds 99 and 98),
averaged; half their squared difference per pixel, halved again, estimates the variance of the
averaged reference, whose mean is then subtracted from each MSE (E[(x - ref)^2] = E[(x - truth)^2]
+ Var(ref) when x and ref are independent). The ratios are printed with and without it.

Usage: bench/adaptive_rmse.py TRITRACE [--size 128] [--ref-spp 8192] [--rounds 2]
       [--integrator bdpt] [--ref-integrator path] [--ref-halves]
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


def rmse(a, b, ref_var=0.0):
    """RMSE against the reference b; ref_var, the reference's own mean variance per value, is
    taken off the MSE first (see --ref-halves)."""
    return math.sqrt(max(sum((x - y) ** 2 for x, y in zip(a, b)) / len(a) - ref_var, 0.0))


def srgb(v):
    v = min(max(v, 0.0), 1.0)
    return 12.92 * v if v <= 0.0031308 else 1.055 * v ** (1 / 2.4) - 0.055


def display_rmse(a, b):
    """RMSE of the 8-bit PNG's values (clamped to [0, 1], sRGB curve), on a 0..1 scale: the
    error a viewer of the PNG sees (a light's pixels at 9.4 or 9.7 both show white)."""
    return math.sqrt(sum((srgb(x) - srgb(y)) ** 2 for x, y in zip(a, b)) / len(a))


def relmse(a, ref, ref_rel_var=0.0):
    """Relative MSE, mean of (x - r)^2 / (r^2 + 0.01): the error relative to each pixel's value
    (the denoiser tables' measure), which weights dark pixels as the noise threshold does.
    ref_rel_var: the reference's own variance in the same weighting, taken off."""
    return sum((x - r) ** 2 / (r * r + 0.01) for x, r in zip(a, ref)) / len(a) - ref_rel_var


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
    p.add_argument("--ref-halves", action="store_true",
                   help="reference from two half-spp renders; subtract its estimated noise")
    p.add_argument("--configs", default="glass:0.05:1024:128,cornell-area:0.05:1024:128",
                   help="scene:threshold:max_spp:uniform_spp,...")
    a = p.parse_args()
    tmp = tempfile.mkdtemp()
    if a.ref_dir:
        os.makedirs(a.ref_dir, exist_ok=True)
    chosen = ["--integrator", a.integrator] if a.integrator else []
    ref_chosen = ["--integrator", a.ref_integrator] if a.ref_integrator else []
    for config in a.configs.split(","):
        scene, t, most, uni = config.split(":")
        ref_var = ref_rel_var = 0.0
        if a.ref_halves:
            halves = []
            for half, seed in (("a", "99"), ("b", "98")):
                path = os.path.join(a.ref_dir or tmp, "%s_ref_%s.pfm" % (scene, half))
                if not os.path.exists(path):
                    ms, _, _, cmd = render(a.tritrace, scene, a.size,
                                           ["--spp", str(a.ref_spp // 2), "--seed", seed,
                                            *ref_chosen], path)
                    print("reference half: %s (%.0f ms)" % (cmd, ms))
                halves.append(read_pfm(path))
            ref = array.array("f", ((x + y) / 2 for x, y in zip(*halves)))
            # Var(one half) ~ (x - y)^2 / 2 per value; the average of two has half of that.
            pixel_var = [(x - y) ** 2 / 4 for x, y in zip(*halves)]
            ref_var = sum(pixel_var) / len(ref)
            ref_rel_var = sum(v / (r * r + 0.01) for v, r in zip(pixel_var, ref)) / len(ref)
            print("%s reference: %d spp in two halves, its own RMSE ~ %.5f, relMSE ~ %.3g "
                  "(taken off every MSE below)" % (scene, a.ref_spp, math.sqrt(ref_var),
                                                  ref_rel_var))
        else:
            ref_path = os.path.join(a.ref_dir or tmp, scene + "_ref.pfm")
            if not os.path.exists(ref_path):
                ms, _, _, cmd = render(a.tritrace, scene, a.size,
                                       ["--spp", str(a.ref_spp), "--seed", "99", *ref_chosen],
                                       ref_path)
                print("reference: %s (%.0f ms)" % (cmd, ms))
            ref = read_pfm(ref_path)
        ratios, cpu_ratios, raw_cpu_ratios, mean_diffs, uniform_diffs = [], [], [], [], []
        rel_ratios, spps = [], []
        ref_mean = sum(ref) / len(ref)
        for r in range(a.rounds):
            seed = str(r + 1 + a.first_seed)
            out = os.path.join(tmp, "x.pfm")
            ta, ca, mean, cmd_a = render(a.tritrace, scene, a.size,
                                         ["--spp", most, "--noise-threshold", t, "--seed", seed,
                                          *chosen], out)
            img = read_pfm(out)
            ea, ra, da = rmse(img, ref, ref_var), relmse(img, ref, ref_rel_var), display_rmse(img, ref)
            ea_raw = rmse(img, ref)
            mean_diffs.append(sum(img) / len(img) - ref_mean)
            tu, cu, _, cmd_u = render(a.tritrace, scene, a.size,
                                      ["--spp", uni, "--seed", seed, *chosen], out)
            img = read_pfm(out)
            eu, ru, du = rmse(img, ref, ref_var), relmse(img, ref, ref_rel_var), display_rmse(img, ref)
            eu_raw = rmse(img, ref)
            uniform_diffs.append(sum(img) / len(img) - ref_mean)
            # At equal time: RMSE scales as 1 / sqrt(time), relMSE (a squared error) as 1 / time.
            eu_eq, ru_eq, du_eq = eu * math.sqrt(tu / ta), ru * tu / ta, du * math.sqrt(tu / ta)
            cpu_ratio = ea / (eu * math.sqrt(cu / ca))
            ratios.append(ea / eu_eq)
            cpu_ratios.append(cpu_ratio)
            raw_cpu_ratios.append(ea_raw / (eu_raw * math.sqrt(cu / ca)))
            rel_ratios.append(ra / (ru * cu / ca))
            spps.append(mean)
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
        print("%s T=%s: CPU-time ratios: RMSE %.2f (range %.2f-%.2f; %.2f with the reference's "
              "noise left in), relMSE %.2f (range %.2f-%.2f), mean spp %.1f"
              % (scene, t, statistics.median(cpu_ratios), min(cpu_ratios), max(cpu_ratios),
                 statistics.median(raw_cpu_ratios), statistics.median(rel_ratios),
                 min(rel_ratios), max(rel_ratios),
                 statistics.mean(x for x in spps if x is not None) if any(spps) else 0.0))
        if a.rounds > 1:
            # Bias check: the images' mean minus the reference's, against the standard error of
            # that mean over the rounds (seeds), for adaptive and, as a control, uniform sampling
            # (a heavy-tailed scene's low-spp images fall short of the mean most of the time, and
            # a few seeds then understate the standard error, for both).
            # With --ref-halves the reference's mean is itself uncertain: its variance is the
            # sum of the pixels' variances over the number of values squared (pixels taken as
            # independent), added to the seeds' in the last figure.
            ref_mean_var = ref_var / len(ref)
            for name, diffs in (("adaptive", mean_diffs), ("uniform", uniform_diffs)):
                d = statistics.mean(diffs)
                se = statistics.stdev(diffs) / math.sqrt(len(diffs))
                se_all = math.sqrt(se * se + ref_mean_var)
                print("%s T=%s: %s image mean - reference mean = %.3g (%.3g%%; reference %.5g), "
                      "standard error over seeds %.2g, %.1f standard errors (%.1f with the "
                      "reference's own, %.2g)"
                      % (scene, t, name, d, 100.0 * d / ref_mean, ref_mean, se,
                         abs(d) / se if se > 0 else 0.0, abs(d) / se_all if se_all > 0 else 0.0,
                         math.sqrt(ref_mean_var)))
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
