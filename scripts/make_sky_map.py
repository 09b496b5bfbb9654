#!/usr/bin/env python3
"""Writes scenes/sky.hdr: a small procedural sky for the environment-map example (scenes/sky.json).

A 256 x 128 equirectangular Radiance HDR map in tritrace's convention (docs/SCENE_FORMAT.md): row 0
looks up, the centre column faces +z, u grows towards +x. Blue overhead fading to a pale horizon,
a darker ground below, and a sun 35 degrees high, 60 degrees left of +z, 2 degrees in radius,
bright enough to cast clear shadows (about three times the sky's irradiance). Flat (not run-length
encoded) RGBE pixels, which stb_image and every other Radiance reader accept; 128 KiB.

Usage: scripts/make_sky_map.py [output path]   (default: scenes/sky.hdr beside this script's repo)
"""
import math
import os
import struct
import sys

WIDTH, HEIGHT = 256, 128
SUN_ELEVATION = math.radians(35.0)
SUN_AZIMUTH = math.radians(-60.0)  # phi: 0 at +z, positive towards +x
SUN_RADIUS = math.radians(2.0)
SUN_RADIANCE = (1500.0, 1400.0, 1200.0)


def direction(u, v):
    theta, phi = math.pi * v, 2.0 * math.pi * (u - 0.5)
    return (math.sin(theta) * math.sin(phi), -math.cos(theta), math.sin(theta) * math.cos(phi))


def radiance(u, v):
    d = direction(u, v)
    elevation = math.asin(max(-1.0, min(1.0, -d[1])))
    sun = (math.cos(SUN_ELEVATION) * math.sin(SUN_AZIMUTH), -math.sin(SUN_ELEVATION),
           math.cos(SUN_ELEVATION) * math.cos(SUN_AZIMUTH))
    cos_sun = sum(a * b for a, b in zip(d, sun))
    if cos_sun > math.cos(SUN_RADIUS):
        return SUN_RADIANCE
    if elevation < 0.0:
        t = min(1.0, -elevation / 0.2)  # the ground darkens away from the horizon
        return tuple((1 - t) * h + t * g for h, g in zip((0.55, 0.52, 0.48), (0.18, 0.16, 0.14)))
    t = math.sqrt(elevation / (0.5 * math.pi))
    zenith, horizon = (0.18, 0.32, 0.75), (0.95, 0.95, 1.0)
    glow = 0.6 * max(0.0, cos_sun) ** 8  # a brighter sky around the sun
    return tuple((1 - t) * h + t * z + glow for h, z in zip(horizon, zenith))


def rgbe(c):
    v = max(c)
    if v < 1e-32:
        return bytes(4)
    m, e = math.frexp(v)
    scale = m * 256.0 / v
    return bytes([int(c[0] * scale), int(c[1] * scale), int(c[2] * scale), e + 128])


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(here, "..", "scenes", "sky.hdr")
    pixels = bytearray()
    for y in range(HEIGHT):
        for x in range(WIDTH):
            pixels += rgbe(radiance((x + 0.5) / WIDTH, (y + 0.5) / HEIGHT))
    # A reader takes a scanline that starts with 2, 2 and a small byte for run-length encoded.
    assert not (pixels[0] == 2 and pixels[1] == 2 and pixels[2] < 128)
    header = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n" % (HEIGHT, WIDTH)
    tmp = out + ".tmp"
    with open(tmp, "wb") as f:
        f.write(header + bytes(pixels))
    os.replace(tmp, out)


if __name__ == "__main__":
    main()
