# Shared helpers of the Python module's tests: the CLI to compare with, and readers for the images
# it writes (PFM, and OpenEXR with ZIP compression), written here from the formats' specifications
# so that the comparison does not go through tritrace's own code.
import os
import pathlib
import struct
import subprocess
import zlib

import numpy as np
import pytest

import tritrace

REPO = pathlib.Path(__file__).resolve().parents[2]


def cli_path():
    path = os.environ.get("TRITRACE_CLI", str(REPO / "build" / "tritrace"))
    if not os.path.exists(path):
        pytest.fail(f"the tritrace CLI is not at {path} (set TRITRACE_CLI)")
    return path


def run_cli(*args, check=True):
    """Runs `tritrace ARGS`; returns the completed process (stdout and stderr as text)."""
    result = subprocess.run([cli_path(), *map(str, args)], capture_output=True, text=True)
    if check and result.returncode != 0:
        raise AssertionError(f"tritrace {' '.join(map(str, args))} failed: {result.stderr}")
    return result


def cli_error(*args):
    """The one-line message `tritrace ARGS` fails with, without its 'tritrace: ' prefix."""
    result = run_cli(*args, check=False)
    assert result.returncode != 0, f"tritrace {args} did not fail"
    line = result.stderr.strip()
    assert line.startswith("tritrace: "), line
    return line[len("tritrace: "):]


def read_pfm(path):
    """A PFM file as an (H, W, 3) float32 array with row 0 at the top (PFM stores bottom-up)."""
    data = pathlib.Path(path).read_bytes()
    header = []
    pos = 0
    while len(header) < 3:  # "PF", "W H", scale, each ending in one whitespace byte
        end = data.index(b"\n", pos)
        header.append(data[pos:end].decode())
        pos = end + 1
    assert header[0] == "PF"
    width, height = map(int, header[1].split())
    scale = float(header[2])
    dtype = "<f4" if scale < 0 else ">f4"
    pixels = np.frombuffer(data, dtype=dtype, count=width * height * 3, offset=pos)
    return pixels.reshape(height, width, 3)[::-1].astype(np.float32)


def read_exr(path):
    """The channels of a single-part scanline OpenEXR file without compression or with ZIP/ZIPS
    compression, as {name: (H, W) float32 array}."""
    data = pathlib.Path(path).read_bytes()
    assert data[:4] == bytes([0x76, 0x2F, 0x31, 0x01]), "not an OpenEXR file"
    pos = 8
    attributes = {}
    while data[pos] != 0:
        name_end = data.index(b"\0", pos)
        name = data[pos:name_end].decode()
        type_end = data.index(b"\0", name_end + 1)
        kind = data[name_end + 1:type_end].decode()
        (size,) = struct.unpack_from("<i", data, type_end + 1)
        attributes[name] = (kind, data[type_end + 5:type_end + 5 + size])
        pos = type_end + 5 + size
    pos += 1
    channels = []  # (name, bytes per value, numpy dtype), in file order (sorted by name)
    raw = attributes["channels"][1]
    p = 0
    while raw[p] != 0:
        end = raw.index(b"\0", p)
        (pixel_type,) = struct.unpack_from("<i", raw, end + 1)
        size, dtype = {1: (2, "<f2"), 2: (4, "<f4"), 0: (4, "<u4")}[pixel_type]
        channels.append((raw[p:end].decode(), size, dtype))
        p = end + 1 + 16
    compression = attributes["compression"][1][0]
    x0, y0, x1, y1 = struct.unpack("<4i", attributes["dataWindow"][1])
    width, height = x1 - x0 + 1, y1 - y0 + 1
    lines_per_chunk = {0: 1, 2: 1, 3: 16}[compression]
    chunks = (height + lines_per_chunk - 1) // lines_per_chunk
    offsets = struct.unpack_from(f"<{chunks}Q", data, pos)
    out = {name: np.zeros((height, width), np.float32) for name, _, _ in channels}
    for offset in offsets:
        y, size = struct.unpack_from("<ii", data, offset)
        block = data[offset + 8:offset + 8 + size]
        lines = min(lines_per_chunk, y1 + 1 - y)
        expected = lines * width * sum(s for _, s, _ in channels)
        if compression != 0 and size < expected:
            raw = np.frombuffer(zlib.decompress(block), np.uint8).astype(np.int64)
            # Undo the predictor (each byte stored as the difference to the one before, + 128)
            # and then the split of even and odd bytes into two halves.
            raw[1:] -= 128
            t = (np.cumsum(raw) % 256).astype(np.uint8)
            half = (len(t) + 1) // 2
            interleaved = np.empty_like(t)
            interleaved[0::2] = t[:half]
            interleaved[1::2] = t[half:]
            block = interleaved.tobytes()
        p = 0
        for line in range(lines):
            for name, size, dtype in channels:
                row = np.frombuffer(block, dtype, count=width, offset=p)
                out[name][y - y0 + line] = row.astype(np.float32)
                p += size * width
    return out


@pytest.fixture(scope="session")
def cornell():
    return tritrace.Scene.builtin("cornell")


def lab_box_triangles():
    """The lab's 30 triangles (30, 3, 3) from the fact sheet (../shared/lab-cornell-box.md): the
    room's corners and the blocks' corners in 555-unit coordinates, scaled to [-1, 1]^3 with x
    and y negated, in float64; the scene's own floats are these rounded once to float32."""
    L = 555.0
    A, B, C, D = (L, 0, 0), (0, 0, 0), (L, 0, L), (0, 0, L)
    E, F, G, H = (L, L, 0), (0, L, 0), (L, L, L), (0, L, L)
    room = [(C, B, A), (C, D, B), (A, E, C), (C, E, G), (F, B, D), (H, F, D), (E, F, G),
            (F, H, G), (G, D, C), (G, H, D)]
    tris = list(room)
    for corners in (
        [(290, 0, 114), (130, 0, 65), (240, 0, 272), (82, 0, 225), (290, 165, 114),
         (130, 165, 65), (240, 165, 272), (82, 165, 225)],
        [(423, 0, 247), (265, 0, 296), (472, 0, 406), (314, 0, 456), (423, 330, 247),
         (265, 330, 296), (472, 330, 406), (314, 330, 456)],
    ):
        a, b, c, d, e, f, g, h = corners
        tris += [(e, b, a), (e, f, b), (f, d, b), (f, h, d), (h, c, d), (h, g, c), (g, e, c),
                 (e, a, c), (g, f, e), (g, h, f)]
    v = np.array(tris, dtype=np.float64) * (2.0 / L) - 1.0
    v[..., 0] *= -1.0
    v[..., 1] *= -1.0
    return v
