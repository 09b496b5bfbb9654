#!/usr/bin/env python3
# Writes tests/data/gltf/room.gltf (run from the repository root): the hand-written test
# model, its buffers and images as data URIs, so that the file is one self-contained text file.
import base64, json, struct
# A small room seen from a camera: a floor, a back wall and two boxes, three materials.
def box(lo, hi):
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    p = [(x0,y0,z0),(x1,y0,z0),(x1,y1,z0),(x0,y1,z0),(x0,y0,z1),(x1,y0,z1),(x1,y1,z1),(x0,y1,z1)]
    f = [(0,2,1),(0,3,2),(4,5,6),(4,6,7),(0,1,5),(0,5,4),(3,7,6),(3,6,2),(0,4,7),(0,7,3),(1,2,6),(1,6,5)]
    return p, [i for t in f for i in t]
def quad(c):
    return c, [0,1,2,0,2,3]
parts = [quad([(-3,0,-3),(-3,0,3),(3,0,3),(3,0,-3)]), quad([(-3,0,-3),(3,0,-3),(3,3,-3),(-3,3,-3)]),
         box((-1.5,0,-1),(-0.5,1.2,0)), box((0.3,0,-0.5),(1.3,0.6,0.5))]
mats = [1, 1, 0, 2]
buf = b''; views = []; acc = []; prims = []
for k, (p, idx) in enumerate(parts):
    pos = b''.join(struct.pack('<3f', *v) for v in p); ib = struct.pack('<%dH' % len(idx), *idx)
    ib += b'\0' * (-len(ib) % 4)
    a = len(acc)
    views.append({"buffer": 0, "byteOffset": len(buf), "byteLength": len(pos), "target": 34962}); buf += pos
    views.append({"buffer": 0, "byteOffset": len(buf), "byteLength": 2 * len(idx), "target": 34963}); buf += ib
    acc += [{"bufferView": a, "componentType": 5126, "count": len(p), "type": "VEC3",
             "min": [min(v[i] for v in p) for i in range(3)], "max": [max(v[i] for v in p) for i in range(3)]},
            {"bufferView": a + 1, "componentType": 5123, "count": len(idx), "type": "SCALAR"}]
    prims.append({"attributes": {"POSITION": a}, "indices": a + 1, "material": mats[k]})
g = {"asset": {"version": "2.0", "generator": "tritrace tests (hand-written: a small room for the pbrt exporter test)"},
     "scene": 0, "scenes": [{"nodes": [0, 1]}],
     "nodes": [{"mesh": 0}, {"camera": 0, "translation": [0, 1.2, 5]}],
     "cameras": [{"type": "perspective", "perspective": {"yfov": 0.7, "aspectRatio": 1.0, "znear": 0.1}}],
     "meshes": [{"primitives": prims}],
     "materials": [
        {"name": "red", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.2, 0.2, 1], "metallicFactor": 0, "roughnessFactor": 1}},
        {"name": "grey", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0, "roughnessFactor": 1}},
        {"name": "green", "pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.7, 0.3, 1], "metallicFactor": 0, "roughnessFactor": 1}}],
     "buffers": [{"byteLength": len(buf), "uri": "data:application/octet-stream;base64," + base64.b64encode(buf).decode()}],
     "bufferViews": views, "accessors": acc}
open('tests/data/gltf/room.gltf', 'w').write(json.dumps(g, indent=1) + '\n')
