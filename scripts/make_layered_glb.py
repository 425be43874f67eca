#!/usr/bin/env python3
"""The textured test scene with glTF's material layers (docs/materials.md): a clear coat
(KHR_materials_clearcoat, factor 1, roughness 0.1) on every other opaque material and a sheen
(KHR_materials_sheen, color (0.9, 0.7, 0.5), roughness 0.4) on the rest; emitters and glass
are left as they are.
Usage: scripts/make_layered_glb.py tests/data/textured.glb OUT.glb"""
import json
import struct
import sys


def main(src, dst):
    data = open(src, "rb").read()
    magic, version, _ = struct.unpack_from("<III", data, 0)
    json_len, json_type = struct.unpack_from("<II", data, 12)
    doc = json.loads(data[20:20 + json_len])
    rest = data[20 + json_len:]
    for i, m in enumerate(doc["materials"]):
        ext = m.setdefault("extensions", {})
        if "KHR_materials_transmission" in ext or m.get("emissiveFactor"):
            continue
        if i % 2 == 0:
            ext["KHR_materials_clearcoat"] = {"clearcoatFactor": 1.0,
                                              "clearcoatRoughnessFactor": 0.1}
        else:
            ext["KHR_materials_sheen"] = {"sheenColorFactor": [0.9, 0.7, 0.5],
                                          "sheenRoughnessFactor": 0.4}
    doc["extensionsUsed"] = doc.get("extensionsUsed", []) + ["KHR_materials_clearcoat",
                                                             "KHR_materials_sheen"]
    text = json.dumps(doc, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    header = struct.pack("<III", magic, version, 20 + len(text) + len(rest))
    open(dst, "wb").write(header + struct.pack("<II", len(text), json_type) + text + rest)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
