#!/usr/bin/env python3
"""Writes a big binary PLY for load and build benchmarks: a displaced sphere (bumps of several
frequencies on a UV sphere) inside the lab box's [-1, 1] cube, with about the number of triangles
asked for (rings x segments x 2). Needs NumPy (python3-numpy). An output name ending in .obj
writes the same mesh as a Wavefront OBJ instead (coordinates with 9 significant digits, which read
back as the PLY's floats; --quads writes each pair of triangles as one quad, which assimp and the
native reader split back into the same two triangles).

    /usr/bin/python3 scripts/make_displaced_sphere_ply.py --triangles 10000000 -o sphere10m.ply
    /usr/bin/python3 scripts/make_displaced_sphere_ply.py --triangles 10000000 -o sphere10m.obj
"""
import argparse
import os
import sys

import numpy as np


def write_obj(path, vertices, faces):
    """ASCII OBJ in blocks (1-based indices); %.9g prints each float so that it reads back exactly."""
    block = 1 << 20
    with open(path, "w") as f:
        f.write("# displaced sphere, scripts/make_displaced_sphere_ply.py\no sphere\n")
        for i in range(0, len(vertices), block):
            np.savetxt(f, vertices[i:i + block].astype(np.float64), fmt="v %.9g %.9g %.9g")
        fmt = "f" + " %d" * faces.shape[1]
        for i in range(0, len(faces), block):
            np.savetxt(f, faces[i:i + block] + 1, fmt=fmt)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--triangles", type=int, default=10_000_000)
    parser.add_argument("-o", "--output", required=True)
    parser.add_argument("--quads", action="store_true", help="OBJ only: faces of four corners")
    args = parser.parse_args()
    if args.triangles < 8:
        parser.error("--triangles: at least 8")
    # rings x segments quads, two triangles each, between the poles' rows of vertices.
    segments = max(4, int(round(np.sqrt(args.triangles))))
    rings = max(2, args.triangles // (2 * segments))
    theta = np.linspace(0.0, np.pi, rings + 1, dtype=np.float64)[:, None]
    phi = np.linspace(0.0, 2.0 * np.pi, segments, endpoint=False, dtype=np.float64)[None, :]
    bumps = (0.06 * np.sin(7 * theta) * np.cos(5 * phi) + 0.03 * np.sin(23 * theta + 3 * phi) *
             np.cos(17 * phi) + 0.01 * np.sin(91 * theta) * np.sin(83 * phi))
    radius = 0.55 * (1.0 + bumps)
    x = radius * np.sin(theta) * np.cos(phi)
    y = radius * np.cos(theta) + 0.2  # the lab's y points down: a little towards the floor
    z = radius * np.sin(theta) * np.sin(phi)
    vertices = np.stack([x, y, z], axis=-1).reshape(-1, 3).astype("<f4")

    r = np.arange(rings, dtype=np.int64)[:, None]
    s = np.arange(segments, dtype=np.int64)[None, :]
    a = r * segments + s
    b = r * segments + (s + 1) % segments
    c = a + segments
    d = b + segments
    quads = np.stack([a, c, d, b], axis=-1).reshape(-1, 4)
    tris = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]], axis=1).reshape(-1, 3)
    faces = np.empty(len(tris), dtype=[("n", "u1"), ("i", "<i4", 3)])
    faces["n"] = 3
    faces["i"] = tris

    tmp = args.output + ".tmp"
    if args.output.lower().endswith(".obj"):
        write_obj(tmp, vertices, quads if args.quads else tris)
        os.replace(tmp, args.output)
        print(f"{args.output}: {len(vertices)} vertices, {len(tris)} triangles, "
              f"{os.path.getsize(args.output) / 1e6:.0f} MB")
        return 0
    if args.quads:
        parser.error("--quads: only for .obj output")
    with open(tmp, "wb") as f:
        f.write(b"ply\nformat binary_little_endian 1.0\n"
                b"comment displaced sphere, scripts/make_displaced_sphere_ply.py\n")
        f.write(b"element vertex %d\nproperty float x\nproperty float y\nproperty float z\n" %
                len(vertices))
        f.write(b"element face %d\nproperty list uchar int vertex_indices\nend_header\n" %
                len(faces))
        vertices.tofile(f)
        faces.tofile(f)
    os.replace(tmp, args.output)
    print(f"{args.output}: {len(vertices)} vertices, {len(faces)} triangles, "
          f"{os.path.getsize(args.output) / 1e6:.0f} MB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
