# Writes tests/data/blender_ramp.hdr with Blender's own Radiance writer (run-length encoded), for
# Environment.RadianceHdrWrittenByBlender:
#   blender -b --factory-startup --python tests/data/make_blender_ramp_hdr.py -- tests/data/blender_ramp.hdr
# (Non-Color: Blender otherwise writes the values through the sRGB transfer function.)
import bpy, sys
w, h = 40, 6
img = bpy.data.images.new("ramp", w, h, float_buffer=True, alpha=False)
px = []
for y in range(h):  # Blender's rows from the bottom
    top = h - 1 - y
    for x in range(w):
        px += [0.1 + 0.1 * x, 0.5, 0.25 * (top + 1), 1.0]
img.colorspace_settings.name = "Non-Color"
img.pixels = px
img.filepath_raw = sys.argv[-1]
img.file_format = "HDR"
img.save()
