#!/usr/bin/env python3
"""The test scenes through the steps web and mobile pipelines run on glTF before shipping it
(gltfpack 1.3.0 and gltf-transform 4.5.1 from npm, pinned: quantization, meshopt and Draco
compression, WebP textures, texture transforms), each result A/B-tested against its original
with `mcpt compare --b-scene`: AGREE, on OpenCL and on Vulkan.

Quantization moves each vertex by up to half a step of its grid (gltfpack: 14-bit positions,
12-bit texture coordinates, 8-bit normals; gltf-transform quantize: 14/12/10; Draco 14/12/10),
below 1e-4 of the scene's size: an edge moves by a hundredth of a pixel at the test's 64x64,
far below the bias the 32-batch test can detect (it reports that bias; about 2 % of a
pixel's value). The same-seed test is left out (--same-seed-limit 1): moved vertices move
every path that touches them, so same-seed images diverge by design. WebP is written lossless
and must give the original's image bit for bit at the same seed (the same-seed test kept):
gltf-transform's default, lossy quality 80, changes the checker textures' colours enough that
the test tells it apart (-0.3 % mean radiance, 31 pixels discovered), as it should.

Controls, each what a loader with a defect would read, must DIFFER: the gltfpack file with its
KHR_texture_transform removed (a loader that ignores it), and with its texture coordinates'
`normalized` flag dropped (a loader that reads quantized integers as they are).
Usage: gltf_pipelines_test.py MCPT_BINARY DATA_DIR"""
import json
import os
import struct
import subprocess
import sys
import tempfile

MCPT, DATA = sys.argv[1], sys.argv[2]
TOOLS = {"gltfpack": "1.3.0", "@gltf-transform/cli": "4.5.1"}
CACHE = os.path.join(os.environ.get("XDG_CACHE_HOME", os.path.expanduser("~/.cache")), "mcpt",
                     "gltf-pipelines-" + "-".join(v for v in TOOLS.values()))
failures = []


def check(ok, what):
    print(("ok    " if ok else "FAIL  ") + what, flush=True)
    if not ok:
        failures.append(what)


def install_tools():
    """gltfpack and gltf-transform, installed once into the cache (npm registry)."""
    bins = os.path.join(CACHE, "node_modules", ".bin")
    if not all(os.path.exists(os.path.join(bins, b)) for b in ("gltfpack", "gltf-transform")):
        os.makedirs(CACHE, exist_ok=True)
        subprocess.run(["npm", "install", "--prefix", CACHE, "--no-audit", "--no-fund",
                        "--silent"] + [f"{p}@{v}" for p, v in TOOLS.items()], check=True)
    return bins


def run_tool(args):
    r = subprocess.run(args, capture_output=True, text=True, timeout=300)
    if r.returncode != 0:
        raise RuntimeError(" ".join(args) + " failed:\n" + r.stdout + r.stderr)


def read_glb(path):
    data = open(path, "rb").read()
    length = struct.unpack_from("<I", data, 12)[0]
    return json.loads(data[20:20 + length]), data[20 + length:]


def write_glb(path, doc, rest):
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    head = struct.pack("<4sII", b"glTF", 2, 12 + 8 + len(text) + len(rest))
    open(path, "wb").write(head + struct.pack("<II", len(text), 0x4E4F534A) + text + rest)


def extensions(path):
    return set(read_glb(path)[0].get("extensionsUsed", []))


def compare(original, other, api, exact=False):
    """mcpt compare's verdict ('AGREE', 'DIFFER') of `other` against `original` on `api`; with
    `exact` the same-seed images must match too (else moved vertices may part them)."""
    same_seed = [] if exact else ["--same-seed-limit", "1"]
    r = subprocess.run([MCPT, "compare", original, "--b-scene", other, "--a", api, "--b", api,
                        "--width", "64", "--height", "64"] + same_seed,
                       capture_output=True, text=True, timeout=600)
    verdict = {0: "AGREE", 2: "DIFFER"}.get(r.returncode, "ERROR")
    if verdict == "ERROR":
        print(r.stdout + r.stderr, flush=True)
    return verdict


def main():
    bins = install_tools()
    gltfpack, transform = os.path.join(bins, "gltfpack"), os.path.join(bins, "gltf-transform")
    work = tempfile.mkdtemp(prefix="mcpt_pipelines_")
    # Each scene through each step: (name, command given input and output, extension written).
    steps = [
        ("gltfpack", lambda i, o: [gltfpack, "-i", i, "-o", o], "KHR_mesh_quantization"),
        ("gltfpack-cc", lambda i, o: [gltfpack, "-cc", "-i", i, "-o", o],
         "EXT_meshopt_compression"),
        ("draco", lambda i, o: [transform, "draco", i, o], "KHR_draco_mesh_compression"),
        ("meshopt", lambda i, o: [transform, "meshopt", i, o], "EXT_meshopt_compression"),
        ("quantize", lambda i, o: [transform, "quantize", i, o], "KHR_mesh_quantization"),
        ("webp", lambda i, o: [transform, "webp", "--lossless", "true", i, o],
         "EXT_texture_webp"),
    ]
    scenes = {"textured.glb": [s for s in steps],
              "cube_box.glb": [s for s in steps if s[0] != "webp"],
              "lamps.gltf": [s for s in steps if s[0] in ("gltfpack", "draco")]}
    # Both APIs, the steps dealt between them in turn (each step on each API over the scenes).
    apis = ["opencl", "vulkan"]
    turn = 0
    for scene, scene_steps in scenes.items():
        original = os.path.join(DATA, scene)
        for name, command, ext in scene_steps:
            out = os.path.join(work, os.path.splitext(scene)[0] + "-" + name + ".glb")
            run_tool(command(original, out))
            check(ext in extensions(out), f"{scene} {name}: the output uses {ext}")
            api = apis[turn % 2]
            turn += 1
            verdict = compare(original, out, api, exact=name == "webp")
            check(verdict == "AGREE", f"{scene} {name} against the original on {api}: {verdict}")
    # Controls on the gltfpack textured file, on both APIs.
    packed = os.path.join(work, "textured-gltfpack.glb")
    doc, rest = read_glb(packed)
    no_transform = json.loads(json.dumps(doc))
    removed = 0
    for m in no_transform.get("materials", []):
        for slot in [m.get("pbrMetallicRoughness", {}).get("baseColorTexture"),
                     m.get("pbrMetallicRoughness", {}).get("metallicRoughnessTexture"),
                     m.get("normalTexture"), m.get("emissiveTexture")]:
            if slot and "KHR_texture_transform" in slot.get("extensions", {}):
                del slot["extensions"]["KHR_texture_transform"]
                removed += 1
    check(removed > 0, f"control: {removed} texture transforms removed")
    no_normalized = json.loads(json.dumps(doc))
    unnormalized = 0
    for mesh in no_normalized["meshes"]:
        for prim in mesh["primitives"]:
            acc = no_normalized["accessors"][prim["attributes"].get("TEXCOORD_0", -1)] \
                if "TEXCOORD_0" in prim["attributes"] else None
            if acc and acc.get("normalized"):
                acc["normalized"] = False
                unnormalized += 1
    check(unnormalized > 0, f"control: {unnormalized} texture coordinate sets unnormalized")
    for label, control in (("transform ignored", no_transform),
                           ("normalization ignored", no_normalized)):
        path = os.path.join(work, "control-" + label.split()[0] + ".glb")
        write_glb(path, control, rest)
        for api in apis:
            verdict = compare(os.path.join(DATA, "textured.glb"), path, api)
            check(verdict == "DIFFER", f"control ({label}) on {api}: {verdict}")
    print(f"{len(failures)} failed" if failures else "all passed", flush=True)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
