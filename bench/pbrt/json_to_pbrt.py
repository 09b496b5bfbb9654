#!/usr/bin/env python3
"""Write one of tritrace's scenes as a pbrt-v4 scene file, for side_by_side.py.

  json_to_pbrt.py SCENE OUT.pbrt [--integrator path|bdpt] [--maxdepth N] [--spp N]
                  [--width W] [--height H] [--grey]

SCENE is a tritrace scene file (.json, the subset used by scenes/cornell.json and
scenes/caustics.json: a look-at camera, diffuse / emissive / dielectric materials, inline meshes and
OBJ meshes with a scale-and-translate transform) or the built-in `cornell-area`, which is
scenes/cornell.json's box (the lab's 30 triangles, camera and albedos) without its point light and
ambient term, plus the ceiling light of src/tritrace/scene/cornell_box.cpp (make_cornell_area).
side_by_side.py renders the result with tritrace as well and checks that it is the built-in scene's
image, so the file cannot drift from tritrace's scene unnoticed.

Conventions carried over (docs/SCENE_FORMAT.md, "pbrt-v4 scene files"):
- tritrace's inline triangles have the lab's normal normalize(cross(v2 - v0, v1 - v0)); pbrt's is
  cross(p1 - p0, p2 - p0), so each (a, b, c) is written (a, c, b): emitters light the same side.
  OBJ faces are counter-clockwise seen from outside for both and are written as they are.
- pbrt's LookAt makes image right = cross(up, dir); tritrace's is -cross(up, dir) (its `down` is
  -up), so `Scale -1 1 1` comes first.
- pbrt's fov spans the shorter image side; tritrace's focal length (pixels) is the same on both axes.
- One sample per pixel through a box of radius 0.5 (tritrace's default `box` filter); the zsobol
  sampler (tritrace's `sobol` is an Owen-scrambled Sobol sequence too, in another order).
--grey replaces each diffuse albedo by the mean of its channels, so that pbrt's spectral rendering
and tritrace's RGB rendering must agree exactly in expectation (a grey albedo's spectrum is flat).
"""

import argparse
import math
import os
import re
import sys

import json

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def load_json(path):
    with open(path, encoding="utf-8") as f:
        text = f.read()
    # tritrace's scene files allow // comments (none of these files has // inside a string).
    return json.loads(re.sub(r"//[^\n]*", "", text))


def f32(x):
    import struct

    return struct.unpack("f", struct.pack("f", x))[0]


def cornell_area():
    scene = load_json(os.path.join(REPO, "scenes", "cornell.json"))
    scene.pop("lights", None)
    scene.pop("ambient", None)
    scene["integrator"] = {"type": "path"}
    # make_cornell_area: radiance 10 (kAreaLightRadiance), albedo 0, the quad at y = 554 of the
    # 555 room, scaled as scale_to_unit_box does (v * 2/L - 1, x and y negated), in float32.
    scene["materials"].append({"name": "light", "albedo": [0, 0, 0], "emission": [10, 10, 10]})
    s = f32(2.0 / 555.0)

    def unit(v):
        x, y, z = (f32(f32(f32(c) * s) - 1.0) for c in v)
        return [-x, -y, z]

    a, b, c, d = (unit(p) for p in ([343, 554, 227], [343, 554, 332], [213, 554, 332],
                                    [213, 554, 227]))
    scene["meshes"].append({"material": "light", "positions": [a, b, c, d],
                            "triangles": [[0, 2, 1], [0, 3, 2]]})
    scene["_dir"] = os.path.join(REPO, "scenes")
    return scene


def read_obj(path):
    verts, faces = [], []
    with open(path, encoding="utf-8") as f:
        for line in f:
            parts = line.split()
            if not parts:
                continue
            if parts[0] == "v":
                verts.append([float(t) for t in parts[1:4]])
            elif parts[0] == "f":
                idx = [int(t.split("/")[0]) for t in parts[1:]]
                idx = [i - 1 if i > 0 else len(verts) + i for i in idx]
                for k in range(1, len(idx) - 1):  # fan, as assimp triangulates a convex face
                    faces.append([idx[0], idx[k], idx[k + 1]])
    return verts, faces


def fmt(values):
    return " ".join("%.9g" % v for v in values)


def camera_lines(cam, width, height):
    pos, look, up = cam["position"], cam["look_at"], cam["up"]
    if "focal_length" in cam:
        focal = float(cam["focal_length"])
    elif "vertical_fov" in cam:
        focal = 0.5 * height / math.tan(math.radians(cam["vertical_fov"]) / 2)
    else:
        sys.exit("json_to_pbrt.py: camera: needs focal_length or vertical_fov")
    if cam.get("width") and "focal_length" in cam and cam.get("height") != height:
        focal *= height / cam["height"]  # a focal length in pixels scales with the image
    fov = math.degrees(2 * math.atan(0.5 * min(width, height) / focal))
    return [
        "Scale -1 1 1",
        "LookAt %s  %s  %s" % (fmt(pos), fmt(look), fmt(up)),
        'Camera "perspective" "float fov" [%.9g]' % fov,
    ]


def convert(scene, args):
    cam = scene["camera"]
    width = args.width or cam.get("width", 256)
    height = args.height or cam.get("height", 256)
    out = ["# Written by tritrace's bench/pbrt/json_to_pbrt.py from %s; do not edit." % args.scene]
    out += camera_lines(cam, width, height)
    out.append('Film "rgb" "integer xresolution" [%d] "integer yresolution" [%d] '
               '"string filename" "pbrt.pfm" "bool savefp16" false' % (width, height))
    out.append('PixelFilter "box" "float xradius" [0.5] "float yradius" [0.5]')
    out.append('Sampler "zsobol" "integer pixelsamples" [%d]' % args.spp)
    out.append('Integrator "%s" "integer maxdepth" [%d]' % (args.integrator, args.maxdepth))
    out.append("WorldBegin")
    materials = {m["name"]: m for m in scene["materials"]}
    base = scene.get("_dir", os.path.dirname(os.path.abspath(args.scene)))
    for mesh in scene["meshes"]:
        mat = materials[mesh["material"]]
        kind = mat.get("type", "diffuse")
        out.append("AttributeBegin")
        if kind == "dielectric":
            out.append('  Material "dielectric" "float eta" [%.9g]' % mat.get("ior", 1.5))
        elif kind == "diffuse":
            albedo = mat.get("albedo", [0.6, 0.6, 0.6])
            if args.grey:
                albedo = [sum(albedo) / 3.0] * 3
            out.append('  Material "diffuse" "rgb reflectance" [%s]' % fmt(albedo))
        else:
            sys.exit("json_to_pbrt.py: material %s: type %s not handled" % (mat["name"], kind))
        if "emission" in mat:
            out.append('  AreaLightSource "diffuse" "rgb L" [%s]' % fmt(mat["emission"]))
        if "file" in mesh:
            verts, faces = read_obj(os.path.join(base, mesh["file"]))
            t = mesh.get("transform", {})
            if set(t) - {"scale", "translate"}:
                sys.exit("json_to_pbrt.py: %s: only scale and translate transforms" % mesh["file"])
            sc = t.get("scale", 1.0)
            sc = [sc] * 3 if not isinstance(sc, list) else sc
            tr = t.get("translate", [0.0, 0.0, 0.0])
            verts = [[tr[i] + sc[i] * v[i] for i in range(3)] for v in verts]
            tris = faces  # counter-clockwise from outside: pbrt's orientation already
        else:
            verts = mesh["positions"]
            tris = [[a, c, b] for a, b, c in mesh["triangles"]]  # the lab's winding, reversed
        out.append('  Shape "trianglemesh" "point3 P" [%s]' % fmt([c for v in verts for c in v]))
        out.append('    "integer indices" [%s]' % " ".join(str(i) for t in tris for i in t))
        out.append("AttributeEnd")
    return "\n".join(out) + "\n"


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("scene", help="a tritrace .json scene file or cornell-area")
    p.add_argument("out", help="the .pbrt file to write")
    p.add_argument("--integrator", choices=["path", "bdpt"], default="path")
    p.add_argument("--maxdepth", type=int, default=5)
    p.add_argument("--spp", type=int, default=64)
    p.add_argument("--width", type=int)
    p.add_argument("--height", type=int)
    p.add_argument("--grey", action="store_true", help="diffuse albedos replaced by their mean")
    args = p.parse_args()
    if args.scene == "cornell-area":
        scene = cornell_area()
    elif os.path.isfile(args.scene):
        scene = load_json(args.scene)
    else:
        sys.exit("json_to_pbrt.py: %s: no such scene file (or the built-in cornell-area)" %
                 args.scene)
    with open(args.out, "w", encoding="utf-8") as f:
        f.write(convert(scene, args))


if __name__ == "__main__":
    main()
