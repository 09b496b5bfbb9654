#!/usr/bin/python3
"""Compare linear float images (PFM, as `tritrace render -o x.pfm` and bench/blender/cornell_area.py
write them) with a reference: per image the mean of each channel, the mean's difference from the
reference's in percent and in standard errors, and the RMSE against the reference (over all
pixels and channels, and without the light's pixels and their edges, see main()).

    /usr/bin/python3 bench/blender/compare.py --ref ref.pfm tritrace_256.pfm cycles_256.pfm ...
    /usr/bin/python3 bench/blender/compare.py --ref ref.pfm --png side_by_side.png a.pfm b.pfm

Needs only Python 3 and numpy (Debian: python3-numpy; /usr/bin/python3 is Debian's, which has it).

The standard error of an image mean is estimated from the image itself, against the reference:
sqrt(sum over pixels of (pixel - reference)^2) / N per channel, which treats the pixels' errors as
independent (true for both renderers: every pixel has its own samples) and includes the
reference's own noise.

Framing checks, to catch a camera or orientation mismatch that the means would hide: the RMSE
against the reference mirrored left to right (far larger than the RMSE when nothing is mirrored),
and the light's area and centroid in pixels, from the light's coverage of the pixels around it,
(v - c) / (10 - c) with c the median of the ring around the light: a camera shifted by a fraction
of a pixel or with another field of view moves or resizes the light by about that much.
"""

import argparse
import struct
import sys
import zlib

import numpy as np


def read_pfm(path):
    """H x W x 3 float32 (or H x W x 1 for 'Pf'), top row first."""
    with open(path, "rb") as f:
        kind = f.readline().strip()
        if kind not in (b"PF", b"Pf"):
            raise ValueError("%s: not a PFM file" % path)
        dims = f.readline().split()
        while len(dims) < 2:
            dims += f.readline().split()
        w, h = int(dims[0]), int(dims[1])
        scale = float(f.readline().strip())
        channels = 3 if kind == b"PF" else 1
        data = np.frombuffer(f.read(w * h * channels * 4), dtype="<f4" if scale < 0 else ">f4")
    return data.reshape(h, w, channels)[::-1].astype(np.float64)


def srgb8(linear):
    c = np.clip(linear, 0.0, 1.0)
    c = np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1.0 / 2.4) - 0.055)
    return (c * 255.0 + 0.5).astype(np.uint8)


def write_png(path, rgb8):
    h, w, _ = rgb8.shape
    raw = b"".join(b"\x00" + rgb8[y].tobytes() for y in range(h))

    def chunk(tag, data):
        body = tag + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body) & 0xFFFFFFFF)

    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n")
        f.write(chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)))
        f.write(chunk(b"IDAT", zlib.compress(raw, 9)))
        f.write(chunk(b"IEND", b""))


LIGHT_RADIANCE = 10.0


def light_analytic(width, height):
    """The light quad's exact pinhole image: area and centroid of the projected quadrilateral
    (the fact sheet's mapping, camera at (0, 0, -3), f = height, optical axis through the
    corner (W/2, H/2) with integer halves)."""
    corners = [(343, 554, 227), (343, 554, 332), (213, 554, 332), (213, 554, 227)]
    pts = []
    for v in corners:
        x, y, z = (c * 2.0 / 555.0 - 1.0 for c in v)
        x, y = -x, -y
        pts.append((width // 2 + height * x / (z + 3.0), height // 2 + height * y / (z + 3.0)))
    x = np.array([p[0] for p in pts])
    y = np.array([p[1] for p in pts])
    cross = x * np.roll(y, -1) - np.roll(x, -1) * y
    a = 0.5 * cross.sum()
    return abs(a), ((x + np.roll(x, -1)) * cross).sum() / (6 * a), \
        ((y + np.roll(y, -1)) * cross).sum() / (6 * a)


def light_window(ref):
    """Rows and columns of a window around the pixels that see the light, 3 pixels wider."""
    ys, xs = np.nonzero(ref.mean(axis=2) > 0.5 * LIGHT_RADIANCE)
    return slice(max(ys.min() - 3, 0), ys.max() + 4), slice(max(xs.min() - 3, 0), xs.max() + 4)


def light_footprint(img, window):
    """The light's area (pixels) and centroid (x, y from the top-left corner, pixel centres at
    i + 0.5) from each pixel's coverage in the window."""
    ys, xs = window
    lum = img[ys, xs].mean(axis=2)
    ring = np.ones(lum.shape, dtype=bool)
    ring[2:-2, 2:-2] = False
    c = np.median(lum[ring])
    cover = np.clip((lum - c) / (LIGHT_RADIANCE - c), 0.0, 1.0)
    gy, gx = np.mgrid[ys, xs]
    area = cover.sum()
    return area, (cover * (gx + 0.5)).sum() / area, (cover * (gy + 0.5)).sum() / area


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--ref", required=True, help="the long reference render (PFM)")
    ap.add_argument("--png", help="write the images side by side (sRGB, clamped) to this PNG")
    ap.add_argument("--ref-spp", type=int, help="the reference's samples per pixel")
    ap.add_argument("--ref-noise", metavar="IMAGE:SPP",
                    help="estimate the reference's own squared error from IMAGE, rendered by the "
                         "reference's renderer with SPP samples and another seed, and print RMSEs "
                         "with it taken out (needs --ref-spp)")
    ap.add_argument("images", nargs="+", help="images to compare (PFM)")
    args = ap.parse_args()

    ref = read_pfm(args.ref)
    # The light's pixels: every pixel that sees some of the emitter in the reference, and one more
    # ring around them. Inside, the value is exactly 10 in any renderer; at the light's edges a
    # sample sees either 10 or the dark ceiling, so those ~90 pixels have a variance far above the
    # rest (at equal spp, about as much squared error as all other pixels together) and measure
    # mostly how the renderer places samples inside a pixel. "RMSE no light" leaves them out.
    seen = ref.mean(axis=2) > 1.0
    light = seen.copy()
    light[1:] |= seen[:-1]
    light[:-1] |= seen[1:]
    light[:, 1:] |= seen[:, :-1]
    light[:, :-1] |= seen[:, 1:]
    print("reference %s: %dx%d, mean %.5f %.5f %.5f; %d pixels see the light, %d left out of "
          "'no light'" % (args.ref, ref.shape[1], ref.shape[0], *ref.reshape(-1, 3).mean(axis=0),
                          int((ref.mean(axis=2) > 5.0).sum()), int(light.sum())))
    # The reference is noisy too: an image's squared error against it is its own plus the
    # reference's (independent samples). For an image of the same unbiased renderer with n samples
    # against a reference of N, MSE(image, ref) = MSE_ref * (N / n + 1), so one such image gives
    # MSE_ref = MSE(image, ref) * n / (N + n), over all pixels and without the light alike.
    ref_mse = None
    if args.ref_noise:
        if not args.ref_spp:
            sys.exit("--ref-noise needs --ref-spp")
        path, n = args.ref_noise.rsplit(":", 1)
        d = read_pfm(path) - ref
        k = int(n) / (args.ref_spp + int(n))
        ref_mse = (np.mean(d ** 2) * k, np.mean(d[~light] ** 2) * k)
        print("reference's own RMSE, estimated from %s (%s spp): %.5f, no light %.5f"
              % (path, n, *np.sqrt(ref_mse)))
    window = light_window(ref)
    area, cx, cy = light_footprint(ref, window)
    print("light: area %.2f px, centroid (%.3f, %.3f) in the reference; exact pinhole image of "
          "the quad: %.2f px, (%.3f, %.3f)" % (area, cx, cy, *light_analytic(ref.shape[1],
                                                                          ref.shape[0])))
    print("%-36s %-24s %-21s %-18s %8s %8s %8s %-26s" % (
        "image", "mean R G B", "mean - ref (%)", "(std errors)", "RMSE", "no light", "mirrored",
        "light area, centroid"))
    shown = [ref]
    for path in args.images:
        img = read_pfm(path)
        if img.shape != ref.shape:
            sys.exit("%s: %s, reference %s" % (path, img.shape, ref.shape))
        n = img.shape[0] * img.shape[1]
        mean = img.reshape(-1, 3).mean(axis=0)
        ref_mean = ref.reshape(-1, 3).mean(axis=0)
        diff = img - ref
        stderr = np.sqrt((diff.reshape(-1, 3) ** 2).sum(axis=0)) / n
        rel = 100.0 * (mean - ref_mean) / ref_mean
        with np.errstate(divide="ignore", invalid="ignore"):
            z = (mean - ref_mean) / stderr
        rmse = np.sqrt(np.mean(diff ** 2))
        rmse_nl = np.sqrt(np.mean(diff[~light] ** 2))
        rmse_mirror = np.sqrt(np.mean((img - ref[:, ::-1]) ** 2))
        area, cx, cy = light_footprint(img, window)
        print("%-36s %.5f %.5f %.5f %+6.2f %+6.2f %+6.2f  %+5.1f %+5.1f %+5.1f %8.5f %8.5f %8.5f "
              "%.2f (%.3f, %.3f)" % (path[-36:], *mean, *rel, *z, rmse, rmse_nl, rmse_mirror,
                                     area, cx, cy))
        if ref_mse:
            print("%-36s RMSE with the reference's noise taken out: %.5f, no light %.5f"
                  % ("", np.sqrt(max(rmse ** 2 - ref_mse[0], 0.0)),
                     np.sqrt(max(rmse_nl ** 2 - ref_mse[1], 0.0))))
        shown.append(img)
    if args.png:
        write_png(args.png, srgb8(np.concatenate(shown, axis=1)))
        print("wrote %s (reference first, then the images in order)" % args.png)


if __name__ == "__main__":
    main()
