#!/usr/bin/env python3
"""Write mcpt's textured test scene as glTF 2.0 binary, laid out as Blender exports (stdlib only).

  make_textured_glb.py DST.glb

A Cornell-like room (x, z in [-1, 1], y in [0, 2], open towards +z) under a node hierarchy
(rotated and scaled parents, as Blender writes them), with every material input mcpt reads:
  floor      checker base color texture (sRGB, REPEAT, 4x4 tiles), a rough dielectric
  back wall  tangent-space normal texture (bumps), per-vertex normals and texture coordinates
  sphere     UV sphere with smooth normals, gold metal, metallic-roughness texture (stripes of
             roughness 0.15 to 0.6), CLAMP_TO_EDGE
  screen     alphaMode MASK quad with round holes (base color alpha), NEAREST magnification
  light      emissive quad with an emissive texture (a warm-to-white gradient)
Images are PNG files embedded in the binary chunk (bufferView + mimeType), as Blender's .glb.
"""

import json
import math
import struct
import sys
import zlib
from array import array

FLOAT, UINT, USHORT = 5126, 5125, 5123
REPEAT, CLAMP, MIRROR = 10497, 33071, 33648
LINEAR, NEAREST = 9729, 9728


def png(width, height, rgba):
    """An 8-bit RGBA PNG of `rgba` (rows top first, 4 ints per texel)."""
    raw = bytearray()
    for y in range(height):
        raw.append(0)  # filter: none
        raw.extend(bytes(rgba[4 * width * y:4 * width * (y + 1)]))

    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    header = struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) +
            chunk(b"IDAT", zlib.compress(bytes(raw), 9)) + chunk(b"IEND", b""))


def image(width, height, texel):
    out = []
    for y in range(height):
        for x in range(width):
            out.extend(max(0, min(255, int(round(c)))) for c in texel(x, y))
    return png(width, height, out)


def checker(x, y):
    light = ((x // 8) + (y // 8)) % 2 == 0
    return (230, 225, 210, 255) if light else (60, 70, 90, 255)


def bumps(x, y):
    # Normal map of a grid of round bumps: tangent-space normal from a height field's slope.
    cx, cy = (x % 16) - 7.5, (y % 16) - 7.5
    r2 = cx * cx + cy * cy
    h = max(0.0, 1.0 - r2 / 49.0)
    dx, dy = -2.0 * cx / 49.0 * 4.0 * (h > 0), -2.0 * cy / 49.0 * 4.0 * (h > 0)
    # +y of the map points up the image: height grows toward -image y.
    n = (-dx, dy, 1.0)
    length = math.sqrt(sum(c * c for c in n))
    return tuple(127.5 + 127.5 * c / length for c in n) + (255,)


def metal_rough(x, y):
    roughness = 0.15 + 0.45 * ((y // 8) % 4) / 3.0  # four bands
    return (0, int(round(255 * roughness)), 255, 255)  # g: roughness, b: metallic


def holes(x, y):
    cx, cy = (x % 16) - 7.5, (y % 16) - 7.5
    inside = cx * cx + cy * cy < 25.0
    return (200, 60, 50, 0 if inside else 255)


def glow(x, y):
    t = x / 15.0
    return (255, int(180 + 75 * t), int(120 + 135 * t), 255)


def quad(corners, uv_scale, normal):
    positions = [c for v in corners for c in v]
    uvs = [0, uv_scale, uv_scale, uv_scale, uv_scale, 0, 0, 0]
    normals = list(normal) * 4
    return positions, normals, uvs, [0, 1, 2, 0, 2, 3]


def uv_sphere(radius, rings=24, segments=48):
    positions, normals, uvs, tris = [], [], [], []
    for r in range(rings + 1):
        theta = math.pi * r / rings
        for s in range(segments + 1):
            phi = 2 * math.pi * s / segments
            n = (math.sin(theta) * math.cos(phi), math.cos(theta), -math.sin(theta) * math.sin(phi))
            positions += [radius * c for c in n]
            normals += list(n)
            uvs += [s / segments, r / rings]
    for r in range(rings):
        for s in range(segments):
            a = r * (segments + 1) + s
            b = a + segments + 1
            if r > 0:
                tris += [a, b, a + 1]
            if r < rings - 1:
                tris += [a + 1, b, b + 1]
    return positions, normals, uvs, tris


def build():
    gltf = {"asset": {"version": "2.0", "generator": "mcpt scripts/make_textured_glb.py"},
            "extensionsUsed": ["KHR_materials_emissive_strength", "KHR_materials_specular"],
            "scene": 0, "scenes": [{"name": "textured", "nodes": [0, 1, 2]}],
            "nodes": [], "meshes": [], "materials": [], "accessors": [], "bufferViews": [],
            "buffers": [], "images": [], "samplers": [], "textures": []}
    blob = bytearray()

    def view(data, target=None):
        while len(blob) % 4:
            blob.append(0)
        v = {"buffer": 0, "byteOffset": len(blob), "byteLength": len(data)}
        if target:
            v["target"] = target
        blob.extend(data)
        gltf["bufferViews"].append(v)
        return len(gltf["bufferViews"]) - 1

    def accessor(values, kind, comps):
        data = array("f" if kind == FLOAT else "I", values)
        if sys.byteorder != "little":
            data.byteswap()
        target = 34963 if kind == UINT else 34962
        acc = {"bufferView": view(data.tobytes(), target), "componentType": kind,
               "count": len(values) // comps, "type": {1: "SCALAR", 2: "VEC2", 3: "VEC3"}[comps]}
        if comps == 3:
            acc["min"] = [min(values[k::3]) for k in range(3)]
            acc["max"] = [max(values[k::3]) for k in range(3)]
        gltf["accessors"].append(acc)
        return len(gltf["accessors"]) - 1

    def texture(name, width, height, texel, wrap=REPEAT, mag=LINEAR):
        gltf["images"].append({"name": name, "mimeType": "image/png",
                               "bufferView": view(image(width, height, texel))})
        gltf["samplers"].append({"magFilter": mag, "minFilter": LINEAR, "wrapS": wrap,
                                 "wrapT": wrap})
        gltf["textures"].append({"sampler": len(gltf["samplers"]) - 1,
                                 "source": len(gltf["images"]) - 1})
        return len(gltf["textures"]) - 1

    def material(m):
        gltf["materials"].append(m)
        return len(gltf["materials"]) - 1

    def mesh(name, geometry, mat):
        positions, normals, uvs, tris = geometry
        attributes = {"POSITION": accessor(positions, FLOAT, 3)}
        if normals:
            attributes["NORMAL"] = accessor(normals, FLOAT, 3)
        if uvs:
            attributes["TEXCOORD_0"] = accessor(uvs, FLOAT, 2)
        gltf["meshes"].append({"name": name, "primitives": [{
            "attributes": attributes, "indices": accessor(tris, UINT, 1), "material": mat}]})
        return len(gltf["meshes"]) - 1

    # Nodes 0-2 are the roots (room, props, camera); children follow.
    children = []

    def node(n):
        children.append(n)
        return 2 + len(children)

    lambert = {"KHR_materials_specular": {"specularFactor": 0.0}}
    # Materials.
    floor_m = material({"name": "checker floor", "pbrMetallicRoughness": {
        "baseColorTexture": {"index": texture("checker", 64, 64, checker)},
        "metallicFactor": 0.0, "roughnessFactor": 0.6}})
    wall_m = material({"name": "bumpy wall", "normalTexture": {
        "index": texture("bumps", 64, 64, bumps)}, "pbrMetallicRoughness": {
        "baseColorFactor": [0.75, 0.75, 0.72, 1.0], "metallicFactor": 0.0,
        "roughnessFactor": 0.35}})
    white = material({"name": "white", "extensions": lambert, "pbrMetallicRoughness": {
        "baseColorFactor": [0.73, 0.73, 0.73, 1.0], "metallicFactor": 0.0}})
    red = material({"name": "red", "extensions": lambert, "pbrMetallicRoughness": {
        "baseColorFactor": [0.65, 0.05, 0.05, 1.0], "metallicFactor": 0.0}})
    green = material({"name": "green", "extensions": lambert, "pbrMetallicRoughness": {
        "baseColorFactor": [0.12, 0.45, 0.15, 1.0], "metallicFactor": 0.0}})
    gold = material({"name": "striped gold", "pbrMetallicRoughness": {
        "baseColorFactor": [1.0, 0.78, 0.34, 1.0], "metallicFactor": 1.0, "roughnessFactor": 1.0,
        "metallicRoughnessTexture": {"index": texture("stripes", 32, 32, metal_rough, CLAMP)}}})
    screen = material({"name": "perforated screen", "alphaMode": "MASK", "alphaCutoff": 0.5,
                       "doubleSided": True, "pbrMetallicRoughness": {
                           "baseColorTexture": {"index": texture("holes", 64, 64, holes, REPEAT,
                                                                 NEAREST)},
                           "metallicFactor": 0.0, "roughnessFactor": 0.8}})
    lamp = material({"name": "lamp", "emissiveFactor": [1.0, 1.0, 1.0],
                     "emissiveTexture": {"index": texture("glow", 16, 16, glow, MIRROR)},
                     "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 17.0},
                                    **lambert},
                     "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1],
                                              "metallicFactor": 0.0}})

    # Room meshes (in the room node's frame, which the scene scales by 2 about the origin).
    h = 0.5
    room = [
        ("floor", quad([(-h, 0, h), (h, 0, h), (h, 0, -h), (-h, 0, -h)], 4, (0, 1, 0)), floor_m),
        ("ceiling", quad([(-h, 1, -h), (h, 1, -h), (h, 1, h), (-h, 1, h)], 1, (0, -1, 0)), white),
        ("back", quad([(-h, 0, -h), (h, 0, -h), (h, 1, -h), (-h, 1, -h)], 2, (0, 0, 1)), wall_m),
        ("left", quad([(-h, 0, h), (-h, 0, -h), (-h, 1, -h), (-h, 1, h)], 1, (1, 0, 0)), red),
        ("right", quad([(h, 0, -h), (h, 0, h), (h, 1, h), (h, 1, -h)], 1, (-1, 0, 0)), green),
        ("lamp", quad([(-0.12, 0.995, -0.12), (0.12, 0.995, -0.12), (0.12, 0.995, 0.12),
                       (-0.12, 0.995, 0.12)], 1, (0, -1, 0)), lamp),  # emits downward
    ]
    room_children = [node({"name": name, "mesh": mesh(name, geo, mat)}) for name, geo, mat in room]
    # Props: a sphere, and a perforated screen standing at an angle.
    sphere = node({"name": "sphere", "mesh": mesh("sphere", uv_sphere(0.35), gold),
                   "translation": [-0.35, 0.35, -0.3], "rotation": [0.0, 0.3826834, 0.0, 0.9238795]})
    screen_geo = quad([(-0.3, 0, 0), (0.3, 0, 0), (0.3, 0.8, 0), (-0.3, 0.8, 0)], 2, (0, 0, 1))
    screen_node = node({"name": "screen", "mesh": mesh("screen", screen_geo, screen),
                        "translation": [0.45, 0.0, 0.2],
                        "rotation": [0.0, -0.258819, 0.0, 0.9659258]})
    gltf["nodes"] = [
        {"name": "room", "scale": [2.0, 2.0, 2.0], "children": room_children},
        {"name": "props", "children": [sphere, screen_node]},
        {"name": "camera", "camera": 0, "translation": [0.0, 1.0, 3.9]},
    ] + children
    gltf["cameras"] = [{"name": "camera", "type": "perspective",
                        "perspective": {"yfov": 0.6911, "znear": 0.01}}]
    return gltf, blob


def write(path):
    gltf, blob = build()
    while len(blob) % 4:
        blob.append(0)
    gltf["buffers"] = [{"byteLength": len(blob)}]
    text = json.dumps(gltf, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    total = 12 + 8 + len(text) + 8 + len(blob)
    with open(path, "wb") as f:
        f.write(struct.pack("<III", 0x46546C67, 2, total))
        f.write(struct.pack("<II", len(text), 0x4E4F534A) + text)
        f.write(struct.pack("<II", len(blob), 0x004E4942) + bytes(blob))


if __name__ == "__main__":
    if len(sys.argv) != 2:
        raise SystemExit(__doc__)
    write(sys.argv[1])
