#!/usr/bin/env python3
"""Convert triangle meshes to glTF 2.0 binary (.glb) test scenes for mcpt (stdlib only).

  make_glb.py convert [--bare] SRC DST.glb   SRC: 'cube', a {positions, cells} .json,
                                             or a .ply / .ply.gz (ASCII or binary)
  make_glb.py check [--quick] [--bare|--box] FILE.glb...

The mesh is normalized to fit a box of size 1 (largest extent 1), centred on x = z = 0 and
standing on y = 0. Without --bare it is placed in a Cornell-like enclosure (x, z in [-1, 1],
y in [0, 2], open towards +z) with a 0.5 x 0.5 emissive ceiling quad and a camera at
(0, 1, 3.9) looking along -z. 'check' re-reads .glb files, validates them and prints the
triangle counts; --quick only validates the header and the scene kind (exit 1 on mismatch).
"""

import gzip
import json
import math
import os
import struct
import sys
import time
from array import array

GLB_MAGIC = 0x46546C67  # 'glTF'
CHUNK_JSON = 0x4E4F534A
CHUNK_BIN = 0x004E4942
FLOAT = 5126
UINT = 5125
ARRAY_BUFFER = 34962
ELEMENT_ARRAY_BUFFER = 34963

WALL_GREY = 0.73
MODEL_GREY = 0.8
LIGHT_STRENGTH = 15.0
LIGHT_HALF = 0.25
LIGHT_Y = 1.99
CAMERA_POS = [0.0, 1.0, 3.9]
CAMERA_YFOV = 0.6911
MODEL_LIFT = 1e-3  # keeps flat model bottoms off the floor plane (no coplanar faces)

PLY_TYPES = {
    "char": "b", "int8": "b", "uchar": "B", "uint8": "B",
    "short": "h", "int16": "h", "ushort": "H", "uint16": "H",
    "int": "i", "int32": "i", "uint": "I", "uint32": "I",
    "float": "f", "float32": "f", "double": "d", "float64": "d",
}


class ConvertError(Exception):
    pass


# ---------------------------------------------------------------------------- input meshes

def load_json_mesh(path):
    """{positions: [[x,y,z]...], cells: [[i,j,k,...]...]} -> (flat positions, flat triangles)."""
    with open(path) as f:
        data = json.load(f)
    positions = [float(c) for p in data["positions"] for c in p]
    tris = []
    for cell in data["cells"]:
        # Fan-triangulate polygons; drop points and lines
        for k in range(1, len(cell) - 1):
            tris += (cell[0], cell[k], cell[k + 1])
    return positions, tris


def parse_ply_header(blob):
    end = blob.find(b"end_header")
    if not blob.startswith(b"ply") or end < 0:
        raise ConvertError("not a PLY file")
    nl = blob.find(b"\n", end)
    body_start = nl + 1
    fmt = None
    elements = []  # [name, count, [(name, type) or (name, (count_type, item_type))]]
    for raw in blob[:end].decode("ascii", "replace").splitlines():
        words = raw.split()
        if not words or words[0] in ("ply", "comment", "obj_info"):
            continue
        if words[0] == "format":
            fmt = words[1]
        elif words[0] == "element":
            elements.append([words[1], int(words[2]), []])
        elif words[0] == "property":
            if words[1] == "list":
                elements[-1][2].append((words[4], (PLY_TYPES[words[2]], PLY_TYPES[words[3]])))
            else:
                elements[-1][2].append((words[2], PLY_TYPES[words[1]]))
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        raise ConvertError("unsupported PLY format %r" % fmt)
    return fmt, elements, body_start


def faces_to_triangles(counts_and_indices):
    """Fan-triangulate an iterable of index lists."""
    tris = []
    for poly in counts_and_indices:
        for k in range(1, len(poly) - 1):
            tris += (poly[0], poly[k], poly[k + 1])
    return tris


def load_ply_ascii(blob, elements, body_start):
    tokens = blob[body_start:].split()
    pos = 0
    positions, tris = None, None
    for name, count, props in elements:
        scalar_only = all(not isinstance(t, tuple) for _, t in props)
        if scalar_only:
            # Fixed-size records: slice the columns out directly
            n = len(props)
            block = tokens[pos:pos + n * count]
            pos += n * count
            if name == "vertex":
                cols = [p for p, _ in props]
                xyz = [block[cols.index(c)::n] for c in ("x", "y", "z")]
                positions = [0.0] * (3 * count)
                for k in range(3):
                    positions[k::3] = map(float, xyz[k])
            continue
        if name == "face" and len(props) == 1 and count > 0:
            # Fast path: all faces are triangles
            block = tokens[pos:pos + 4 * count]
            if len(block) == 4 * count and set(block[0::4]) == {b"3"}:
                pos += 4 * count
                ints = list(map(int, block))
                tris = [0] * (3 * count)
                for k in range(3):
                    tris[k::3] = ints[k + 1::4]
                continue
        # General records: walk token by token
        polys = []
        for _ in range(count):
            for pname, ptype in props:
                if isinstance(ptype, tuple):
                    n = int(tokens[pos])
                    values = [int(t) for t in tokens[pos + 1:pos + 1 + n]]
                    pos += 1 + n
                    if name == "face" and pname in ("vertex_indices", "vertex_index"):
                        polys.append(values)
                else:
                    pos += 1
        if name == "face":
            tris = faces_to_triangles(polys)
    return positions, tris


def load_ply_binary(blob, fmt, elements, body_start):
    endian = "<" if fmt == "binary_little_endian" else ">"
    off = body_start
    positions, tris = None, None
    for name, count, props in elements:
        scalar_only = all(not isinstance(t, tuple) for _, t in props)
        if scalar_only:
            # Fixed-size records: one struct per record
            rec = struct.Struct(endian + "".join(t for _, t in props))
            block = blob[off:off + rec.size * count]
            off += rec.size * count
            if name == "vertex":
                cols = [p for p, _ in props]
                ix, iy, iz = (cols.index(c) for c in ("x", "y", "z"))
                positions = []
                for r in rec.iter_unpack(block):
                    positions += (r[ix], r[iy], r[iz])
            continue
        if name == "face" and len(props) == 1 and count > 0:
            # Fast path: all faces are triangles
            ctype, itype = props[0][1]
            rec = struct.Struct(endian + ctype + "3" + itype)
            block = blob[off:off + rec.size * count]
            if len(block) == rec.size * count:
                recs = list(rec.iter_unpack(block))
                if all(r[0] == 3 for r in recs):
                    off += rec.size * count
                    tris = [i for r in recs for i in r[1:]]
                    continue
        # General records: walk property by property
        polys = []
        for _ in range(count):
            for pname, ptype in props:
                if isinstance(ptype, tuple):
                    (n,) = struct.unpack_from(endian + ptype[0], blob, off)
                    off += struct.calcsize(ptype[0])
                    values = list(struct.unpack_from(endian + str(n) + ptype[1], blob, off))
                    off += n * struct.calcsize(ptype[1])
                    if name == "face" and pname in ("vertex_indices", "vertex_index"):
                        polys.append(values)
                else:
                    off += struct.calcsize(ptype)
        if name == "face":
            tris = faces_to_triangles(polys)
    return positions, tris


def load_ply(path):
    opener = gzip.open if path.endswith(".gz") else open
    with opener(path, "rb") as f:
        blob = f.read()
    fmt, elements, body_start = parse_ply_header(blob)
    if fmt == "ascii":
        positions, tris = load_ply_ascii(blob, elements, body_start)
    else:
        positions, tris = load_ply_binary(blob, fmt, elements, body_start)
    if positions is None or tris is None:
        raise ConvertError("PLY file has no vertex or face element")
    return positions, tris


def cube_mesh():
    """Unit cube, 12 triangles, counter-clockwise seen from outside."""
    positions = [float(c) for i in range(8) for c in ((i & 1) - 0.5, (i >> 1 & 1) - 0.5,
                                                      (i >> 2 & 1) - 0.5)]
    quads = [(0, 4, 6, 2), (1, 3, 7, 5),   # -x, +x
             (0, 1, 5, 4), (2, 6, 7, 3),   # -y, +y
             (0, 2, 3, 1), (4, 5, 7, 6)]   # -z, +z
    tris = []
    for a, b, c, d in quads:
        tris += (a, b, c, a, c, d)
    return positions, tris


# ---------------------------------------------------------------------------- mesh processing

def clean_mesh(positions, tris):
    """Drop degenerate and out-of-range triangles and unreferenced vertices."""
    nv = len(positions) // 3
    a, b, c = tris[0::3], tris[1::3], tris[2::3]
    bad = [k for k in range(len(a)) if a[k] == b[k] or b[k] == c[k] or a[k] == c[k]
           or not (0 <= a[k] < nv and 0 <= b[k] < nv and 0 <= c[k] < nv)]
    if bad:
        skip = set(bad)
        keep = [k for k in range(len(a)) if k not in skip]
        tris = [i for k in keep for i in (a[k], b[k], c[k])]
    used = bytearray(nv)
    for i in tris:
        used[i] = 1
    unused = nv - sum(used)
    if unused:
        # Compact the vertex array and renumber the indices
        remap = [0] * nv
        kept = []
        for v in range(nv):
            if used[v]:
                remap[v] = len(kept) // 3
                kept += positions[3 * v:3 * v + 3]
        positions = kept
        tris = [remap[i] for i in tris]
    return positions, tris, len(bad), unused


def signed_volume(positions, tris):
    p = positions
    vol = 0.0
    for i, j, k in zip(tris[0::3], tris[1::3], tris[2::3]):
        ax, ay, az = p[3 * i], p[3 * i + 1], p[3 * i + 2]
        bx, by, bz = p[3 * j], p[3 * j + 1], p[3 * j + 2]
        cx, cy, cz = p[3 * k], p[3 * k + 1], p[3 * k + 2]
        vol += ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz) + az * (bx * cy - by * cx)
    return vol / 6.0


def normalize(positions):
    """Scale to largest extent 1, centre x and z on 0, put the lowest point at MODEL_LIFT."""
    cols = [positions[k::3] for k in range(3)]
    lo = [min(c) for c in cols]
    hi = [max(c) for c in cols]
    extent = max(h - l for l, h in zip(lo, hi))
    if not extent > 0:
        raise ConvertError("mesh has zero extent")
    s = 1.0 / extent
    offset = [-(lo[0] + hi[0]) / 2 * s, -lo[1] * s + MODEL_LIFT, -(lo[2] + hi[2]) / 2 * s]
    out = [0.0] * len(positions)
    for k in range(3):
        o = offset[k]
        out[k::3] = [x * s + o for x in cols[k]]
    return out


def quad(corners, inward):
    """Four corners (in order around the quad) -> 2 triangles whose normal faces `inward`."""
    v0, v1, v2 = corners[0], corners[1], corners[2]
    e1 = [v1[k] - v0[k] for k in range(3)]
    e2 = [v2[k] - v0[k] for k in range(3)]
    n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
         e1[0] * e2[1] - e1[1] * e2[0]]
    if sum(n[k] * inward[k] for k in range(3)) < 0:
        corners = corners[::-1]
    return corners, [0, 1, 2, 0, 2, 3]


def merge_quads(quads):
    positions, tris = [], []
    for corners, local in quads:
        base = len(positions) // 3
        positions += [float(c) for v in corners for c in v]
        tris += [base + i for i in local]
    return positions, tris


def enclosure_mesh():
    """Floor, ceiling, back, left and right walls; open towards +z."""
    return merge_quads([
        quad([(-1, 0, -1), (1, 0, -1), (1, 0, 1), (-1, 0, 1)], (0, 1, 0)),     # floor
        quad([(-1, 2, -1), (1, 2, -1), (1, 2, 1), (-1, 2, 1)], (0, -1, 0)),    # ceiling
        quad([(-1, 0, -1), (1, 0, -1), (1, 2, -1), (-1, 2, -1)], (0, 0, 1)),   # back
        quad([(-1, 0, -1), (-1, 0, 1), (-1, 2, 1), (-1, 2, -1)], (1, 0, 0)),   # left
        quad([(1, 0, -1), (1, 0, 1), (1, 2, 1), (1, 2, -1)], (-1, 0, 0)),      # right
    ])


def light_mesh():
    h, y = LIGHT_HALF, LIGHT_Y
    return merge_quads([quad([(-h, y, -h), (h, y, -h), (h, y, h), (-h, y, h)], (0, -1, 0))])


# ---------------------------------------------------------------------------- glTF writing

def material(name, grey, emissive=False):
    m = {"name": name,
         "pbrMetallicRoughness": {"baseColorFactor": [grey, grey, grey, 1.0],
                                  "metallicFactor": 0.0, "roughnessFactor": 1.0},
         # No specular layer: exactly Lambertian, as the thesis' scenes.
         "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}}}
    if emissive:
        m["emissiveFactor"] = [1.0, 1.0, 1.0]
        m["extensions"]["KHR_materials_emissive_strength"] = {"emissiveStrength": LIGHT_STRENGTH}
    return m


def build_glb(objects, bare, extras):
    """objects: [(name, positions, tris, material)] -> glb bytes."""
    gltf = {"asset": {"version": "2.0", "generator": "mcpt scripts/make_glb.py",
                      "extras": extras},
            "scene": 0, "scenes": [{"name": extras["source"], "nodes": []}],
            "nodes": [], "meshes": [], "materials": [], "accessors": [], "bufferViews": [],
            "buffers": []}
    bin_parts = []
    bin_len = 0

    def add_view(data, target):
        nonlocal bin_len
        raw = data.tobytes() if sys.byteorder == "little" else swapped(data)
        gltf["bufferViews"].append({"buffer": 0, "byteOffset": bin_len,
                                    "byteLength": len(raw), "target": target})
        bin_parts.append(raw)
        bin_len += len(raw)  # float32 and uint32 data keep every view 4-byte aligned
        return len(gltf["bufferViews"]) - 1

    for name, positions, tris, mat in objects:
        # Positions: float32 with min/max taken from the stored float32 values
        pos = array("f", positions)
        lo = [min(pos[k::3]) for k in range(3)]
        hi = [max(pos[k::3]) for k in range(3)]
        gltf["accessors"].append({"bufferView": add_view(pos, ARRAY_BUFFER),
                                  "componentType": FLOAT, "count": len(pos) // 3,
                                  "type": "VEC3", "min": lo, "max": hi})
        pos_acc = len(gltf["accessors"]) - 1
        # Indices: uint32
        idx = array("I", tris)
        gltf["accessors"].append({"bufferView": add_view(idx, ELEMENT_ARRAY_BUFFER),
                                  "componentType": UINT, "count": len(idx), "type": "SCALAR"})
        idx_acc = len(gltf["accessors"]) - 1
        gltf["materials"].append(mat)
        gltf["meshes"].append({"name": name, "primitives": [{
            "attributes": {"POSITION": pos_acc}, "indices": idx_acc,
            "material": len(gltf["materials"]) - 1, "mode": 4}]})
        gltf["nodes"].append({"name": name, "mesh": len(gltf["meshes"]) - 1})
    gltf["extensionsUsed"] = ["KHR_materials_specular"]
    if not bare:
        gltf["extensionsUsed"].append("KHR_materials_emissive_strength")
        gltf["cameras"] = [{"name": "camera", "type": "perspective",
                            "perspective": {"yfov": CAMERA_YFOV, "znear": 0.01}}]
        gltf["nodes"].append({"name": "camera", "camera": 0, "translation": CAMERA_POS})
    gltf["scenes"][0]["nodes"] = list(range(len(gltf["nodes"])))
    gltf["buffers"].append({"byteLength": bin_len})

    # Chunks: JSON padded with spaces, BIN with zeros, both to 4 bytes
    js = json.dumps(gltf, separators=(",", ":")).encode("utf-8")
    js += b" " * (-len(js) % 4)
    binary = b"".join(bin_parts)
    binary += b"\0" * (-len(binary) % 4)
    total = 12 + 8 + len(js) + 8 + len(binary)
    return b"".join([struct.pack("<III", GLB_MAGIC, 2, total),
                     struct.pack("<II", len(js), CHUNK_JSON), js,
                     struct.pack("<II", len(binary), CHUNK_BIN), binary])


def swapped(data):
    copy = array(data.typecode, data)
    copy.byteswap()
    return copy.tobytes()


def load_source(src):
    if src == "cube":
        return cube_mesh()
    if src.endswith(".json"):
        return load_json_mesh(src)
    if src.endswith(".ply") or src.endswith(".ply.gz"):
        return load_ply(src)
    raise ConvertError("unknown source %r (cube, .json, .ply or .ply.gz)" % src)


def convert(src, dst, bare):
    t0 = time.time()
    positions, tris = load_source(src)
    positions, tris, degenerate, unused = clean_mesh(positions, tris)
    # Orientation: make a mostly closed mesh face outwards (counter-clockwise seen from outside)
    flipped = signed_volume(positions, tris) < 0
    if flipped:
        tris[1::3], tris[2::3] = tris[2::3], tris[1::3]
    positions = normalize(positions)
    model_mat = material("model", MODEL_GREY)
    objects = [("model", positions, tris, model_mat)]
    if not bare:
        objects = [("walls",) + enclosure_mesh() + (material("walls", WALL_GREY),),
                   ("light",) + light_mesh() + (material("light", 0.0, emissive=True),),
                   objects[0]]
    extras = {"mcptScene": "bare" if bare else "cornell", "source": os.path.basename(src),
              "modelTriangles": len(tris) // 3}
    blob = build_glb(objects, bare, extras)
    # Write atomically so an interrupted run never leaves a half file behind
    tmp = dst + ".tmp"
    with open(tmp, "wb") as f:
        f.write(blob)
    os.replace(tmp, dst)
    notes = []
    if degenerate:
        notes.append("%d degenerate faces dropped" % degenerate)
    if unused:
        notes.append("%d unused vertices dropped" % unused)
    if flipped:
        notes.append("winding flipped to face outwards")
    print("  %-16s %9d model triangles, %8d vertices, %6.2f MB, %.1f s%s" % (
        os.path.basename(dst), len(tris) // 3, len(positions) // 3, len(blob) / 1e6,
        time.time() - t0, ("  (" + "; ".join(notes) + ")") if notes else ""))


# ---------------------------------------------------------------------------- validation

def read_glb(path):
    with open(path, "rb") as f:
        blob = f.read()
    if len(blob) < 28:
        raise ConvertError("too short")
    magic, version, total = struct.unpack_from("<III", blob, 0)
    if magic != GLB_MAGIC or version != 2:
        raise ConvertError("bad magic or version")
    if total != len(blob):
        raise ConvertError("header length %d != file size %d" % (total, len(blob)))
    jlen, jtype = struct.unpack_from("<II", blob, 12)
    if jtype != CHUNK_JSON or jlen % 4 or 20 + jlen > total:
        raise ConvertError("bad JSON chunk")
    gltf = json.loads(blob[20:20 + jlen].decode("utf-8"))
    binary = b""
    if 20 + jlen < total:
        blen, btype = struct.unpack_from("<II", blob, 20 + jlen)
        if btype != CHUNK_BIN or blen % 4 or 28 + jlen + blen != total:
            raise ConvertError("bad BIN chunk")
        binary = blob[28 + jlen:]
    return gltf, binary


def check(path, quick, want):
    gltf, binary = read_glb(path)
    kind = gltf.get("asset", {}).get("extras", {}).get("mcptScene")
    if gltf.get("asset", {}).get("version") != "2.0":
        raise ConvertError("asset.version is not 2.0")
    if want and kind != want:
        raise ConvertError("scene kind %r, wanted %r" % (kind, want))
    if "KHR_materials_specular" not in gltf.get("extensionsUsed", []):
        raise ConvertError("written before its materials were made Lambertian "
                           "(KHR_materials_specular); convert it again")
    if quick:
        return
    if len(gltf["buffers"]) != 1 or gltf["buffers"][0]["byteLength"] > len(binary):
        raise ConvertError("buffer does not fit the BIN chunk")
    for v in gltf["bufferViews"]:
        if v["byteOffset"] % 4 or v["byteOffset"] + v["byteLength"] > len(binary):
            raise ConvertError("bufferView out of range or misaligned")

    def accessor_data(i, code, comps):
        acc = gltf["accessors"][i]
        view = gltf["bufferViews"][acc["bufferView"]]
        start = view["byteOffset"] + acc.get("byteOffset", 0)
        n = acc["count"] * comps
        if acc.get("byteOffset", 0) + 4 * n > view["byteLength"]:
            raise ConvertError("accessor %d overruns its bufferView" % i)
        data = array(code)
        data.frombytes(binary[start:start + 4 * n])
        if sys.byteorder != "little":
            data.byteswap()
        return acc, data

    counts = []
    for mesh in gltf["meshes"]:
        tri_total = 0
        for prim in mesh["primitives"]:
            acc, pos = accessor_data(prim["attributes"]["POSITION"], "f", 3)
            if acc["componentType"] != FLOAT or acc["type"] != "VEC3":
                raise ConvertError("POSITION is not float32 VEC3")
            lo = [min(pos[k::3]) for k in range(3)]
            hi = [max(pos[k::3]) for k in range(3)]
            if lo != acc["min"] or hi != acc["max"]:
                raise ConvertError("POSITION min/max mismatch in mesh %s" % mesh.get("name"))
            iacc, idx = accessor_data(prim["indices"], "I", 1)
            if iacc["componentType"] != UINT or iacc["count"] % 3:
                raise ConvertError("indices are not uint32 triangles")
            if idx and max(idx) >= acc["count"]:
                raise ConvertError("index out of range")
            if not 0 <= prim["material"] < len(gltf["materials"]):
                raise ConvertError("bad material index")
            tri_total += iacc["count"] // 3
        counts.append("%s %d" % (mesh.get("name", "?"), tri_total))
    for n in gltf["nodes"]:
        if "mesh" in n and not 0 <= n["mesh"] < len(gltf["meshes"]):
            raise ConvertError("bad mesh index in node")
    cams = len(gltf.get("cameras", []))
    print("  %-16s ok: %s; %d camera%s, %s" % (os.path.basename(path), ", ".join(counts), cams,
                                               "" if cams == 1 else "s", kind))


def main(argv):
    if len(argv) >= 2 and argv[0] == "convert":
        bare = "--bare" in argv[1:]
        rest = [a for a in argv[1:] if a != "--bare"]
        if len(rest) != 2:
            raise SystemExit(__doc__)
        try:
            convert(rest[0], rest[1], bare)
        except (ConvertError, OSError, ValueError, KeyError, IndexError) as e:
            print("make_glb.py: %s: %s" % (rest[0], e), file=sys.stderr)
            return 1
        return 0
    if len(argv) >= 2 and argv[0] == "check":
        quick = "--quick" in argv
        want = "bare" if "--bare" in argv else "cornell" if "--box" in argv else None
        status = 0
        for path in (a for a in argv[1:] if not a.startswith("--")):
            try:
                check(path, quick, want)
            except (ConvertError, OSError, ValueError, KeyError, IndexError, TypeError) as e:
                if not quick:
                    print("make_glb.py: %s: %s" % (path, e), file=sys.stderr)
                status = 1
        return status
    raise SystemExit(__doc__)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
