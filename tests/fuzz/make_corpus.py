#!/usr/bin/env python3
"""Writes the fuzz targets' seed corpus (corpus/<target>/) and the inputs of past defects
(regressions/<target>/), small and deterministic (stdlib only). Run from anywhere:

  tests/fuzz/make_corpus.py

The seeds cover each target's main paths: glTF as .glb and as .gltf with data: URIs (from
memory there is no folder to read from), sparse accessors, a node hierarchy, a camera; triangle
soups with rays; EXR files and pixel blocks. The regressions are the crafted files that
crashed, hung or exhausted memory before (issue 12), kept so that they never do again.
"""

import base64
import json
import os
import shutil
import struct
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "data")


def write(kind, target, name, data):
    folder = os.path.join(HERE, kind, target)
    os.makedirs(folder, exist_ok=True)
    with open(os.path.join(folder, name), "wb") as f:
        f.write(data if isinstance(data, bytes) else data.encode())


# ---- glTF: an emissive quad over a diffuse floor triangle, in one buffer
QUAD = [(-1, 2, -1), (1, 2, -1), (1, 2, 1), (-1, 2, 1)]
FLOOR = [(-3, 0, -3), (3, 0, -3), (0, 0, 3)]


def scene_json(buffer_uri, nbytes, sparse=False, hierarchy=False):
    accessors = [
        {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
         "min": [-1, 2, -1], "max": [1, 2, 1]},
        {"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"},
        {"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC3",
         "min": [-3, 0, -3], "max": [3, 0, 3]},
    ]
    if sparse:  # the floor's third vertex moved by a sparse substitution
        accessors[2]["max"] = [3, 0, 2]
        accessors[2]["sparse"] = {"count": 1, "indices": {"bufferView": 3, "componentType": 5125},
                                  "values": {"bufferView": 4}}
    nodes = [{"mesh": 0}, {"mesh": 1}, {"camera": 0, "translation": [0, 1, 6]}]
    if hierarchy:
        nodes = [{"children": [1, 2], "scale": [2, 2, 2], "rotation": [0, 0.38268343, 0, 0.92387953]},
                 {"mesh": 0}, {"mesh": 1, "matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, -0.5, 0, 1]},
                 {"camera": 0, "translation": [0, 1, 6]}]
    doc = {
        "asset": {"version": "2.0", "generator": "mcpt tests/fuzz/make_corpus.py"},
        "extensionsUsed": ["KHR_materials_emissive_strength"],
        "scene": 0,
        "scenes": [{"nodes": [0, 3] if hierarchy else [0, 1, 2]}],
        "nodes": nodes,
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.7, "znear": 0.01}}],
        "meshes": [
            {"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]},
            {"primitives": [{"attributes": {"POSITION": 2}, "material": 1}]},
        ],
        "materials": [
            {"emissiveFactor": [1, 1, 1],
             "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4}}},
            {"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.5, 0.3, 1]}},
        ],
        "accessors": accessors,
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 12},
            {"buffer": 0, "byteOffset": 60, "byteLength": 36},
            {"buffer": 0, "byteOffset": 96, "byteLength": 4},
            {"buffer": 0, "byteOffset": 100, "byteLength": 12},
        ],
        "buffers": [{"byteLength": nbytes}],
    }
    if buffer_uri is not None:
        doc["buffers"][0]["uri"] = buffer_uri
    return doc


def scene_bin():
    b = b"".join(struct.pack("<3f", *v) for v in QUAD)
    b += struct.pack("<6H", 0, 2, 1, 0, 3, 2)
    b += b"".join(struct.pack("<3f", *v) for v in FLOOR)
    b += struct.pack("<I", 2) + struct.pack("<3f", 0, 0, 2)
    return b


def glb(doc, binary=b""):
    text = json.dumps(doc, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    binary += b"\0" * (-len(binary) % 4)
    chunks = struct.pack("<I", len(text)) + b"JSON" + text
    if binary:
        chunks += struct.pack("<I", len(binary)) + b"BIN\0" + binary
    return struct.pack("<III", 0x46546C67, 2, 12 + len(chunks)) + chunks


def data_uri(b):
    return "data:application/octet-stream;base64," + base64.b64encode(b).decode()


def gltf_files():
    b = scene_bin()
    write("corpus", "gltf", "quad.glb", glb(scene_json(None, len(b)), b))
    write("corpus", "gltf", "quad_sparse.gltf", json.dumps(scene_json(data_uri(b), len(b), sparse=True)))
    write("corpus", "gltf", "quad_hierarchy.glb", glb(scene_json(None, len(b), hierarchy=True), b))
    # The floor with glTF's material layers (clearcoat and sheen).
    layers = scene_json(None, len(b))
    layers["extensionsUsed"] += ["KHR_materials_clearcoat", "KHR_materials_sheen"]
    layers["materials"][1]["extensions"] = {
        "KHR_materials_clearcoat": {"clearcoatFactor": 1, "clearcoatRoughnessFactor": 0.2},
        "KHR_materials_sheen": {"sheenColorFactor": [0.5, 0.5, 1], "sheenRoughnessFactor": 0.5}}
    write("corpus", "gltf", "quad_layers.glb", glb(layers, b))
    # The box also as gltfpack -cc (meshopt, quantized) and gltf-transform draco wrote it.
    for name in ("cube_box.glb", "emissive_triangle.gltf", "cube_box_meshopt.glb",
                 "cube_box_draco.glb"):
        shutil.copy(os.path.join(DATA, name), os.path.join(HERE, "corpus", "gltf", name))
    # Past defects: JSON nested 30,000 deep (stack overflow in the parser) ...
    deep = scene_json(None, len(b))
    text = json.dumps(deep, separators=(",", ":"))
    text = text[:-1] + ',"extras":' + "[" * 30000 + "]" * 30000 + "}"
    write("regressions", "gltf", "deep_nesting.gltf", text)
    chunk = text.encode() + b" " * (-len(text) % 4)
    write("regressions", "gltf", "deep_nesting.glb",
          struct.pack("<III", 0x46546C67, 2, 20 + len(chunk)) + struct.pack("<I", len(chunk)) + b"JSON" + chunk)
    # ... an accessor without a bufferView and a count near the cap (gigabytes allocated) ...
    huge = scene_json(None, len(b))
    del huge["accessors"][2]["bufferView"]
    huge["accessors"][2]["count"] = 250000000
    write("regressions", "gltf", "huge_accessor.glb", glb(huge, b))
    # ... a sparse accessor whose count far exceeds its views (3 GB before its own check) ...
    sparse = scene_json(None, len(b), sparse=True)
    sparse["accessors"][2]["count"] = 200000000
    sparse["accessors"][2]["sparse"]["count"] = 200000000
    write("regressions", "gltf", "huge_sparse.glb", glb(sparse, b))
    # ... and buffer URIs that leave the scene's folder (from memory: no file system at all).
    for name, uri in (("uri_absolute.gltf", "/etc/passwd"), ("uri_parent.gltf", "../../../../etc/passwd"),
                      ("uri_device.gltf", "/dev/zero")):
        write("regressions", "gltf", name, json.dumps(scene_json(uri, len(b))))


# ---- k-d tree: 4 option bytes, 9 floats per triangle, then rays (6 floats each)
def kdtree_files():
    cube = []
    for axis in range(3):
        for side in (-1.0, 1.0):
            u, v = (axis + 1) % 3, (axis + 2) % 3
            corners = []
            for a, c in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                p = [0.0, 0.0, 0.0]
                p[axis], p[u], p[v] = side, a, c
                corners.append(p)
            cube += [corners[0] + corners[1] + corners[2], corners[0] + corners[2] + corners[3]]
    rays = [[0, 0, 0, 1, 0.3, 0.2], [5, 0.5, 0.5, -1, 0, 0], [0.25, 4, -0.5, 0, -1, 0.01],
            [1, 1, 1, -1, -1, -1], [0, 0, 5, 0, 0, -1], [2, 2, 2, 1, 1, 1]]
    tris = b"".join(struct.pack("<9f", *t) for t in cube)
    rb = b"".join(struct.pack("<6f", *r) for r in rays)
    for kind in range(4):
        write("corpus", "kdtree", f"cube_kind{kind}", bytes([kind, 8, 0, len(rays) << 1]) + tris + rb)
    # A staircase of stacked, touching and in-plane triangles (shared split planes).
    stairs = []
    for i in range(16):
        y, x = i * 0.25, i * 0.25
        stairs += [[x, y, -1, x + 0.25, y, -1, x + 0.25, y, 1], [x, y, -1, x + 0.25, y, 1, x, y, 1],
                   [x + 0.25, y, -1, x + 0.25, y + 0.25, -1, x + 0.25, y + 0.25, 1]]
    sb = b"".join(struct.pack("<9f", *t) for t in stairs)
    srays = [[-1, 2, 0, 1, -0.5, 0.1], [2, 5, 0, 0, -1, 0], [1, 1.0, 0, 1, 0, 0]]
    write("corpus", "kdtree", "stairs_sah", bytes([0, 63, 0, len(srays) << 1]) + sb +
          b"".join(struct.pack("<6f", *r) for r in srays))
    # Non-finite, huge, denormal and degenerate triangles (no rays: the builder alone).
    inf, nan = float("inf"), float("nan")
    odd = [[nan, 0, 0, 1, 0, 0, 0, 1, 0], [inf, -inf, 0, 1, 1, 1, 0, 0, 1],
           [3e38, 3e38, 3e38, -3e38, -3e38, -3e38, 3e38, -3e38, 0],
           [1e-40, 0, 0, 0, 1e-40, 0, 0, 0, 1e-40], [1, 1, 1, 1, 1, 1, 1, 1, 1],
           [0, 0, 0, 1, 1, 1, 2, 2, 2]]
    write("corpus", "kdtree", "odd_values", bytes([0, 20, 1, 0]) + b"".join(struct.pack("<9f", *t) for t in odd))


# ---- images: byte 0 odd = pixel block to write; even = an EXR file to read
def exr(width, height, rgb):
    def attr(name, kind, value):
        return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(value)) + value

    channels = b"".join(c + b"\0" + struct.pack("<iB3xii", 2, 0, 1, 1) for c in (b"B", b"G", b"R")) + b"\0"
    box = struct.pack("<4i", 0, 0, width - 1, height - 1)
    header = struct.pack("<ii", 20000630, 2)
    header += attr("channels", "chlist", channels) + attr("compression", "compression", b"\0")
    header += attr("dataWindow", "box2i", box) + attr("displayWindow", "box2i", box)
    header += attr("lineOrder", "lineOrder", b"\0") + attr("pixelAspectRatio", "float", struct.pack("<f", 1))
    header += attr("screenWindowCenter", "v2f", struct.pack("<2f", 0, 0))
    header += attr("screenWindowWidth", "float", struct.pack("<f", 1)) + b"\0"
    offset = len(header) + 8 * height
    table, lines = b"", b""
    for y in range(height):
        row = rgb[y * width * 3:(y + 1) * width * 3]
        data = b"".join(struct.pack("<%df" % width, *row[c::3]) for c in (2, 1, 0))
        table += struct.pack("<Q", offset + len(lines))
        lines += struct.pack("<ii", y, len(data)) + data
    return header + table + lines


def image_files():
    pixels = [0.0, 0.5, 1.0, 2.0, 1e-40, 65504.0, 0.25, 0.125, 3.0, 0.01, 0.7, 0.9]
    # (No .exr extension: .gitignore leaves those out.)
    write("corpus", "image", "read_2x2", b"\0" + exr(2, 2, pixels))
    write("corpus", "image", "read_3x1", b"\2" + exr(3, 1, pixels[:9]))
    block = struct.pack("<12f", *pixels[:11], float("nan"))
    write("corpus", "image", "write_2x2", b"\1" + bytes([1, 1]) + block)
    write("corpus", "image", "write_5x3", b"\3" + bytes([4, 2]) + struct.pack("<3f", float("inf"), -1.0, 0.5) * 15)


def hdr(width, height, rows):
    """A Radiance .hdr: the header, then `rows` (bytes) as they are."""
    return b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n" % (height, width) + rows


def environment_files():
    pixels = [0.0, 0.5, 1.0, 2.0, 1e-3, 6.0e4, 0.25, 0.125, 3.0, 0.01, 0.7, 0.9]
    write("corpus", "environment", "rgb_2x2_exr", exr(2, 2, pixels))
    # Run-length encoded rows of 8: per channel a run of 5 and a dump of 3.
    row = b"\2\2\0\x08" + (b"\x85\x80" + b"\x03\x81\x82\x83") * 4
    write("corpus", "environment", "rle_8x2.hdr", hdr(8, 2, row * 2))
    write("corpus", "environment", "flat_4x2.hdr", hdr(4, 2, b"\x80\x40\x20\x81" * 8))
    # The hang of issue 36: a dump of length 0, then the end of the file (and stray bytes).
    write("regressions", "environment", "rle_zero_dump.hdr", hdr(64, 4, b"\2\2\0\x40\0"))
    write("regressions", "environment", "rle_zero_dump_stray.hdr", hdr(64, 4, b"\2\2\0\x40\0abc"))


def fnv1a(data, h=0xcbf29ce484222325):
    for b in data:
        h = ((h ^ b) * 0x100000001b3) & 0xFFFFFFFFFFFFFFFF
    return h


def checkpoint(width, height, spp, first=0, exact=False, text="mcpt=seed\nsamples=all\n"):
    """A checkpoint (common/render/checkpoint.cpp's format 2) of constant sums."""
    n = width * height
    body = b"MCPTCKPT" + struct.pack("<II", 2, len(text)) + text.encode()
    body += struct.pack("<IIQQddQI", width, height, spp, 0, float(n * spp), 0.5, first, int(exact))
    body += struct.pack("<%dd" % (3 * n), *([0.5 * spp] * (3 * n)))
    body += struct.pack("<%dd" % (3 * n), *([0.25 * spp] * (3 * n)))
    body += struct.pack("<%dd" % n, *([0.0] * n))
    if exact:
        body += (struct.pack("<Q", 1 << 40) + b"\0" * 8) * (6 * n)
    return body + struct.pack("<Q", fnv1a(body))


def checkpoint_files():
    write("corpus", "checkpoint", "sums_3x2", checkpoint(3, 2, 16))
    write("corpus", "checkpoint", "exact_2x2", checkpoint(2, 2, 16, exact=True))
    write("corpus", "checkpoint", "part_1x1", checkpoint(1, 1, 64, 64, text="samples=64-128 of 128\n"))
    # Issue 36: headers that announced more than the file holds (read whole before).
    big = checkpoint(1, 1, 16)
    write("regressions", "checkpoint", "fingerprint_1gib", big[:12] + struct.pack("<I", 1 << 30) + big[16:])
    at = 16 + len("mcpt=seed\nsamples=all\n")  # width and height follow the fingerprint
    write("regressions", "checkpoint", "image_16384_squared", big[:at] + struct.pack("<II", 16384, 16384) + big[at + 8:])


if __name__ == "__main__":
    shutil.rmtree(os.path.join(HERE, "corpus"), ignore_errors=True)  # regressions/ also keeps
    # the inputs the fuzzers found, written there by hand with their fixes
    gltf_files()
    kdtree_files()
    image_files()
    environment_files()
    checkpoint_files()
