#!/usr/bin/env python3
"""The denoiser's quality against converged references (issue 24, docs/DENOISING.md).

For each scene, at 256 x 256: a reference (--ref-spp samples, a different seed from the test
renders), the noisy render at 4, 16 and 64 spp, the same renders with --denoise (what a user
runs: the denoiser uses the render's own half-buffer variance, albedo, normal and depth), and a
long noisy render (256 spp; 512 for mirror_glass) to beat. Prints a table of relative MSE
(mean over pixels and channels of (x - ref)^2 / (ref^2 + 0.01)), the image mean against the
reference's and against the noisy image's, and the fraction of 16 x 16 blocks whose mean is
within 3% of the reference's (all three channels). Writes small sRGB PNGs (noisy 16 spp,
denoised 16 spp, reference) for the docs.

With --seeds (e.g. 0-7) it also checks the cornell-area goal seed by seed: 16 spp denoised
against 256 spp not denoised, both with each --seed, the relMSE split into the pixels within 2 of
the light's boundary (the light seen directly: the reference's pixels brighter than 5, and the
pixels they touch) and the rest, and the denoised image's mean against the noisy one's.

Images are written as .pfm (trivial to read with numpy; no OpenEXR bindings needed). Renders
that already exist in --out are reused unless --force is given, so the expensive references are
rendered once.

    python3 bench/denoise_quality.py --tritrace build/tritrace --out /tmp/dq_bench \\
        --png-dir docs/images/denoise
"""
import argparse
import os
import struct
import subprocess
import sys
import time
import zlib

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# name -> (scene arguments, the long noisy spp to beat)
SCENES = {
    "cornell-area": (["--scene", "cornell-area", "--integrator", "path"], 256),
    "glass": ([os.path.join(ROOT, "scenes", "glass.json")], 256),
    "rough_metal": ([os.path.join(ROOT, "scenes", "rough_metal.json")], 256),
    "sky": ([os.path.join(ROOT, "scenes", "sky.json")], 256),
    "mirror_glass": ([os.path.join(ROOT, "scenes", "mirror_glass.json")], 512),
}
TEST_SEED = 0  # the scenes' default seed: what a user gets
REF_SEED = 7  # independent of the test renders


def read_pfm(path):
    with open(path, "rb") as f:
        kind = f.readline().strip()
        width, height = map(int, f.readline().split())
        scale = float(f.readline())
        data = np.fromfile(f, dtype="<f4" if scale < 0 else ">f4")
    channels = 3 if kind == b"PF" else 1
    # PFM rows run bottom to top.
    return data.reshape(height, width, channels)[::-1].astype(np.float64)


def write_png(path, image):
    """8-bit sRGB PNG (no exposure), written with zlib alone."""
    c = np.clip(image, 0.0, 1.0)
    srgb = np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1 / 2.4) - 0.055)
    pixels = np.round(srgb * 255.0).astype(np.uint8)
    height, width, _ = pixels.shape
    raw = b"".join(b"\x00" + pixels[y].tobytes() for y in range(height))

    def chunk(tag, body):
        return (struct.pack(">I", len(body)) + tag + body +
                struct.pack(">I", zlib.crc32(tag + body) & 0xFFFFFFFF))

    png = (b"\x89PNG\r\n\x1a\n" +
           chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)) +
           chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))
    with open(path, "wb") as f:
        f.write(png)


def rel_mse(x, ref):
    return float(np.mean((x - ref) ** 2 / (ref ** 2 + 0.01)))


def blocks_within(x, ref, tolerance=0.03, block=16):
    h, w, _ = ref.shape
    h, w = h // block * block, w // block * block

    def means(img):
        return img[:h, :w].reshape(h // block, block, w // block, block, 3).mean(axis=(1, 3))

    bx, br = means(x), means(ref)
    ok = np.abs(bx - br) <= tolerance * np.abs(br) + 1e-6
    return float(ok.all(axis=2).mean())


def render(args, tritrace, scene_args, spp, seed, out, extra=()):
    if os.path.exists(out) and not args.force:
        return 0.0
    cmd = [tritrace, "render", *scene_args, "--width", str(args.size), "--height",
           str(args.size), "--spp", str(spp), "--seed", str(seed), "-q", "-o", out, *extra]
    if args.threads:
        cmd += ["--threads", str(args.threads)]
    print("  " + " ".join(cmd), file=sys.stderr, flush=True)
    start = time.monotonic()
    subprocess.run(cmd, check=True)
    return time.monotonic() - start


def dilate(mask, steps):
    for _ in range(steps):
        grown = mask.copy()
        grown[1:] |= mask[:-1]
        grown[:-1] |= mask[1:]
        grown[:, 1:] |= mask[:, :-1]
        grown[:, :-1] |= mask[:, 1:]
        mask = grown
    return mask


def seed_table(args):
    """The cornell-area goal per seed, with the relMSE split at the light's boundary."""
    first, _, last = args.seeds.partition("-")
    seeds = range(int(first), int(last or first) + 1)
    scene_args, _ = SCENES["cornell-area"]
    path = lambda tag: os.path.join(args.out, f"cornell-area_{tag}.pfm")  # noqa: E731
    render(args, args.tritrace, scene_args, args.ref_spp, REF_SEED, path(f"ref{args.ref_spp}"))
    ref = read_pfm(path(f"ref{args.ref_spp}"))
    light = ref.mean(axis=2) > 5.0
    boundary = dilate(light, 2) & ~(light & ~dilate(~light, 2))
    print("| seed | 16 spp denoised | of which within 2 px of the light's boundary | rest "
          "| 256 spp not denoised | of which at the boundary | goal | denoised mean / noisy mean |")
    print("|---|---|---|---|---|---|---|---|")
    met = 0
    for seed in seeds:
        render(args, args.tritrace, scene_args, 16, seed, path(f"s{seed}_16"))
        render(args, args.tritrace, scene_args, 16, seed, path(f"s{seed}_16d"), ["--denoise"])
        render(args, args.tritrace, scene_args, 256, seed, path(f"s{seed}_256"))
        noisy, den, long_img = (read_pfm(path(f"s{seed}_{t}")) for t in ("16", "16d", "256"))
        e_den = ((den - ref) ** 2 / (ref ** 2 + 0.01)).mean(axis=2)
        e_long = ((long_img - ref) ** 2 / (ref ** 2 + 0.01)).mean(axis=2)
        n = e_den.size
        ok = e_den.mean() < e_long.mean()
        met += ok
        print(f"| {seed} | {e_den.mean():.6f} | {e_den[boundary].sum() / n:.6f} "
              f"| {e_den[~boundary].sum() / n:.6f} | {e_long.mean():.6f} "
              f"| {e_long[boundary].sum() / n:.6f} | {'met' if ok else 'missed'} "
              f"| {den.mean() / noisy.mean():.5f} |")
    print(f"\ngoal met on {met} of {len(seeds)} seeds ({int(boundary.sum())} boundary pixels)\n")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tritrace", default=os.path.join(ROOT, "build", "tritrace"))
    parser.add_argument("--out", default="/tmp/tritrace_denoise_quality")
    parser.add_argument("--scenes", default="cornell-area,glass,rough_metal,mirror_glass",
                        help="comma-separated, from: " + ", ".join(SCENES))
    parser.add_argument("--spps", default="4,16,64")
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--ref-spp", type=int, default=4096)
    parser.add_argument("--threads", type=int, default=0)
    parser.add_argument("--png-dir", default="", help="write noisy/denoised/reference PNGs here")
    parser.add_argument("--force", action="store_true", help="render again what exists")
    parser.add_argument("--seeds", default="",
                        help="also the cornell-area goal per seed, e.g. 0-7 (renders 16 spp "
                        "denoised and 256 spp per seed)")
    parser.add_argument("--only-seeds", action="store_true",
                        help="with --seeds: skip the scene table")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    spps = [int(s) for s in args.spps.split(",")]

    if args.seeds:
        seed_table(args)
        if args.only_seeds:
            return
    rows = []
    for name in args.scenes.split(","):
        scene_args, long_spp = SCENES[name]
        print(f"{name}:", file=sys.stderr, flush=True)
        path = lambda tag: os.path.join(args.out, f"{name}_{tag}.pfm")  # noqa: E731
        render(args, args.tritrace, scene_args, args.ref_spp, REF_SEED, path(f"ref{args.ref_spp}"))
        ref = read_pfm(path(f"ref{args.ref_spp}"))
        for spp in spps:
            render(args, args.tritrace, scene_args, spp, TEST_SEED, path(f"{spp}"))
            render(args, args.tritrace, scene_args, spp, TEST_SEED, path(f"{spp}d"), ["--denoise"])
            noisy, den = read_pfm(path(f"{spp}")), read_pfm(path(f"{spp}d"))
            rows.append((name, spp, rel_mse(noisy, ref), rel_mse(den, ref),
                         den.mean() / noisy.mean(), den.mean() / ref.mean(),
                         blocks_within(noisy, ref), blocks_within(den, ref)))
        render(args, args.tritrace, scene_args, long_spp, TEST_SEED, path(f"{long_spp}"))
        long_img = read_pfm(path(f"{long_spp}"))
        rows.append((name, long_spp, rel_mse(long_img, ref), None, None,
                     long_img.mean() / ref.mean(), blocks_within(long_img, ref), None))
        if args.png_dir:
            os.makedirs(args.png_dir, exist_ok=True)
            for tag, img in (("16", read_pfm(path("16"))), ("16d", read_pfm(path("16d"))),
                             ("ref", ref)):
                write_png(os.path.join(args.png_dir, f"{name}_{tag}.png"), img)

    print(f"| scene | spp | noisy relMSE | denoised relMSE | denoised mean / noisy mean "
          f"| denoised mean / reference mean | 16x16 blocks within 3%: noisy | denoised |")
    print("|---|---|---|---|---|---|---|---|")
    fmt = lambda v, f: "" if v is None else format(v, f)  # noqa: E731
    for name, spp, rn, rd, mn, mr, bn, bd in rows:
        print(f"| {name} | {spp}{'' if rd is not None else ' (not denoised)'} | {rn:.6f} "
              f"| {fmt(rd, '.6f')} | {fmt(mn, '.4f')} | {mr:.4f} | {bn:.3f} | {fmt(bd, '.3f')} |")


if __name__ == "__main__":
    main()
