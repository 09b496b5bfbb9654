#!/usr/bin/env python3
# Writes tests/data/gltf/alpha_modes.gltf (run from the repository root): the hand-written test
# model, its buffers and images as data URIs, so that the file is one self-contained text file.
import base64, json, struct, zlib
def png_rgba(w, h, pixels):
    raw = b''.join(b'\x00' + bytes(sum((list(p) for p in pixels[y*w:(y+1)*w]), [])) for y in range(h))
    def chunk(t, d): return struct.pack('>I', len(d)) + t + d + struct.pack('>I', zlib.crc32(t + d) & 0xffffffff)
    return b'\x89PNG\r\n\x1a\n' + chunk(b'IHDR', struct.pack('>IIBBBBB', w, h, 8, 6, 0, 0, 0)) + chunk(b'IDAT', zlib.compress(raw)) + chunk(b'IEND', b'')
cols = [255, 255, 0, 0, 0, 255, 255, 255]
png = png_rgba(8, 1, [(200, 120, 40, a) for a in cols])
# Four quads (positions, uvs with u = x - x0 along the columns, v = 1 - y), each two triangles.
def quad(x0, y0, w, h, z):
    p = [(x0, y0, z), (x0 + w, y0, z), (x0 + w, y0 + h, z), (x0, y0 + h, z)]
    t = [(0, 1), (1, 1), (1, 0), (0, 0)]
    return p, t
quads = [quad(-1, -1, 6, 3, -1), quad(0, 0, 1, 1, 0), quad(2, 0, 1, 1, 0), quad(3.5, 0, 1, 1, 0)]
buf = b''; views = []; accessors = []; prims = []
for k, (p, t) in enumerate(quads):
    pos = b''.join(struct.pack('<3f', *v) for v in p); uv = b''.join(struct.pack('<2f', *v) for v in t)
    idx = struct.pack('<6H', 0, 1, 2, 0, 2, 3) + b'\0\0'
    a = len(accessors)
    for data, target in ((pos, 34962), (uv, 34962), (idx, 34963)):
        views.append({"buffer": 0, "byteOffset": len(buf), "byteLength": len(data) if target == 34962 else 12, "target": target}); buf += data
    lo = [min(v[i] for v in p) for i in range(3)]; hi = [max(v[i] for v in p) for i in range(3)]
    accessors += [{"bufferView": a, "componentType": 5126, "count": 4, "type": "VEC3", "min": lo, "max": hi},
                  {"bufferView": a + 1, "componentType": 5126, "count": 4, "type": "VEC2"},
                  {"bufferView": a + 2, "componentType": 5123, "count": 6, "type": "SCALAR"}]
    prims.append({"attributes": {"POSITION": a, "TEXCOORD_0": a + 1}, "indices": a + 2, "material": k})
gltf = {
  "asset": {"version": "2.0", "generator": "tritrace tests (hand-written: alpha modes)"},
  "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
  "meshes": [{"primitives": prims}],
  "materials": [
    {"name": "wall", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0}},
    {"name": "mask", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0}, "alphaMode": "MASK", "alphaCutoff": 0.4},
    {"name": "blend", "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 0.3], "metallicFactor": 0}, "alphaMode": "BLEND"},
    {"name": "opaque", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "baseColorFactor": [1, 1, 1, 0.2], "metallicFactor": 0}}],
  "textures": [{"source": 0, "sampler": 0}],
  "samplers": [{"wrapS": 33071, "wrapT": 33071}],
  "images": [{"uri": "data:image/png;base64," + base64.b64encode(png).decode()}],
  "buffers": [{"byteLength": len(buf), "uri": "data:application/octet-stream;base64," + base64.b64encode(buf).decode()}],
  "bufferViews": views, "accessors": accessors}
open('tests/data/gltf/alpha_modes.gltf', 'w').write(json.dumps(gltf, indent=1) + '\n')
