#!/usr/bin/env python3
"""Writes a scene that places the procedural terrain (its room included) COUNT times as instances:
the memory and speed measurement of instancing (docs/PERFORMANCE.md).

    scripts/make_instanced_terrain.py 1000 scenes/terrain_instances_1000.json
    scripts/make_instanced_terrain.py 1 /tmp/terrain_instance_1.json

The copies fill a cube grid (10 x 10 x 10 for 1000) inside the lab's [-1, 1]^3 room, each scaled to
its cell and turned by a few degrees about y so that not every transform is a pure scale. COUNT = 1
places one copy at full size: the same triangles as `--scene terrain:1m`.
"""
import argparse
import json
import math


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("count", type=int, help="how many instances (at least 1)")
    parser.add_argument("output", help="the scene file to write")
    parser.add_argument("--terrain", default="terrain:1m", help="the generator (default terrain:1m)")
    args = parser.parse_args()
    if args.count < 1:
        parser.error("count must be at least 1")
    side = math.ceil(round(args.count ** (1.0 / 3.0), 9))
    cell = 2.0 / side
    instances = []
    for k in range(args.count):
        i, j, l = k % side, (k // side) % side, k // (side * side)
        if args.count == 1:
            instances.append({})
            continue
        centre = [-1.0 + cell * (i + 0.5), -1.0 + cell * (j + 0.5), -1.0 + cell * (l + 0.5)]
        instances.append({
            "scale": round(0.45 * cell, 6),
            "rotate": [0, (k * 7) % 21 - 10, 0],
            "translate": [round(c, 6) for c in centre],
        })
    scene = {
        "description": f"{args.terrain} placed "
                       f"{args.count} time(s) as instances (scripts/make_instanced_terrain.py).",
        "lights": [{"position": [0, -0.5, -1.5], "power": [20, 20, 20]}],
        "integrator": {"type": "lab"},
        "meshes": [{"generator": args.terrain, "instances": instances}],
    }
    with open(args.output, "w") as f:
        json.dump(scene, f, indent=None, separators=(",", ":"))
        f.write("\n")


if __name__ == "__main__":
    main()
