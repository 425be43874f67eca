# Scenes made the way a Blender user makes them (Blender meshes, Principled materials, Blender
# lamps), written by Blender's own glTF exporter: what docs/lights.md compares with Cycles.
#   blender -b --factory-startup --python scripts/make_blender_scenes.py -- lamps lamps.glb
#   scripts/cycles-side-by-side --scene lamps.glb --backend opencl
# lamps: a ground, a box, a rough metal sphere and a plastic one; a point lamp 300 W, a spot
#        500 W (50 degrees) and a sun 2 W/m^2 (point, spot, sun: that lamp alone).
# many:  a 20 m floor, six boxes and a ball; 64 point lamps of 5-60 W low over the floor and
#        16 emissive panels facing down from the ceiling's height.
# layers: a ground, a car-paint ball (clearcoat 1, coat roughness 0.03), a varnished box
#        (clearcoat 0.7, 0.2), a cloth ball (sheen) and a ball of green glass (absorbing); a
#        point lamp and a sun. Blender 3.4 writes the clearcoat and the transmission; the sheen
#        (KHR_materials_sheen) and the glass's absorption (KHR_materials_volume), which its
#        exporter drops, are added to the written file's JSON here.
import json
import math
import random
import struct
import sys

import bpy


def material(name, colour, metallic=0.0, roughness=0.5, emission=None, **inputs):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    p = m.node_tree.nodes["Principled BSDF"]
    p.inputs["Base Color"].default_value = (*colour, 1)
    p.inputs["Metallic"].default_value = metallic
    p.inputs["Roughness"].default_value = roughness
    for key, value in inputs.items():  # e.g. Clearcoat=1.0, Transmission=1.0
        p.inputs[key.replace("_", " ")].default_value = value
    if emission:
        p.inputs["Emission"].default_value = (*emission, 1)
        p.inputs["Emission Strength"].default_value = 1.0
    return m


def lamp(sc, name, kind, energy, location, rotation=(0, 0, 0), colour=(1, 1, 1)):
    data = bpy.data.lights.new(name, kind)
    data.energy = energy
    data.color = colour
    obj = bpy.data.objects.new(name, data)
    obj.location, obj.rotation_euler = location, rotation
    sc.collection.objects.link(obj)
    return data


def camera(sc, location, tilt_degrees, fov):
    data = bpy.data.cameras.new("camera")
    data.sensor_fit = "VERTICAL"
    data.angle_y = fov
    obj = bpy.data.objects.new("camera", data)
    obj.location, obj.rotation_euler = location, (math.radians(tilt_degrees), 0, 0)
    sc.collection.objects.link(obj)
    sc.camera = obj


def add(mat):
    bpy.context.object.data.materials.append(mat)


def lamps_scene(sc, which):
    bpy.ops.mesh.primitive_plane_add(size=12, location=(0, 0, 0))
    add(material("ground", (0.6, 0.6, 0.6), roughness=0.8))
    bpy.ops.mesh.primitive_cube_add(size=1.2, location=(-1.4, 0.6, 0.6), rotation=(0, 0, 0.4))
    add(material("box", (0.7, 0.3, 0.2), roughness=0.6))
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.7, location=(0.3, -0.2, 0.7), segments=64,
                                         ring_count=32)
    bpy.ops.object.shade_smooth()
    add(material("metal", (0.9, 0.8, 0.6), metallic=1.0, roughness=0.3))
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.5, location=(1.6, 0.8, 0.5), segments=64,
                                         ring_count=32)
    bpy.ops.object.shade_smooth()
    add(material("plastic", (0.2, 0.4, 0.8), roughness=0.4))
    if which in ("lamps", "point"):
        lamp(sc, "point", "POINT", 300, (2, -2, 3))
    if which in ("lamps", "spot"):
        spot = lamp(sc, "spot", "SPOT", 500, (-2.5, -2, 4), (math.radians(35), 0, math.radians(-40)))
        spot.spot_size = math.radians(50)
    if which in ("lamps", "sun"):
        lamp(sc, "sun", "SUN", 2, (0, 0, 6), (math.radians(40), 0, math.radians(30)))
    camera(sc, (0, -7, 3), 70, 0.7)


def many_scene(sc):
    rng = random.Random(7)
    bpy.ops.mesh.primitive_plane_add(size=20, location=(0, 0, 0))
    add(material("floor", (0.6, 0.6, 0.6), roughness=0.8))
    for i in range(6):
        bpy.ops.mesh.primitive_cube_add(size=1.0, location=(rng.uniform(-7, 7), rng.uniform(-7, 7), 0.5),
                                        rotation=(0, 0, rng.uniform(0, 3)))
        add(material("box%d" % i, (rng.uniform(0.2, 0.8), 0.4, 0.3)))
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.8, location=(1.0, 1.0, 0.8), segments=48,
                                         ring_count=24)
    bpy.ops.object.shade_smooth()
    add(material("ball", (0.8, 0.7, 0.5), roughness=0.5))
    for i in range(64):
        energy = rng.uniform(5, 60)
        colour = (1.0, rng.uniform(0.6, 1.0), rng.uniform(0.4, 1.0))
        location = (rng.uniform(-9, 9), rng.uniform(-9, 9), rng.uniform(1.0, 2.5))
        lamp(sc, "p%d" % i, "POINT", energy, location, colour=colour)
    for i in range(16):
        x, y = -7.5 + 5 * (i % 4), -7.5 + 5 * (i // 4)
        bpy.ops.mesh.primitive_plane_add(size=0.6, location=(x, y, 3.5), rotation=(math.pi, 0, 0))
        s = rng.uniform(2, 8)
        add(material("panel%d" % i, (0, 0, 0), emission=(s, s, s * 0.9)))
    camera(sc, (0, -13, 3), 78, 0.9)


# Extensions Blender 3.4's exporter does not write, added by material name after export.
LAYERS_EXTENSIONS = {
    "cloth": {"KHR_materials_sheen": {"sheenColorFactor": [0.9, 0.9, 1.0],
                                      "sheenRoughnessFactor": 0.4}},
    "green glass": {"KHR_materials_volume": {"thicknessFactor": 1.0,
                                             "attenuationDistance": 0.5,
                                             "attenuationColor": [0.3, 0.8, 0.5]}},
}


def layers_scene(sc):
    bpy.ops.mesh.primitive_plane_add(size=12, location=(0, 0, 0))
    add(material("ground", (0.6, 0.6, 0.6), roughness=0.8))
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.7, location=(-1.5, 0.2, 0.7), segments=64,
                                         ring_count=32)
    bpy.ops.object.shade_smooth()
    add(material("car paint", (0.5, 0.02, 0.02), roughness=0.4, Clearcoat=1.0,
                 Clearcoat_Roughness=0.03))
    bpy.ops.mesh.primitive_cube_add(size=1.2, location=(0.3, 1.0, 0.6), rotation=(0, 0, 0.4))
    add(material("varnish", (0.45, 0.25, 0.1), roughness=0.6, Clearcoat=0.7,
                 Clearcoat_Roughness=0.2))
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.5, location=(1.6, -0.6, 0.5), segments=64,
                                         ring_count=32)
    bpy.ops.object.shade_smooth()
    add(material("cloth", (0.15, 0.15, 0.45), roughness=1.0))
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.5, location=(-0.2, -1.3, 0.5), segments=64,
                                         ring_count=32)
    bpy.ops.object.shade_smooth()
    add(material("green glass", (1, 1, 1), roughness=0.0, Transmission=1.0, IOR=1.5))
    lamp(sc, "point", "POINT", 400, (2, -2, 3))
    lamp(sc, "sun", "SUN", 2, (0, 0, 6), (math.radians(40), 0, math.radians(30)))
    camera(sc, (0, -7, 3), 70, 0.7)


def add_material_extensions(path, extensions):
    """Adds extensions to the named materials of a .glb's JSON chunk (rewrites the file)."""
    data = open(path, "rb").read()
    json_length = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20:20 + json_length])
    rest = data[20 + json_length:]
    for m in doc.get("materials", []):
        for name, ext in extensions.get(m.get("name"), {}).items():
            m.setdefault("extensions", {})[name] = ext
            used = doc.setdefault("extensionsUsed", [])
            if name not in used:
                used.append(name)
    chunk = json.dumps(doc, separators=(",", ":")).encode()
    chunk += b" " * (-len(chunk) % 4)
    out = struct.pack("<III", 0x46546C67, 2, 12 + 8 + len(chunk) + len(rest))
    out += struct.pack("<II", len(chunk), 0x4E4F534A) + chunk + rest
    open(path, "wb").write(out)


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    if len(argv) != 2 or argv[0] not in ("lamps", "point", "spot", "sun", "many", "layers"):
        sys.exit("usage: blender -b --factory-startup --python make_blender_scenes.py -- "
                 "lamps|point|spot|sun|many|layers OUT.glb")
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    if argv[0] == "many":
        many_scene(sc)
    elif argv[0] == "layers":
        layers_scene(sc)
    else:
        lamps_scene(sc, argv[0])
    bpy.ops.export_scene.gltf(filepath=argv[1], export_format="GLB", export_cameras=True,
                              export_lights=True, export_apply=True)
    if argv[0] == "layers":
        add_material_extensions(argv[1], LAYERS_EXTENSIONS)


main()
