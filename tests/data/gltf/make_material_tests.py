#!/usr/bin/env python3
"""Writes the small glTF files the material import tests read (tests/scene/io/gltf_material_test.cpp).

Each is a quad x, z in [-1, 1] at y = 0 facing +y, its buffers and PNG textures embedded as data:
URIs, so that the expected values in the tests can be computed from the numbers written here.
Run from this folder: python3 make_material_tests.py
"""
import base64
import json
import math
import struct
import zlib


def png(width, height, rgb):
    """An 8-bit RGB PNG of rows from the top, each texel an (r, g, b) tuple."""
    raw = b"".join(b"\x00" + bytes(c for texel in rgb[y * width:(y + 1) * width] for c in texel)
                   for y in range(height))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(
            ">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def data_uri(mime, data):
    return "data:" + mime + ";base64," + base64.b64encode(data).decode()


CORNERS = [(-1.0, 0.0, -1.0), (1.0, 0.0, -1.0), (1.0, 0.0, 1.0), (-1.0, 0.0, 1.0)]
INDICES = [0, 2, 1, 0, 3, 2]  # counter-clockwise seen from +y


def quad(attributes):
    """A glTF document's mesh part: POSITION, NORMAL (+y) and `attributes` (name -> (type, values
    per corner)), one buffer holding them all and the indices."""
    blob = b""
    accessors, views, attrs = [], [], {}
    columns = {"VEC2": 2, "VEC3": 3, "VEC4": 4}

    def add(name, kind, values):
        nonlocal blob
        data = b"".join(struct.pack("<" + "f" * columns[kind], *v) for v in values)
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data)})
        accessor = {"bufferView": len(views) - 1, "componentType": 5126, "count": len(values),
                    "type": kind}
        if name == "POSITION":
            accessor["min"] = [-1.0, 0.0, -1.0]
            accessor["max"] = [1.0, 0.0, 1.0]
        accessors.append(accessor)
        attrs[name] = len(accessors) - 1
        blob += data

    add("POSITION", "VEC3", CORNERS)
    add("NORMAL", "VEC3", [(0.0, 1.0, 0.0)] * 4)
    for name, (kind, values) in attributes.items():
        add(name, kind, values)
    index_data = struct.pack("<6H", *INDICES)
    views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(index_data)})
    accessors.append({"bufferView": len(views) - 1, "componentType": 5123, "count": 6,
                      "type": "SCALAR"})
    blob += index_data
    return {
        "meshes": [{"primitives": [{"attributes": attrs, "indices": len(accessors) - 1,
                                    "material": 0}]}],
        "buffers": [{"byteLength": len(blob),
                     "uri": data_uri("application/octet-stream", blob)}],
        "bufferViews": views,
        "accessors": accessors,
    }


def uv0():
    """glTF texture coordinates ((x + 1) / 2, (z + 1) / 2): v grows along +z."""
    return ("VEC2", [((x + 1) / 2, (z + 1) / 2) for x, _, z in CORNERS])


def document(attributes, material, images, extra_nodes=(), extensions=None, samplers=None):
    doc = {"asset": {"version": "2.0"}, "scene": 0,
           "scenes": [{"nodes": list(range(1 + len(extra_nodes)))}],
           "nodes": [{"mesh": 0}] + list(extra_nodes)}
    doc.update(quad(attributes))
    doc["materials"] = [material]
    doc["images"] = [{"uri": data_uri("image/png", image)} for image in images]
    doc["textures"] = [{"source": i, "sampler": 0} for i in range(len(images))]
    doc["samplers"] = samplers or [{}]
    used = set()
    text = json.dumps(material)
    for name in ("KHR_texture_transform", "KHR_materials_emissive_strength", "KHR_materials_ior",
                 "KHR_materials_transmission", "KHR_lights_punctual"):
        if name in text or (extensions and name in json.dumps(extensions)):
            used.add(name)
    if used:
        doc["extensionsUsed"] = sorted(used)
    if extensions:
        doc["extensions"] = extensions
    return doc


def write(name, doc):
    with open(name, "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")


# Metallic-roughness, transmission, IOR and emissive strength. A 2 x 1 data texture: texel
# (R, G, B) = (255, 200, 50) on the left (u < 1/2), (51, 100, 250) on the right.
write("material_params.gltf", document(
    {"TEXCOORD_0": uv0()},
    {"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0.8,
                              "roughnessFactor": 0.5,
                              "metallicRoughnessTexture": {"index": 0}},
     "emissiveFactor": [0.2, 0.4, 0.8],
     "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 5.0},
                    "KHR_materials_ior": {"ior": 1.7},
                    "KHR_materials_transmission": {"transmissionFactor": 0.6,
                                                   "transmissionTexture": {"index": 0}}}},
    [png(2, 1, [(255, 200, 50), (51, 100, 250)])]))


def sun(b_degrees, towards):
    """A node holding directional light 0, shining from unit direction `towards` (tilted by b from
    +y): its -z axis is -towards. Columns x', y', z' = towards, right-handed."""
    z = towards
    x = (0.0, 0.0, 1.0) if abs(z[2]) < 0.5 else (1.0, 0.0, 0.0)
    d = sum(a * b for a, b in zip(x, z))
    x = tuple(a - d * b for a, b in zip(x, z))
    n = math.sqrt(sum(a * a for a in x))
    x = tuple(a / n for a in x)
    y = (z[1] * x[2] - z[2] * x[1], z[2] * x[0] - z[0] * x[2], z[0] * x[1] - z[1] * x[0])
    return {"matrix": [*x, 0, *y, 0, *z, 0, 0, 0, 0, 1],
            "extensions": {"KHR_lights_punctual": {"light": 0}}}


LIGHTS = {"KHR_lights_punctual": {"lights": [{"type": "directional", "intensity": 683}]}}
B = math.radians(40.0)


def normal_mapped(name, texel, towards, tangents=None):
    attributes = {"TEXCOORD_0": uv0()}
    if tangents:
        attributes["TANGENT"] = ("VEC4", [tangents] * 4)
    write(name, document(
        attributes,
        {"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0,
                                  "roughnessFactor": 1},
         "normalTexture": {"index": 0}},
        [png(1, 1, [texel])], extra_nodes=[sun(B, towards)], extensions=LIGHTS))


# A normal map tilting the normal by 30 degrees towards +u (red), and one towards image down (green
# below 128: glTF's +y is the image's up, decreasing glTF v, here -z, so the tilt is towards +z,
# the side the default camera looks from); the sun 40 degrees from +y on the side of the tilt.
# Bytes round(255 (m + 1) / 2) of the tilted normal m.
def byte(x):
    return round(255 * (x + 1) / 2)


A = math.radians(30.0)
normal_mapped("normal_map_u.gltf", (byte(math.sin(A)), 128, byte(math.cos(A))),
              (math.sin(B), math.cos(B), 0.0))
normal_mapped("normal_map_v.gltf", (128, byte(-math.sin(A)), byte(math.cos(A))),
              (0.0, math.cos(B), math.sin(B)))
# The file's own tangents (+z, w = -1: the bitangent -(y x z) = -x): red tilts towards +z.
normal_mapped("normal_map_tangents.gltf", (byte(math.sin(A)), 128, byte(math.cos(A))),
              (0.0, math.cos(B), math.sin(B)), tangents=(0.0, 0.0, 1.0, -1.0))

# A texture transform on the second coordinate set, and vertex colours. A 2 x 2 checker (rows from
# the top): (255, 0, 0) (0, 255, 0) / (0, 0, 255) (255, 255, 255).
write("texture_transform.gltf", document(
    {"TEXCOORD_0": uv0(),
     "TEXCOORD_1": ("VEC2", [(0.3 + 0.2 * x, 0.6 - 0.1 * z) for x, _, z in CORNERS]),
     "COLOR_0": ("VEC4", [(0.5 + 0.25 * x, 0.5 + 0.25 * z, 1.0, 1.0) for x, _, z in CORNERS])},
    {"pbrMetallicRoughness": {
        "baseColorFactor": [0.8, 0.6, 1.0, 1],
        "baseColorTexture": {"index": 0, "texCoord": 0,
                             "extensions": {"KHR_texture_transform": {
                                 "offset": [0.25, 0.1], "rotation": 0.3, "scale": [2.0, 0.5],
                                 "texCoord": 1}}}}},
    [png(2, 2, [(255, 0, 0), (0, 255, 0), (0, 0, 255), (255, 255, 255)])]))
