#!/usr/bin/env python3
"""How much any per-pixel allocation of samples can gain over uniform sampling (issue 24).

An adaptive rule that must not read a pixel's own samples can only move samples between pixels.
This script measures what the best such move would give, with far better information than a
pilot: each pixel's per-sample variance from two 1024-spp renders with the independent sampler
(--aovs variance, other seeds), and each pixel's actual error at 256 spp with the default Sobol
sampler (six seeds, against the reference). Under the model error_i(n) = e_i * 256 / n (Monte
Carlo's 1/n) an allocation n_i (mean n) gives MSE ratio mean(e_i / n_i) / mean(e_i) with n_i
normalised to mean 1; the allocation is n_i proportional to (the variance averaged over the
(2r+1)^2 pixels around it)^(alpha/2), at least a share of the mean. The best over r, alpha and the
share is printed, and, as a check, the allocation from three seeds' error maps applied to the
other three's. RMSE ratios below are square roots.

Usage: PYTHONPATH=build/python bench/adaptive_bound.py build/tritrace --ref-dir ref [--size 96]
(needs NumPy; the references are adaptive_rmse.py's, <scene>_ref.pfm.)
"""
import argparse
import os
import subprocess
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tests", "python"))
from conftest import read_exr, read_pfm  # noqa: E402

SCENES = {
    "glass": ["%s/../scenes/glass.json" % HERE],
    "cornell-area": ["--scene", "cornell-area", "--integrator", "path"],
}


def box(a, r):
    if r == 0:
        return a
    p = np.pad(a, r, mode="edge")
    out = np.zeros_like(a)
    for dy in range(-r, r + 1):
        for dx in range(-r, r + 1):
            out += p[r + dy:r + dy + a.shape[0], r + dx:r + dx + a.shape[1]]
    return out / (2 * r + 1) ** 2


def main():
    p = argparse.ArgumentParser()
    p.add_argument("tritrace")
    p.add_argument("--size", type=int, default=96)
    p.add_argument("--ref-dir", required=True)
    a = p.parse_args()
    tmp = tempfile.mkdtemp()
    for scene, args in SCENES.items():
        def render(extra, out):
            subprocess.run([a.tritrace, "render", *args, "--width", str(a.size), "--height",
                            str(a.size), "-q", "-o", out, *extra], check=True)
        ref = read_pfm(os.path.join(a.ref_dir, scene + "_ref.pfm"))
        variance = 0.0
        for seed in (7, 8):
            out = os.path.join(tmp, "v.exr")
            render(["--spp", "1024", "--sampler", "independent", "--seed", str(seed), "--aovs",
                    "variance"], out)
            ch = read_exr(out)
            variance = variance + 512 * sum(ch["variance." + c] for c in "RGB")
        errors = []
        for seed in range(11, 17):
            out = os.path.join(tmp, "u.pfm")
            render(["--spp", "256", "--seed", str(seed)], out)
            errors.append(((read_pfm(out) - ref) ** 2).sum(-1))
        e = np.mean(errors, 0)
        best = []
        for r in (0, 1, 2, 3, 5):
            for alpha in (0.25, 0.5, 0.75, 1.0):
                for share in (0.25, 0.5, 0.75):
                    n = box(variance, r) ** (alpha / 2)
                    n = np.maximum(n / n.mean(), share)
                    n /= n.mean()
                    best.append((np.sqrt((e / n).mean() / e.mean()), r, alpha, share))
        best.sort()
        print("%s: best allocation from the variance, RMSE ratio %.3f (r %d, n ~ sigma^%.2f, "
              "at least %.2f of the mean); n ~ sigma (alpha 1), r 2, share 0.5: %.3f"
              % (scene, *best[0], [b[0] for b in best if b[1:] == (2, 1.0, 0.5)][0]))
        half_a, half_b = np.mean(errors[:3], 0), np.mean(errors[3:], 0)
        n = np.sqrt(box(half_a, 2))
        n = np.maximum(n / n.mean(), 0.25)
        n /= n.mean()
        print("%s: allocation from three seeds' error maps (r 2) on the other three's: %.3f"
              % (scene, np.sqrt((half_b / n).mean() / half_b.mean())))
    return 0


if __name__ == "__main__":
    sys.exit(main())
