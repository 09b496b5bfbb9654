#!/usr/bin/env python3
"""bdpt against path at equal CPU time, with the error split by image region (issue 25).

For each scene:
  Also the split of the equal-time ratio: MSE ratio = c (cost) x m (bdpt's MSE per sample over
  path's, equal spp) x g (path's error falling faster than 1 / spp: the Sobol sampler).
  1. A converged reference: path at --ref-spp, rendered as two halves with seeds distinct from the
     test seeds (--ref-seed and --ref-seed + 1). The reference is their mean; its own noise (RMS
     over pixels and channels) is RMS(half1 - half2) / 2, and the script prints it beside the
     smallest RMSE it compares, which it must be well under.
  2. Calibration: bdpt and path at the largest --bdpt-spp, first seed, --threads 1; the ratio of
     their CPU times is the cost of a bdpt sample in path samples, c.
  3. For each seed and each bdpt spp B: bdpt at B, path at round(B c) (the equal-time pair) and
     path at B (equal spp), alternated, each with --threads 1 and its CPU time (user + sys of the
     child process, from getrusage), each RMSE over all pixels and channels of the linear PFM
     against the reference. The statistics line gives rays per sample.
  4. Medians over seeds. Two equal-time ratios: the pair's RMSE ratio (their CPU times are printed
     to show how equal they came out), and RMSE x sqrt(CPU time), bdpt's over path's at B c.
  5. Regions, from renders of the scene's own camera with --max-depth 0 (emitters the camera sees
     directly) and, for scenes with glass, with the glass made a blue emitter: "emitter" (pixels
     that see an emitter directly, even in part), "glass" (pixels that see the glass, even in part:
     everything seen through it, including the caustic seen through it, the specular-diffuse-
     specular paths), "caustic" (the remaining pixels that are more than 25% brighter in the
     reference than in a path render of the scene without its glass objects: diffuse surfaces
     seen directly that get light focused by the glass) and "rest". Each region's share of each
     integrator's squared error, and its RMSE ratio, in the equal-time pair.
  6. The k pixels (1, 5, 20, 100) with the largest squared error in bdpt's render of the pair:
     their share of its squared error, their MSE in bdpt's render over path's at equal spp, and
     their regions (a few pixels holding much of the error, at a per-sample ratio near 1, are a
     part that bdpt's strategies do not sample better than path's).

--light-paths F [F ...] (default 1) measures bdpt with a light subpath in the share F of its
samples (`tritrace render --light-paths F`), each F as its own bdpt with its own cost c, beside
the same path renders (all alternated in one loop over seeds); the tables are printed per F. F may
be `auto` (`--light-paths auto`: the pilot's choice, its cost included in bdpt's CPU time).

--ref-cache DIR keeps the reference and region renders (path only, keyed by the scene file's
contents) between runs, and --ref-only fills it and stops, so that the timed runs of another build
need not render them again. --sampler independent makes the timed renders plain Monte Carlo (the
split's m without the Sobol sampler's stratification; the reference stays sobol).

Usage:
  bench/bdpt_equal_time.py build/tritrace --size 48 --seeds 1 2 3 --bdpt-spp 64 256 1024 \
      --scenes cornell-area scenes/glass.json scenes/caustics.json --out /tmp/bdpt_eq
A scene is `cornell-area` (built in) or a .json file; in a scene file the materials named in
--glass (default: every dielectric) are the glass. Needs NumPy. Writes PNGs (reference, path and
bdpt of the equal-time pair at the largest B, regions) and results.json under --out.
"""
import argparse
import json
import os
import re
import resource
import statistics
import struct
import subprocess
import sys
import zlib

import numpy as np

STATS = re.compile(r"\(([\d.]+) Mpaths/s, ([\d.]+) Mrays/s")
CHOSE = re.compile(r"--light-paths auto chose ([\d.e+-]+)")


def read_pfm(path):
    with open(path, "rb") as f:
        assert f.readline().strip() == b"PF"
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        data = np.frombuffer(f.read(), dtype="<f4" if scale < 0 else ">f4")
    return data.reshape(h, w, 3)[::-1].astype(np.float64)  # PFM rows run bottom to top


def write_png(path, img, zoom=3):
    """Linear RGB -> sRGB 8-bit PNG, each pixel zoom x zoom (standard library only)."""
    v = np.clip(img, 0.0, 1.0)
    v = np.where(v <= 0.0031308, 12.92 * v, 1.055 * v ** (1 / 2.4) - 0.055)
    v = np.repeat(np.repeat((v * 255 + 0.5).astype(np.uint8), zoom, 0), zoom, 1)
    h, w, _ = v.shape
    raw = b"".join(b"\x00" + v[y].tobytes() for y in range(h))

    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data))

    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
    with open(path, "wb") as f:
        f.write(png)


class Scene:
    def __init__(self, spec, glass_names, tmp):
        self.spec = spec
        self.name = os.path.splitext(os.path.basename(spec))[0]
        self.tmp = tmp
        self.doc = None
        if spec.endswith(".json"):
            with open(spec) as f:
                self.doc = json.load(f)
            folder = os.path.dirname(os.path.abspath(spec))
            for mesh in self.doc["meshes"]:  # so that variants written elsewhere find their files
                if "file" in mesh:
                    mesh["file"] = os.path.join(folder, mesh["file"])
            env = self.doc.get("environment")
            if isinstance(env, dict) and "file" in env:  # an environment map (sky.json)
                env["file"] = os.path.join(folder, env["file"])
            mats = self.doc.get("materials", [])
            self.glass = [m["name"] for m in mats if (m["name"] in glass_names if glass_names
                                                       else m.get("type") == "dielectric")]
        else:
            self.glass = []

    def args(self, doc=None):
        if self.doc is None:
            return ["--scene", self.spec]
        if doc is None:
            return [self.spec]
        path = os.path.join(self.tmp, "%s_%d.json" % (self.name, id(doc)))
        with open(path, "w") as f:
            json.dump(doc, f)
        return [path]

    def without_glass(self):
        doc = json.loads(json.dumps(self.doc))
        doc["meshes"] = [m for m in doc["meshes"] if m.get("material") not in self.glass]
        return doc


class Runner:
    def __init__(self, exe, size, tmp, cache=None):
        self.exe, self.size, self.tmp, self.cache = exe, size, tmp, cache

    def cached(self, key, scene_args, integrator, spp, seed, threads=1, extra=()):
        """The image of a render that does not depend on the build under test (the reference and
        the region masks, all path): loaded from --ref-cache when it holds it, else rendered and
        stored there. The key names the scene file's contents, so an edited scene renders anew."""
        if self.cache is None:
            return self.render(scene_args, integrator, spp, seed, threads, extra)[0]
        text = open(scene_args[0]).read() if scene_args[0].endswith(".json") else scene_args[1]
        digest = "%08x" % zlib.crc32(("%s %s %d %d %d %s" % (text, integrator, spp, seed, self.size,
                                                            " ".join(extra))).encode())
        path = os.path.join(self.cache, "%s_%s.npy" % (key, digest))
        if os.path.exists(path):
            return np.load(path)
        img = self.render(scene_args, integrator, spp, seed, threads, extra)[0]
        os.makedirs(self.cache, exist_ok=True)
        np.save(path, img)
        return img

    def render(self, scene_args, integrator, spp, seed, threads=1, extra=()):
        out = os.path.join(self.tmp, "r.pfm")
        cmd = [self.exe, "render", *scene_args, "--integrator", integrator, "--width",
               str(self.size), "--height", str(self.size), "--spp", str(spp), "--seed", str(seed),
               "--threads", str(threads), *extra, "-o", out]
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        p = subprocess.run(cmd, capture_output=True, text=True)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        if p.returncode != 0:
            sys.exit("failed: %s\n%s" % (" ".join(cmd), p.stderr))
        cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
        m = STATS.search(p.stdout + p.stderr)
        rays = float(m.group(2)) / float(m.group(1)) if m else float("nan")
        chose = CHOSE.search(p.stdout)
        self.chosen = chose.group(1) if chose else None
        return read_pfm(out), cpu, rays


def rms(a):
    return float(np.sqrt(np.mean(a * a)))


def lum(img):
    return img @ np.array([0.2126, 0.7152, 0.0722])


def regions(runner, scene, ref, ref_seed):
    """Boolean masks (h, w) by region name, in a fixed order."""
    direct = runner.cached(scene.name + "_direct", scene.args(), "path", 256, ref_seed + 2,
                           threads=2, extra=["--max-depth", "0"])
    emitter = direct.max(axis=2) > 0
    out = {"emitter": emitter}
    rest = ~emitter
    if scene.glass:
        doc = json.loads(json.dumps(scene.doc))
        for m in doc["materials"]:
            if m["name"] in scene.glass:
                name = m["name"]
                m.clear()
                m.update(name=name, albedo=[0, 0, 0], emission=[0, 0, 1], two_sided=True)
        lit = runner.cached(scene.name + "_glass_lit", scene.args(doc), "path", 256,
                            ref_seed + 2, threads=2, extra=["--max-depth", "0"])
        glass = (lit[..., 2] - lit[..., 0] > 1e-6) & rest  # the emitter is white, the glass blue
        rest &= ~glass
        bare = runner.cached(scene.name + "_bare", scene.args(scene.without_glass()), "path",
                             4096, ref_seed + 3, threads=2)
        caustic = rest & (lum(ref) > 1.25 * lum(bare))
        rest &= ~caustic
        out.update(glass=glass, caustic=caustic)
    out["rest"] = rest
    return out


def region_png(path, masks):
    colours = {"emitter": (1, 1, 0), "glass": (0, 0.4, 1), "caustic": (1, 0.3, 0),
               "rest": (0.15, 0.15, 0.15)}
    img = np.zeros(next(iter(masks.values())).shape + (3,))
    for name, mask in masks.items():
        img[mask] = colours[name]
    write_png(path, img)


def share(text):
    """--light-paths' values: a share in (0, 1] or auto."""
    return text if text == "auto" else float(text)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("tritrace")
    ap.add_argument("--scenes", nargs="+", default=["cornell-area", "scenes/glass.json",
                                                    "scenes/caustics.json"])
    ap.add_argument("--size", type=int, default=48)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--bdpt-spp", type=int, nargs="+", default=[64, 256, 1024])
    ap.add_argument("--ref-spp", type=int, default=65536, help="both halves together")
    ap.add_argument("--ref-seed", type=int, default=1000)
    ap.add_argument("--ref-threads", type=int, default=2)
    ap.add_argument("--glass", nargs="*", default=None, help="material names (default: dielectrics)")
    ap.add_argument("--out", default="bdpt_equal_time_out")
    ap.add_argument("--sampler", default="sobol", choices=["sobol", "independent"],
                    help="the timed renders' sampler (the reference's is always sobol)")
    ap.add_argument("--ref-cache", default=None,
                    help="folder keeping the reference and region renders between runs")
    ap.add_argument("--ref-only", action="store_true",
                    help="only render the reference and regions into --ref-cache")
    ap.add_argument("--light-paths", type=share, nargs="+", default=[1.0],
                    help="bdpt's shares of samples with a light subpath, each measured apart, or "
                         "auto (the pilot's choice, bdpt_pilot.h)")
    a = ap.parse_args()
    if set(a.seeds) & {a.ref_seed, a.ref_seed + 1, a.ref_seed + 2, a.ref_seed + 3}:
        sys.exit("--seeds must differ from the reference's seeds")
    os.makedirs(a.out, exist_ok=True)
    runner = Runner(a.tritrace, a.size, a.out, a.ref_cache)
    results = {}
    for spec in a.scenes:
        scene = Scene(spec, a.glass, a.out)
        print("\n## %s (%dx%d)" % (scene.name, a.size, a.size), flush=True)
        # 1. reference
        halves = []
        for k in range(2):
            halves.append(runner.cached(scene.name + "_ref", scene.args(), "path", a.ref_spp // 2,
                                        a.ref_seed + k, threads=a.ref_threads))
        ref = (halves[0] + halves[1]) / 2
        ref_noise = rms(halves[0] - halves[1]) / 2
        # per pixel, summed over channels: an unbiased estimate of the reference's own squared
        # error, which every RMSE against it contains (independent seeds); subtracted below
        ref_sq = ((halves[0] - halves[1]) ** 2).sum(2) / 4
        masks = regions(runner, scene, ref, a.ref_seed)
        if a.ref_only:
            continue
        # 2. calibration (bdpt for each share F, path once)
        bmax = max(a.bdpt_spp)
        sampler = ["--sampler", a.sampler]

        def variant(f):
            if f == "auto":
                return "bdpt F=auto"
            return "bdpt" if f == 1.0 else "bdpt F=%g" % f

        def extra_of(label):
            if label.startswith("bdpt F="):
                return sampler + ["--light-paths", label[len("bdpt F="):]]
            return sampler

        def integrator_of(label):
            return label.split()[0]

        _, tp, _ = runner.render(scene.args(), "path", bmax, a.seeds[0], extra=sampler)
        costs = {}
        for f in a.light_paths:
            _, tb, _ = runner.render(scene.args(), "bdpt", bmax, a.seeds[0],
                                     extra=extra_of(variant(f)))
            costs[f] = tb / tp
        print("reference: path %d spp, seeds %d+%d, own noise RMS %.5f; bdpt sample = %s path "
              "samples of CPU" % (a.ref_spp, a.ref_seed, a.ref_seed + 1, ref_noise,
                                  ", ".join("%.2f (F %s)" % (costs[f], f) for f in a.light_paths)),
              flush=True)
        # 3. runs, alternated
        runs = {}  # (label, spp) -> list of (rmse, cpu, rays, sq-error image)
        configs = []
        for f in a.light_paths:
            for b in a.bdpt_spp:
                configs += [(variant(f), b), ("path", max(1, round(b * costs[f]))), ("path", b)]
        configs = list(dict.fromkeys(configs))
        for seed in a.seeds:
            for label, spp in configs:
                img, cpu, rays = runner.render(scene.args(), integrator_of(label), spp, seed,
                                               extra=extra_of(label))
                err = img - ref
                runs.setdefault((label, spp), []).append((rms(err), cpu, rays, (err ** 2).sum(2), img))
                if runner.chosen is not None:
                    print("%s %d spp seed %d: auto chose F = %s" % (label, spp, seed, runner.chosen),
                          flush=True)
        med = {k: (statistics.median(r[0] for r in v), statistics.median(r[1] for r in v),
                   statistics.median(r[2] for r in v)) for k, v in runs.items()}
        print("\n| integrator | spp | CPU s | RMSE | rays / sample |\n|---|---|---|---|---|")
        for k in configs:
            print("| %s | %d | %.2f | %.5f | %.1f |" % (k[0], k[1], med[k][1], med[k][0], med[k][2]))
        per_f = {}
        for f in a.light_paths:
            bdpt, cost = variant(f), costs[f]
            print("\n### %s: bdpt sample = %.2f path samples of CPU" % (bdpt, cost))
            print("\n| bdpt spp | path spp (equal time) | CPU s bdpt / path | RMSE bdpt / path, "
                  "equal-time pair | same, reference's noise subtracted | RMSE sqrt(t): bdpt / path "
                  "| RMSE bdpt / path, equal spp |")
            print("|---|---|---|---|---|---|---|")
            rows = []
            for b in a.bdpt_spp:
                pe = max(1, round(b * cost))
                rb, tb, _ = med[(bdpt, b)]
                rp, tp, _ = med[("path", pe)]
                rs = med[("path", b)][0]
                n2 = ref_noise ** 2
                row = dict(bdpt_spp=b, path_spp=pe, cpu_bdpt=tb, cpu_path=tp, rmse_bdpt=rb,
                           rmse_path=rp, ratio_pair=rb / rp,
                           ratio_pair_denoised_ref=((rb ** 2 - n2) / (rp ** 2 - n2)) ** 0.5,
                           ratio_scaled=(rb * tb ** 0.5) / (rp * tp ** 0.5), ratio_equal_spp=rb / rs)
                rows.append(row)
                print("| %d | %d | %.2f / %.2f | %.2f | %.2f | %.2f | %.2f |" % (
                    b, pe, tb, tp, row["ratio_pair"], row["ratio_pair_denoised_ref"],
                    row["ratio_scaled"], row["ratio_equal_spp"]))
            # The equal-time ratio split (issue 25): with MSE the mean over seeds of each render's
            # squared error, the reference's own noise subtracted, and c = path spp / bdpt spp of the
            # pair, ratio^2 = MSE_bdpt(B) / MSE_path(cB) = c * m * g, where m = MSE_bdpt(B) /
            # MSE_path(B) is bdpt's error per sample against path's (equal spp) and g = MSE_path(B) /
            # (c MSE_path(cB)) is how much faster than 1 / spp path's error falls from B to cB (1 for
            # plain Monte Carlo; below 1 where the Sobol sampler's stratification pays).
            mse = {k: statistics.fmean(r[0] ** 2 for r in v) - ref_noise ** 2 for k, v in runs.items()}
            print("\n| bdpt spp | c (path / bdpt spp) | m: MSE bdpt / path at equal spp | g: path's "
                  "convergence beyond 1/spp | c m g = equal-time MSE ratio | its square root |")
            print("|---|---|---|---|---|---|")
            for b, row in zip(a.bdpt_spp, rows):
                pe = max(1, round(b * cost))
                c = pe / b
                m = mse[(bdpt, b)] / mse[("path", b)]
                g = mse[("path", b)] / (c * mse[("path", pe)])
                row.update(split_c=c, split_m=m, split_g=g)
                print("| %d | %.2f | %.3f | %.3f | %.2f | %.2f |" % (b, c, m, g, c * m * g,
                                                                 (c * m * g) ** 0.5))
            # 5. regions, in the equal-time pair at the largest B (squared error summed over seeds)
            pe = max(1, round(bmax * cost))
            sq = {i: sum(r[3] for r in runs[k]) / len(runs[k])
                  for i, k in (("bdpt", (bdpt, bmax)), ("path", ("path", pe)))}
            print("\nregions at bdpt %d spp / path %d spp (mean over seeds of the squared error):"
                  % (bmax, pe))
            print("| region | pixels | share of path's squared error | share of bdpt's | "
                  "RMSE bdpt / path in the region | same, reference's noise subtracted |\n"
                  "|---|---|---|---|---|---|")
            reg = {}
            for name, mask in masks.items():
                sp = sq["path"][mask].sum() / sq["path"].sum()
                sb = sq["bdpt"][mask].sum() / sq["bdpt"].sum()
                ratio = (sq["bdpt"][mask].sum() / max(sq["path"][mask].sum(), 1e-300)) ** 0.5
                rn = ref_sq[mask].sum()
                ratio_d = (max(sq["bdpt"][mask].sum() - rn, 0) /
                           max(sq["path"][mask].sum() - rn, 1e-300)) ** 0.5
                reg[name] = dict(pixels=int(mask.sum()), share_path=sp, share_bdpt=sb, ratio=ratio,
                                 ratio_denoised_ref=ratio_d)
                print("| %s | %d | %.1f%% | %.1f%% | %.2f | %.2f |" % (
                    name, mask.sum(), 100 * sp, 100 * sb, ratio, ratio_d))
            for drop in (["emitter"], ["emitter", "glass"]):
                keep = ~np.any([masks[d] for d in drop if d in masks], axis=0)
                rn = ref_sq[keep].sum()
                ratio = ((sq["bdpt"][keep].sum() - rn) / (sq["path"][keep].sum() - rn)) ** 0.5
                print("equal-time RMSE ratio without %s (reference's noise subtracted): %.2f"
                      % (" and ".join(drop), ratio))
                reg["ratio_without_" + "_".join(drop)] = ratio
            # 6. the pixels that hold bdpt's error: the k worst of its equal-time render (mean over
            # seeds of the squared error), their share of its total and path's error in the same
            # pixels at equal spp (a strategy-independent part, the same per sample in both
            # integrators, shows as a ratio near 1 there).
            sq_spp = sum(r[3] for r in runs[("path", bmax)]) / len(runs[("path", bmax)])
            order = np.argsort(-sq["bdpt"].ravel())
            names = np.full(sq["bdpt"].size, "", dtype=object)
            for name, mask in masks.items():
                names[mask.ravel()] = name
            top = []
            print("\nbdpt's worst pixels at %d spp | share of bdpt's squared error | their MSE, "
                  "bdpt / path at equal spp | regions" % bmax)
            for k in (1, 5, 20, 100):
                idx = order[:k]
                share_b = sq["bdpt"].ravel()[idx].sum() / sq["bdpt"].sum()
                per_spp = sq["bdpt"].ravel()[idx].sum() / max(sq_spp.ravel()[idx].sum(), 1e-300)
                where = ", ".join("%s %d" % (n, c) for n, c in
                                  zip(*np.unique(names[idx].astype(str), return_counts=True)))
                top.append(dict(pixels=k, share_bdpt=float(share_b), m=float(per_spp)))
                print("| %d | %.1f%% | %.2f | %s |" % (k, 100 * share_b, per_spp, where))
            per_f[bdpt] = dict(cost=cost, rows=rows, regions=reg, worst_pixels=top)
        smallest = min(m[0] for m in med.values())
        print("reference noise / smallest RMSE compared: %.2f" % (ref_noise / smallest))
        # images
        write_png(os.path.join(a.out, "%s_ref.png" % scene.name), ref)
        write_png(os.path.join(a.out, "%s_path.png" % scene.name), runs[("path", pe)][0][4])
        write_png(os.path.join(a.out, "%s_bdpt.png" % scene.name), runs[(bdpt, bmax)][0][4])
        region_png(os.path.join(a.out, "%s_regions.png" % scene.name), masks)
        results[scene.name] = dict(ref_noise=ref_noise, light_paths=per_f,
                                   runs={"%s %d" % k: v for k, v in med.items()})
        with open(os.path.join(a.out, "results.json"), "w") as f:
            json.dump(results, f, indent=1)


if __name__ == "__main__":
    main()
