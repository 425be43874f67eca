# Error against render time, mcpt against Blender Cycles on the very same Cornell box, on the
# same machine. Runs inside Blender (scripts/cycles-side-by-side starts it):
#   1. builds mcpt's built-in "cornell" scene in Cycles: geometry (mcpt's y-up mapped to
#      Blender's z-up), materials (Lambert, sharp mirror, sharp glass of IOR 1.5, a one-sided
#      emitter), pinhole camera, 1-pixel box filter, the same bounce limit, no clamping, no
#      glossy filter, no adaptive sampling, no denoising;
#   2. renders both at 1, 2, 4, ... spp, each renderer against its own reference (two
#      independent high-sample renders: their mean, with their noise subtracted);
#   3. prints and writes time to each relative RMSE target, a CSV, an SVG plot, and where the
#      variance lives (per-pixel variance of each renderer from its two references).
# With --export-glb PATH it only writes the box as glTF (Principled materials) and exits.
# --scene lamps: a floor, a wall and a box (Lambert) lit by a point lamp, a spot (hard edge)
# and a sun, exported by Blender's own glTF exporter (KHR_lights_punctual, 683 lm/W) for mcpt;
# --scene hdri --env FILE: the same geometry lit by an equirectangular map (Cycles' world
# Environment Texture, mcpt's --env). Both also print mean radiance per region (4 x 4).
# --scene FILE.glb: any scene as Blender exports it (its camera, lamps and materials), with
# --env for a map. Like for like unless --as-is: lamps punctual (Blender's importer gives them
# a 0.25 m radius and the sun 0.5 degrees), spots hard-edged (blend 0), emitters one-sided in
# Cycles where the file's are (not doubleSided: Cycles' meshes emit from both faces, mcpt's
# where glTF says so), non-metals Lambertian in both (Specular 0 in the
# file mcpt renders, a Diffuse BSDF in Cycles: Principled v1 is 6-16% brighter than glTF's
# BRDF). --variant NAME=OPTIONS adds an mcpt row with other options (an A/B in one run).
# --mcpt-scene FILE: mcpt renders FILE (the same scene in another encoding: Draco, or with
# extensions Blender 3.4 drops) instead of Blender's re-export; KHR_materials_volume is given
# to Cycles as a Volume Absorption. File scenes end with the mean radiance per material.
# --by-bounce 0,1,7: per-sample variance by bounce limit and region instead of the curves.
# Relative RMSE is mcpt converge's: sqrt(mean over pixels and channels of (image - ref)^2,
# less the reference noise) / mean reference radiance.
import argparse
import json
import math
import os
import re
import subprocess
import sys
import time

import bpy
import numpy as np


def material_masks(args, sc, path):
    """The material each pixel's camera ray hits first (index into the returned names; -1 on
    edges and background): a Cycles render with every material an emitter of its own grey
    level, no lamps, no bounces. Changes the scene's materials: call after the last render."""
    mats = [mat for mat in bpy.data.materials if mat.users]
    for i, mat in enumerate(mats):
        mat.use_nodes = True
        nt = mat.node_tree
        for node in list(nt.nodes):
            nt.nodes.remove(node)
        e = nt.nodes.new("ShaderNodeEmission")
        level = (i + 1) / len(mats)
        e.inputs["Color"].default_value = (level, level, level, 1)
        out = nt.nodes.new("ShaderNodeOutputMaterial")
        nt.links.new(e.outputs["Emission"], out.inputs["Surface"])
    for o in sc.objects:
        if o.type == "LIGHT":
            o.hide_render = True
    add_world(sc, None)
    sc.cycles.max_bounces = 0
    render_cycles(sc, 16, 1, path)
    level = read_exr(path, args.size).mean(axis=2) * len(mats) - 1
    index = np.rint(level)
    return np.where((np.abs(level - index) < 0.01) & (index >= 0), index, -1).astype(int), \
        [mat.name for mat in mats]


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    p = argparse.ArgumentParser(prog="cycles-side-by-side")
    p.add_argument("--mcpt", required=True, help="the mcpt binary")
    p.add_argument("--out", default="side-by-side", help="output folder")
    p.add_argument("--size", type=int, default=256)
    p.add_argument("--max-spp", type=int, default=1024)
    p.add_argument("--ref-spp", type=int, default=2048, help="per reference render (two each)")
    p.add_argument("--threads", type=int, default=os.cpu_count())
    p.add_argument("--backend", action="append", help="mcpt backends (default opencl, vulkan)")
    p.add_argument("--sampler", action="append", help="mcpt samplers (default sobol)")
    p.add_argument("--targets", default="0.10,0.05,0.02")
    p.add_argument("--export-glb", help="only write the box as a .glb (Principled materials, "
                   "64x32-segment spheres) to this path, for mcpt's mesh benchmarks")
    p.add_argument("--scene", default="cornell",
                   help="cornell, lamps, hdri, or a .glb/.gltf file (as Blender exports it: its "
                   "camera, lamps and materials; --env for a map)")
    p.add_argument("--as-is", action="store_true",
                   help="a file scene as imported, not like for like (Blender's Principled v1 "
                   "on non-metals, the importer's 0.25 m lamp radius and 0.5 degree sun)")
    p.add_argument("--mcpt-scene", dest="mcpt_scene_file",
                   help="with --scene FILE: mcpt renders this file instead of Blender's re-export "
                   "of FILE (the same scene where Blender cannot read or keep it: Draco, "
                   "KHR_materials_sheen and _volume); materials then stay as imported in Cycles")
    p.add_argument("--env", help="--scene hdri: the equirectangular map (.exr or .hdr)")
    p.add_argument("--variant", action="append", default=[],
                   help="another mcpt row: NAME=OPTIONS, e.g. 'luminance=--env-sampling "
                   "luminance' (A/B of an option against Cycles and the default, one run)")
    p.add_argument("--by-bounce",
                   help="instead of the curves: per-sample variance by bounce limit, e.g. 0,1,7 "
                   "(Cycles' max_bounces b against mcpt's --max-depth b + 1): --seeds renders of "
                   "--seed-spp spp each, the variance across them per pixel, by 4 x 4 region")
    p.add_argument("--seeds", type=int, default=8, help="--by-bounce: renders per row")
    p.add_argument("--seed-spp", type=int, default=16, help="--by-bounce: spp per render")
    return p.parse_args(argv)


# ---- the scene, as common/scene/builtin_scenes.cpp builds it (mcpt coordinates)
WALLS = [  # corners (counter-clockwise seen from inside), colour
    ([(-1, 0, -1), (-1, 0, 1), (1, 0, 1), (1, 0, -1)], (0.73, 0.73, 0.73)),  # floor
    ([(-1, 2, -1), (1, 2, -1), (1, 2, 1), (-1, 2, 1)], (0.73, 0.73, 0.73)),  # ceiling
    ([(-1, 0, -1), (1, 0, -1), (1, 2, -1), (-1, 2, -1)], (0.73, 0.73, 0.73)),  # back
    ([(-1, 0, -1), (-1, 2, -1), (-1, 2, 1), (-1, 0, 1)], (0.65, 0.05, 0.05)),  # left
    ([(1, 0, -1), (1, 0, 1), (1, 2, 1), (1, 2, -1)], (0.12, 0.45, 0.15)),  # right
]
LIGHT = ([(-0.25, 1.98, -0.25), (0.25, 1.98, -0.25), (0.25, 1.98, 0.25), (-0.25, 1.98, 0.25)],
         (17.0, 12.0, 4.0))
GLASS_SPHERE = ((0.45, 0.35, 0.3), 0.35, 1.5)
MIRROR_SPHERE = ((-0.45, 0.35, -0.35), 0.35, 0.95)
CAMERA = ((0.0, 1.0, 3.9), 0.6911)  # position (looking down -z, y up), vertical fov
MCPT_MAX_DEPTH = 8  # mcpt's default: 8 scattering vertices; Cycles counts 0 for direct light


def to_blender(p):
    return (p[0], -p[2], p[1])


def material(name, build):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    nt = m.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    shader = build(nt)
    nt.links.new(shader.outputs[0], out.inputs["Surface"])
    return m


def diffuse(colour):
    def build(nt):
        n = nt.nodes.new("ShaderNodeBsdfDiffuse")
        n.inputs["Color"].default_value = (*colour, 1)
        n.inputs["Roughness"].default_value = 0.0
        return n
    return build


def emitter(radiance):
    # One-sided, as in mcpt: no emission seen from behind.
    def build(nt):
        n = nt.nodes.new("ShaderNodeEmission")
        n.inputs["Color"].default_value = (*radiance, 1)
        geo = nt.nodes.new("ShaderNodeNewGeometry")
        front = nt.nodes.new("ShaderNodeMath")
        front.operation = "SUBTRACT"
        front.inputs[0].default_value = 1.0
        nt.links.new(geo.outputs["Backfacing"], front.inputs[1])
        nt.links.new(front.outputs[0], n.inputs["Strength"])
        return n
    return build


def mirror(tint):
    def build(nt):
        n = nt.nodes.new("ShaderNodeBsdfGlossy")
        n.distribution = "SHARP"
        n.inputs["Color"].default_value = (tint, tint, tint, 1)
        return n
    return build


def glass(ior):
    def build(nt):
        n = nt.nodes.new("ShaderNodeBsdfGlass")
        n.distribution = "SHARP"
        n.inputs["Color"].default_value = (1, 1, 1, 1)
        n.inputs["IOR"].default_value = ior
        return n
    return build


def principled(colour, metallic=0.0, roughness=1.0, transmission=0.0, ior=1.5, emission=None):
    # What glTF can carry (the exporter maps Principled to metallic-roughness, transmission,
    # IOR and emissive strength): Lambert-like walls, a metal mirror, clear glass, the lamp.
    def build(nt):
        n = nt.nodes.new("ShaderNodeBsdfPrincipled")
        n.inputs["Base Color"].default_value = (*colour, 1)
        n.inputs["Metallic"].default_value = metallic
        n.inputs["Roughness"].default_value = roughness
        n.inputs["Transmission"].default_value = transmission
        n.inputs["IOR"].default_value = ior
        if emission:
            peak = max(emission)
            n.inputs["Emission"].default_value = (*[e / peak for e in emission], 1)
            n.inputs["Emission Strength"].default_value = peak
        return n
    return build


def add_mesh(name, verts, faces, mat, smooth=False):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts, [], faces)
    mesh.update()
    for poly in mesh.polygons:
        poly.use_smooth = smooth
    obj = bpy.data.objects.new(name, mesh)
    obj.data.materials.append(mat)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def add_sphere(name, centre, radius, mat, segments=256, rings=128):
    # A finely tessellated, smooth-shaded sphere (mcpt's are analytic).
    c = to_blender(centre)
    verts, faces = [], []
    for i in range(rings + 1):
        theta = math.pi * i / rings
        for j in range(segments):
            phi = 2 * math.pi * j / segments
            verts.append((c[0] + radius * math.sin(theta) * math.cos(phi),
                          c[1] + radius * math.sin(theta) * math.sin(phi),
                          c[2] + radius * math.cos(theta)))
    for i in range(rings):
        for j in range(segments):
            a, b = i * segments + j, i * segments + (j + 1) % segments
            faces.append((a, a + segments, b + segments, b))
    return add_mesh(name, verts, faces, mat, smooth=True)


def build_scene(args, for_gltf=False):
    if is_file_scene(args):
        return cycles_settings(args, build_file_scene(args, for_gltf))
    if args.scene != "cornell":
        return cycles_settings(args, build_lights_scene(args, for_gltf))
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    for i, (corners, colour) in enumerate(WALLS):
        add_mesh("wall%d" % i, [to_blender(p) for p in corners], [(0, 1, 2, 3)],
                 material("wall%d" % i, principled(colour) if for_gltf else diffuse(colour)))
    light = material("light", principled((0, 0, 0), emission=LIGHT[1]) if for_gltf
                     else emitter(LIGHT[1]))
    light.use_backface_culling = True  # exported as doubleSided false: one-sided in mcpt too
    add_mesh("light", [to_blender(p) for p in LIGHT[0]], [(0, 1, 2, 3)], light)
    tess = dict(segments=64, rings=32) if for_gltf else {}
    add_sphere("glass", GLASS_SPHERE[0], GLASS_SPHERE[1],
               material("glass", principled((1, 1, 1), roughness=0.0, transmission=1.0,
                                            ior=GLASS_SPHERE[2]) if for_gltf
                        else glass(GLASS_SPHERE[2])), **tess)
    tint = MIRROR_SPHERE[2]
    add_sphere("mirror", MIRROR_SPHERE[0], MIRROR_SPHERE[1],
               material("mirror", principled((tint, tint, tint), metallic=1.0, roughness=0.0)
                        if for_gltf else mirror(tint)), **tess)
    cam_data = bpy.data.cameras.new("camera")
    cam_data.sensor_fit = "VERTICAL"
    cam_data.angle_y = CAMERA[1]
    cam = bpy.data.objects.new("camera", cam_data)
    cam.location = to_blender(CAMERA[0])
    cam.rotation_euler = (math.pi / 2, 0, 0)  # looks down Blender's +y (mcpt's -z), z up
    sc.collection.objects.link(cam)
    sc.camera = cam
    world = bpy.data.worlds.new("black")
    world.use_nodes = False
    world.color = (0, 0, 0)
    sc.world = world
    return cycles_settings(args, sc)


def is_file_scene(args):
    return args.scene not in ("cornell", "lamps", "hdri")


def add_world(sc, env):
    """The map as Cycles' world (an Environment Texture; linear, as mcpt shows it to camera
    rays), or black."""
    if env:
        world = bpy.data.worlds.new("env")
        world.use_nodes = True
        nt = world.node_tree
        tex = nt.nodes.new("ShaderNodeTexEnvironment")
        tex.image = bpy.data.images.load(os.path.abspath(env))
        tex.interpolation = "Linear"
        nt.links.new(tex.outputs["Color"], nt.nodes["Background"].inputs["Color"])
    else:
        world = bpy.data.worlds.new("black")
        world.use_nodes = False
        world.color = (0, 0, 0)
    sc.world = world


def non_metal_principled(mat):
    """The Principled BSDF node of a material whose metallic is 0 (no texture on it, no
    transmission), or None."""
    if not mat or not mat.use_nodes:
        return None
    for n in mat.node_tree.nodes:
        if n.type == "BSDF_PRINCIPLED":
            metal, trans = n.inputs["Metallic"], n.inputs["Transmission"]
            if (not metal.is_linked and metal.default_value == 0.0 and not trans.is_linked
                    and trans.default_value == 0.0):
                return n
    return None


def one_sided_emission(mat):
    """Cycles' mesh emission leaves both faces; mcpt's the front face only where the glTF
    material is not doubleSided (the importer's use_backface_culling). Like for like: the
    Principled emission times 1 - Backfacing."""
    if not mat or not mat.use_nodes:
        return
    nt = mat.node_tree
    for n in list(nt.nodes):
        if n.type != "BSDF_PRINCIPLED":
            continue
        strength = n.inputs["Emission Strength"]
        if strength.is_linked or strength.default_value <= 0:
            continue
        geometry = nt.nodes.new("ShaderNodeNewGeometry")
        front = nt.nodes.new("ShaderNodeMath")
        front.operation = "SUBTRACT"
        front.inputs[0].default_value = 1.0
        nt.links.new(geometry.outputs["Backfacing"], front.inputs[1])
        scaled = nt.nodes.new("ShaderNodeMath")
        scaled.operation = "MULTIPLY"
        scaled.inputs[1].default_value = strength.default_value
        nt.links.new(front.outputs["Value"], scaled.inputs[0])
        nt.links.new(scaled.outputs["Value"], strength)


def gltf_json(path):
    """The JSON of a .glb or .gltf file."""
    data = open(path, "rb").read()
    if data[:4] == b"glTF":
        length = int.from_bytes(data[12:16], "little")
        return json.loads(data[20:20 + length])
    return json.loads(data)


def add_volume_absorption(mat, volume):
    """KHR_materials_volume (which Blender 3.4's importer drops) as a Volume Absorption node:
    glTF's sigma_a = -ln(attenuationColor) / attenuationDistance per channel; Cycles' is
    density x (1 - color), so density = max sigma_a and color = 1 - sigma_a / density."""
    distance = volume.get("attenuationDistance", float("inf"))
    colour = volume.get("attenuationColor", [1.0, 1.0, 1.0])
    if volume.get("thicknessFactor", 0.0) <= 0 or not math.isfinite(distance):
        return
    sigma = [-math.log(max(c, 1e-9)) / distance for c in colour]
    density = max(sigma)
    if density <= 0:
        return
    nt = mat.node_tree
    node = nt.nodes.new("ShaderNodeVolumeAbsorption")
    node.inputs["Color"].default_value = (*[1.0 - s / density for s in sigma], 1.0)
    node.inputs["Density"].default_value = density
    out = [m for m in nt.nodes if m.type == "OUTPUT_MATERIAL"][0]
    nt.links.new(node.outputs["Volume"], out.inputs["Volume"])


def coated(n):
    """Whether a Principled node has a clearcoat (then kept as Principled: the coat is what
    is compared; Cycles' v1 coat is GTR1 at a quarter of the weight, on top of the base)."""
    c = n.inputs["Clearcoat"]
    return c.is_linked or c.default_value > 0


def build_file_scene(args, for_gltf):
    """A .glb/.gltf as Blender imports it. Like for like (unless --as-is): lamps punctual
    (radius 0, sun angle 0) and spots hard-edged for both; emission one-sided in Cycles where
    the file's material is (not doubleSided);
    non-metals with Specular 0 in the file mcpt renders (Lambertian in mcpt) and a Diffuse BSDF
    of the same base colour in Cycles."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    # Debian's Blender 3.4 importer uses np.bool, gone from Debian's numpy 1.24.
    if not hasattr(np, "bool"):
        np.bool = bool
    bpy.ops.import_scene.gltf(filepath=os.path.abspath(args.scene))
    if not for_gltf:
        for m in gltf_json(args.scene).get("materials", []):
            volume = m.get("extensions", {}).get("KHR_materials_volume")
            if volume and m.get("name") in bpy.data.materials:
                add_volume_absorption(bpy.data.materials[m["name"]], volume)
    cams = [o for o in sc.objects if o.type == "CAMERA"]
    if not cams:
        sys.exit("%s has no camera" % args.scene)
    sc.camera = cams[0]
    if not args.as_is:
        for o in sc.objects:
            if o.type == "LIGHT":
                if o.data.type == "SUN":
                    o.data.angle = 0.0
                else:
                    o.data.shadow_soft_size = 0.0
                if o.data.type == "SPOT":
                    # Blender's blend is a smoothstep over (1 - cos outer) x blend; glTF's inner
                    # cone a squared ramp in cosine: 7.5% apart on a 50-degree spot of blend
                    # 0.15. A hard edge is the same in both.
                    o.data.spot_blend = 0.0
        for mat in bpy.data.materials:
            if not for_gltf and mat.use_backface_culling:
                one_sided_emission(mat)
            n = non_metal_principled(mat)
            if n is None or coated(n) or args.mcpt_scene_file:
                continue
            if for_gltf:
                n.inputs["Specular"].default_value = 0.0
                continue
            nt = mat.node_tree
            d = nt.nodes.new("ShaderNodeBsdfDiffuse")
            colour = n.inputs["Base Color"]
            if colour.is_linked:
                nt.links.new(colour.links[0].from_socket, d.inputs["Color"])
            else:
                d.inputs["Color"].default_value = colour.default_value
            out = [m for m in nt.nodes if m.type == "OUTPUT_MATERIAL"][0]
            emission = n.inputs["Emission Strength"].default_value
            if emission > 0 and (n.inputs["Emission"].is_linked or
                                 max(n.inputs["Emission"].default_value[:3]) > 0):
                # An emitter keeps its Principled node (Cycles' emission is the same), with
                # Specular 0 as in the file mcpt renders: else its specular layer reflects the
                # scene at grazing angles (5.8% of the radiance of the top of a view of
                # ceiling panels).
                n.inputs["Specular"].default_value = 0.0
                continue
            nt.links.new(d.outputs["BSDF"], out.inputs["Surface"])
    add_world(sc, args.env)
    return sc


def cycles_settings(args, sc):
    # Renderer settings that match mcpt's estimator.
    r, c = sc.render, sc.cycles
    r.engine = "CYCLES"
    r.resolution_x = r.resolution_y = args.size
    r.resolution_percentage = 100
    r.threads_mode = "FIXED"
    r.threads = args.threads
    r.image_settings.file_format = "OPEN_EXR"
    r.image_settings.color_depth = "32"
    r.image_settings.exr_codec = "NONE"
    sc.view_settings.view_transform = "Standard"
    sc.view_settings.look = "None"
    c.device = "CPU"
    c.use_adaptive_sampling = False
    c.use_denoising = False
    c.pixel_filter_type = "BOX"
    c.filter_width = 1.0
    bounces = MCPT_MAX_DEPTH - 1
    c.max_bounces = bounces
    c.diffuse_bounces = c.glossy_bounces = c.transmission_bounces = bounces
    c.volume_bounces = c.transparent_max_bounces = bounces
    c.caustics_reflective = c.caustics_refractive = True
    c.blur_glossy = 0.0
    c.sample_clamp_direct = c.sample_clamp_indirect = 0.0
    c.light_sampling_threshold = 0.0
    c.use_animated_seed = False
    return sc


# ---- the lamps and HDRI scenes (Blender coordinates, z up; the exporter turns them y up)
LAMP_ROOM = [  # corners, colour: a floor, a back wall, a box
    ([(-3, -3, 0), (3, -3, 0), (3, 3, 0), (-3, 3, 0)], (0.7, 0.7, 0.7)),
    ([(-3, 2, 0), (3, 2, 0), (3, 2, 3), (-3, 2, 3)], (0.7, 0.3, 0.2)),
]
LAMP_BOX = ((0.3, 0.0, 0.5), 0.5, (0.3, 0.5, 0.7))  # centre, half size, colour


def build_lights_scene(args, for_gltf):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    mat = lambda name, c: material(name, principled(c) if for_gltf else diffuse(c))
    for i, (corners, colour) in enumerate(LAMP_ROOM):
        # Faces toward the camera (+z for the floor, -y for the wall).
        add_mesh("room%d" % i, corners, [(0, 1, 2, 3)], mat("room%d" % i, colour))
    (cx, cy, cz), h, colour = LAMP_BOX
    v = [(cx + sx * h, cy + sy * h, cz + sz * h) for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
    faces = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    add_mesh("box", v, faces, mat("box", colour))
    if for_gltf:
        for m in bpy.data.materials:  # no specular layer: glTF's Diffuse in mcpt
            m.node_tree.nodes["Principled BSDF"].inputs["Specular"].default_value = 0.0
    if args.scene == "lamps":
        def lamp(name, kind, energy, location, rotation=(0, 0, 0), colour=(1, 1, 1)):
            data = bpy.data.lights.new(name, kind)
            data.energy = energy
            data.color = colour
            if kind != "SUN":
                data.shadow_soft_size = 0.0
            else:
                data.angle = 0.0
            obj = bpy.data.objects.new(name, data)
            obj.location = location
            obj.rotation_euler = rotation
            sc.collection.objects.link(obj)
            return data
        lamp("point", "POINT", 40.0, (1, -1, 2), colour=(1, 0.9, 0.8))
        spot = lamp("spot", "SPOT", 60.0, (-1, -1, 2.5), colour=(0.8, 0.9, 1))
        spot.spot_size = 1.0  # full cone angle, radians
        spot.spot_blend = 0.0  # a hard edge, as glTF's inner = outer
        lamp("sun", "SUN", 1.5, (0, 0, 5), rotation=(math.radians(30), 0, math.radians(20)))
        add_world(sc, None)
    else:
        add_world(sc, args.env)
    cam_data = bpy.data.cameras.new("camera")
    cam_data.sensor_fit = "VERTICAL"
    cam_data.angle_y = 0.8
    cam = bpy.data.objects.new("camera", cam_data)
    cam.location = (0, -5, 2)
    cam.rotation_euler = (math.radians(75), 0, 0)
    sc.collection.objects.link(cam)
    sc.camera = cam
    return sc


# ---- rendering
def read_exr(path, size):
    img = bpy.data.images.load(path, check_existing=False)
    px = np.array(img.pixels[:], dtype=np.float64).reshape(size, size, 4)[:, :, :3]
    bpy.data.images.remove(img)
    return px


def render_cycles(sc, spp, seed, path):
    sc.cycles.samples = spp
    sc.cycles.seed = seed
    sc.render.filepath = path
    start = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    return time.perf_counter() - start


def render_mcpt(args, backend, sampler, spp, seed, path, options=()):
    cmd = [args.mcpt, "render", args.mcpt_scene, "--backend", backend, "--spp", str(spp), "--seed",
           str(seed), "--sampler", sampler, "--width", str(args.size), "--height", str(args.size),
           "-q", "-o", path] + args.mcpt_extra + list(options)
    out = subprocess.run(cmd, capture_output=True, text=True)
    if out.returncode != 0:
        sys.exit("mcpt failed: " + " ".join(cmd) + "\n" + out.stdout + out.stderr)
    m = re.search(r"spp, max depth \d+ in ([0-9.]+) s", out.stdout + out.stderr)
    return float(m.group(1))


class Reference:
    """Mean of two independent renders; its noise variance from their difference."""

    def __init__(self, a, b):
        self.mean = 0.5 * (a + b)
        self.noise = float(np.mean((a - b) ** 2)) / 4  # variance of the mean, per value
        self.pixel_var = (a - b) ** 2 / 2  # per-pixel variance of one render (1 dof)

    def rel_rmse(self, img):
        mse = max(float(np.mean((img - self.mean) ** 2)) - self.noise, 0.0)
        return math.sqrt(mse) / float(np.mean(self.mean))


def time_to(curve, target):
    """Log-log interpolation of (seconds, rel_rmse); extrapolated along the last slope."""
    for (t0, e0), (t1, e1) in zip(curve, curve[1:]):
        if e0 >= target >= e1 and e0 > 0 and e1 > 0 and e0 != e1:
            f = math.log(e0 / target) / math.log(e0 / e1)
            return math.exp(math.log(t0) + f * math.log(t1 / t0)), False
    if curve and curve[0][1] <= target:
        return curve[0][0], False
    (t0, e0), (t1, e1) = curve[-2], curve[-1]
    slope = math.log(e1 / e0) / math.log(t1 / t0)
    if slope >= -0.05:
        return float("inf"), True
    return t1 * (target / e1) ** (1 / slope), True


def write_svg(path, runs, targets):
    w, h, m = 720, 480, 60
    pts = [p for _, curve in runs for p in curve if p[0] > 0 and p[1] > 0]
    x0, x1 = math.log10(min(p[0] for p in pts)), math.log10(max(p[0] for p in pts))
    y0, y1 = math.log10(min(min(p[1] for p in pts), min(targets))), math.log10(max(p[1] for p in pts))
    sx = lambda t: m + (math.log10(t) - x0) / (x1 - x0) * (w - 2 * m)
    sy = lambda e: h - m - (math.log10(e) - y0) / (y1 - y0) * (h - 2 * m)
    colours = ["#d62728", "#1f77b4", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b"]
    s = ['<svg xmlns="http://www.w3.org/2000/svg" width="%d" height="%d" font-family="sans-serif" '
         'font-size="12">' % (w, h), '<rect width="100%" height="100%" fill="white"/>',
         '<text x="%d" y="20" font-size="14">Relative RMSE against render time (log-log), '
         '%s, %s</text>' % (m, SCENE_TITLE[0], "same machine"),
         '<text x="%d" y="%d">seconds</text>' % (w // 2, h - 15),
         '<text x="10" y="%d" transform="rotate(-90 10 %d)">relative RMSE</text>' % (h // 2, h // 2)]
    for e in targets:
        s.append('<line x1="%d" x2="%d" y1="%.1f" y2="%.1f" stroke="#ccc" stroke-dasharray="4"/>'
                 '<text x="%d" y="%.1f" fill="#888">%g%%</text>'
                 % (m, w - m, sy(e), sy(e), w - m + 4, sy(e) + 4, 100 * e))
    for k in range(math.floor(x0), math.ceil(x1) + 1):
        if x0 <= k <= x1:
            s.append('<text x="%.1f" y="%d" text-anchor="middle">%g</text>' % (sx(10 ** k), h - m + 16, 10 ** k))
    for k in range(math.floor(y0), math.ceil(y1) + 1):
        if y0 <= k <= y1:
            s.append('<text x="%d" y="%.1f" text-anchor="end">%g</text>' % (m - 4, sy(10 ** k) + 4, 10 ** k))
    for i, (name, curve) in enumerate(runs):
        col = colours[i % len(colours)]
        points = " ".join("%.1f,%.1f" % (sx(t), sy(e)) for t, e in curve if t > 0 and e > 0)
        s.append('<polyline fill="none" stroke="%s" stroke-width="2" points="%s"/>' % (col, points))
        s.append('<text x="%d" y="%d" fill="%s">%s</text>' % (w - m - 220, m + 16 * i, col, name))
    s.append('<rect x="%d" y="%d" width="%d" height="%d" fill="none" stroke="black"/>'
             % (m, m - 10, w - 2 * m, h - 2 * m + 10))
    s.append("</svg>")
    with open(path, "w") as f:
        f.write("\n".join(s))


SCENE_TITLE = ["Cornell box"]


def by_bounce(args, sc, rows, exr):
    """Per-sample variance of each row (Cycles first) at each bounce limit, from independent
    renders (seeds 1000, 1001, ...): where the variance comes in, and whose it is."""
    print("per-sample variance by bounce limit: %d renders of %d spp per row"
          % (args.seeds, args.seed_spp))
    for b in [int(x) for x in args.by_bounce.split(",")]:
        c = sc.cycles
        c.max_bounces = c.diffuse_bounces = c.glossy_bounces = c.transmission_bounces = b
        variances = []
        for name, backend, sampler, options in rows:
            imgs = []
            for k in range(args.seeds):
                path = exr("bounce-%d-%s" % (b, name.replace(" ", "-")))
                if backend is None:
                    render_cycles(sc, args.seed_spp, 1000 + k, path)
                else:
                    render_mcpt(args, backend, sampler, args.seed_spp, 1000 + k, path,
                                list(options) + ["--max-depth", str(b + 1)])
                imgs.append(read_exr(path, args.size))
            stack = np.stack(imgs)
            variances.append(stack.var(0, ddof=1).mean(2) * args.seed_spp)
            print("  bounces %d, %-24s mean %.5f  variance per sample %.5f  x%.3f of Cycles'"
                  % (b, name, float(stack.mean()), float(variances[-1].mean()),
                     float(variances[-1].mean() / max(variances[0].mean(), 1e-30))), flush=True)
        n = args.size // 4
        region = lambda v, i, j: float(v[i * n:(i + 1) * n, j * n:(j + 1) * n].mean())
        for (name, _, _, _), v in list(zip(rows, variances))[1:]:
            print("    %s / Cycles by region (bottom row first):" % name)
            for i in range(4):
                print("     " + " | ".join(
                    "%6.2f" % (region(v, i, j) / region(variances[0], i, j))
                    if region(variances[0], i, j) > 0 else "     -" for j in range(4)))


def main():
    args = parse_args()
    SCENE_TITLE[0] = ({"cornell": "Cornell box", "lamps": "lamps (point, spot, sun)",
                       "hdri": "HDRI " + os.path.basename(args.env or "")}.get(args.scene) or
                      os.path.basename(args.scene) + (" under " + os.path.basename(args.env)
                                                      if args.env else ""))
    backends = args.backend or ["opencl", "vulkan"]
    samplers = args.sampler or ["sobol"]
    targets = [float(t) for t in args.targets.split(",")]
    if args.export_glb:
        build_scene(args, for_gltf=True)
        bpy.ops.export_scene.gltf(filepath=os.path.abspath(args.export_glb), export_format="GLB",
                                  export_cameras=True, export_apply=True)
        print("wrote %s" % args.export_glb)
        return
    os.makedirs(args.out, exist_ok=True)
    args.mcpt_scene, args.mcpt_extra = "cornell", []
    if args.scene != "cornell":
        if args.scene == "hdri" and not args.env:
            sys.exit("--scene hdri needs --env FILE")
        # mcpt renders what Blender's own glTF exporter writes.
        if args.mcpt_scene_file:
            args.mcpt_scene = os.path.abspath(args.mcpt_scene_file)
        else:
            build_scene(args, for_gltf=True)
            stem = os.path.splitext(os.path.basename(args.scene))[0]
            args.mcpt_scene = os.path.abspath(os.path.join(args.out, stem + "-mcpt.glb"))
            bpy.ops.export_scene.gltf(filepath=args.mcpt_scene, export_format="GLB",
                                      export_cameras=True, export_lights=True, export_apply=True)
        if args.env:
            args.mcpt_extra = ["--env", os.path.abspath(args.env)]
    sc = build_scene(args)
    print("Cycles: %s, %d threads, pattern %s, box filter 1 px, max bounces %d"
          % (bpy.app.version_string, args.threads, sc.cycles.sampling_pattern, sc.cycles.max_bounces))
    exr = lambda name: os.path.join(args.out, name + ".exr")
    if args.by_bounce:
        rows = [("cycles", None, None, [])] + [("mcpt " + b, b, samplers[0], []) for b in backends]
        for v in args.variant:
            label, _, options = v.partition("=")
            rows.append(("mcpt " + backends[0] + " " + label, backends[0], samplers[0],
                         options.split()))
        by_bounce(args, sc, rows, exr)
        return
    spps = [1 << k for k in range(int(math.log2(args.max_spp)) + 1)]

    # References: two independent renders each.
    print("references: 2 x %d spp each ..." % args.ref_spp, flush=True)
    refs = {}
    imgs = []
    for seed in (90001, 90002):
        render_cycles(sc, args.ref_spp, seed, exr("cycles-ref-%d" % seed))
        imgs.append(read_exr(exr("cycles-ref-%d" % seed), args.size))
    refs["cycles"] = Reference(*imgs)
    imgs = []
    for seed in (90001, 90002):
        render_mcpt(args, backends[0], "sobol", args.ref_spp, seed, exr("mcpt-ref-%d" % seed))
        imgs.append(read_exr(exr("mcpt-ref-%d" % seed), args.size))
    refs["mcpt"] = Reference(*imgs)
    for name, ref in refs.items():
        print("  %s: mean radiance %.5f, reference noise %.2f%% of it"
              % (name, float(np.mean(ref.mean)), 100 * math.sqrt(ref.noise) / float(np.mean(ref.mean))))
    # The scenes match when the references differ by no more than their noise.
    c, m = refs["cycles"], refs["mcpt"]
    mismatch = max(float(np.mean((c.mean - m.mean) ** 2)) - c.noise - m.noise, 0.0)
    print("  cycles vs mcpt references: mean radiance ratio %.4f, RMS difference beyond noise "
          "%.2f%% of the mean" % (float(np.mean(c.mean) / np.mean(m.mean)),
                                  100 * math.sqrt(mismatch) / float(np.mean(m.mean))))
    # Mean radiance per region: 4 x 4 blocks of the image, row 0 at the top.
    q = args.size // 4
    print("  mean radiance per region, mcpt / Cycles (4 x 4, bottom row first):")
    for by in range(4):
        cells = []
        for bx in range(4):
            mc = float(np.mean(c.mean[by * q:(by + 1) * q, bx * q:(bx + 1) * q]))
            mm = float(np.mean(m.mean[by * q:(by + 1) * q, bx * q:(bx + 1) * q]))
            cells.append("%.4f/%.4f = %.3f" % (mm, mc, mm / mc if mc > 0 else float("nan")))
        print("    " + " | ".join(cells))

    # Error against time.
    runs = []
    rows = ["renderer,spp,seconds,rel_rmse"]
    names = [("cycles", None, None, [])] + [
        ("mcpt " + b + (" " + s if len(samplers) > 1 else ""), b, s, []) for b in backends
        for s in samplers]
    for v in args.variant:
        label, _, options = v.partition("=")
        names.append(("mcpt " + backends[0] + " " + label, backends[0], samplers[0],
                      options.split()))
    for name, backend, sampler, options in names:
        curve = []
        for spp in spps:
            path = exr("%s-%d" % (name.replace(" ", "-"), spp))
            if backend is None:
                t = render_cycles(sc, spp, 1, path)
            else:
                t = render_mcpt(args, backend, sampler, spp, 1, path, options)
            err = refs["cycles" if backend is None else "mcpt"].rel_rmse(read_exr(path, args.size))
            curve.append((t, err))
            print("  %-22s %5d spp %8.3f s  rel RMSE %6.2f%%" % (name, spp, t, 100 * err), flush=True)
        if backend is None:
            # Cycles' time includes its scene sync: take off the extrapolation to 0 spp.
            t1, t2 = curve[0][0], curve[1][0]
            sync = max(0.0, 2 * t1 - t2)
            curve = [(t - sync, e) for t, e in curve]
            print("  (cycles: %.3f s of scene synchronisation taken off each time)" % sync)
        rows += ["%s,%d,%.4f,%.6f" % (name, spp, t, e) for spp, (t, e) in zip(spps, curve)]
        runs.append((name, curve))

    # Time to each target, and the ratio to Cycles.
    print("\n| relative RMSE | " + " | ".join(n for n, _ in runs) + " |")
    print("|---|" + "---:|" * len(runs))
    for target in targets:
        cells = []
        base = None
        for name, curve in runs:
            t, extrapolated = time_to(curve, target)
            base = t if base is None else base
            cell = ("~" if extrapolated else "") + "%.2f s" % t
            if name != "cycles" and math.isfinite(t) and base > 0:
                cell += " (x%.2f)" % (t / base)
            cells.append(cell)
        print("| %g%% | %s |" % (100 * target, " | ".join(cells)))
    print("(~: extrapolated along the last two points' slope; xN: time relative to Cycles)")

    # Where the variance lives: per-sample variance per pixel from each renderer's two references.
    vc = c.pixel_var.mean(axis=2) * args.ref_spp
    vm = m.pixel_var.mean(axis=2) * args.ref_spp
    lum = m.mean.mean(axis=2)
    # Ranked on 4x4 blocks (48 values each) by both renderers' variance shares alike, so that
    # neither renderer's noise picks the regions.
    k = 4
    s = args.size // k
    bm = vm[:s * k, :s * k].reshape(s, k, s, k).mean(axis=(1, 3))
    bc = vc[:s * k, :s * k].reshape(s, k, s, k).mean(axis=(1, 3))
    order = np.argsort((bm / bm.sum() + bc / bc.sum()).ravel())[::-1]
    n = order.size
    print("\nper-sample variance, mcpt / Cycles, by region (4x4 blocks ranked by their share of the "
          "variance):")
    for lo, hi in [(0, 0.01), (0.01, 0.05), (0.05, 0.25), (0.25, 1.0)]:
        sel = order[int(lo * n):int(hi * n)]
        print("  blocks %3.0f%%-%3.0f%%: %5.1f%% of mcpt's variance, %5.1f%% of Cycles'; ratio %.2f"
              % (100 * lo, 100 * hi, 100 * bm.ravel()[sel].sum() / bm.sum(),
                 100 * bc.ravel()[sel].sum() / bc.sum(),
                 bm.ravel()[sel].sum() / max(bc.ravel()[sel].sum(), 1e-30)))
    print("  all pixels: ratio %.2f; median block relative std: mcpt %.3f, Cycles %.3f"
          % (vm.sum() / vc.sum(),
             float(np.median(np.sqrt(bm) / np.maximum(lum[:s * k, :s * k].reshape(s, k, s, k).mean(axis=(1, 3)), 1e-9))),
             float(np.median(np.sqrt(bc) / np.maximum(c.mean.mean(axis=2)[:s * k, :s * k].reshape(s, k, s, k).mean(axis=(1, 3)), 1e-9)))))
    # A map of log2(mcpt / Cycles) per-sample variance over the 4x4 blocks: red where mcpt is
    # noisier, blue where Cycles is (full colour at 4x).
    ratio = np.clip(np.log2(np.maximum(bm, 1e-12) / np.maximum(bc, 1e-12)) / 2, -1, 1)
    ratio = np.kron(ratio, np.ones((k, k)))
    rgba = np.ones((args.size, args.size, 4))
    rgba[:, :, 0] = 1 - np.maximum(-ratio, 0)
    rgba[:, :, 1] = 1 - np.abs(ratio)
    rgba[:, :, 2] = 1 - np.maximum(ratio, 0)
    img = bpy.data.images.new("ratio", args.size, args.size, float_buffer=False)
    img.pixels = rgba.ravel().tolist()
    img.filepath_raw = os.path.join(args.out, "variance-ratio.png")
    img.file_format = "PNG"
    img.save()

    if is_file_scene(args):
        # Mean radiance per material seen by the camera (pixels wholly on it).
        index, names = material_masks(args, sc, exr("materials"))
        print("\nmean radiance per material seen by the camera, mcpt / Cycles:")
        for i, name in enumerate(names):
            sel = index == i
            if sel.sum() == 0:
                continue
            mm, mc = float(np.mean(m.mean[sel])), float(np.mean(c.mean[sel]))
            print("  %-24s %6d px  %.4f / %.4f = %.3f"
                  % (name, int(sel.sum()), mm, mc, mm / mc if mc > 0 else float("nan")))

    with open(os.path.join(args.out, "side-by-side.csv"), "w") as f:
        f.write("\n".join(rows) + "\n")
    write_svg(os.path.join(args.out, "side-by-side.svg"), runs, targets)
    print("\nwrote %s/side-by-side.csv, side-by-side.svg, variance-ratio.png" % args.out)


if __name__ == "__main__":
    main()
