# blender-picture.py: run by scripts/blender-picture.sh inside Blender:
#   blender -b --factory-startup --python blender-picture.py -- RESULT.glb OUT.png F1 F2
# Imports the glb as the README's "Using results in Blender" says, renders
# scene frames F1 and F2 (0-based result frames) from the side with
# Cycles on the CPU (32 samples; Debian's build has no denoiser), and writes them side by side
# as one PNG of 800 x 400 pixels.
import os
import sys
import tempfile

import numpy as np

np.bool = bool  # Debian's Blender 3.4 glTF importer still uses np.bool (numpy 1.24 removed it)

import bpy  # noqa: E402
from mathutils import Vector  # noqa: E402

glb, out, frames = sys.argv[-4], sys.argv[-3], [int(sys.argv[-2]), int(sys.argv[-1])]
W, H = 400, 400

bpy.ops.wm.read_factory_settings(use_empty=True)
sc = bpy.context.scene
sc.frame_start = 0
bpy.ops.import_scene.gltf(filepath=glb)
obj = [o for o in sc.objects if o.type == "MESH"][0]

# Bounds over the frames to show, so both pictures share one camera.
lo, hi = Vector((1e30,) * 3), Vector((-1e30,) * 3)
for f in frames:
    sc.frame_set(f)
    ev = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    for v in ev.to_mesh().vertices:
        p = obj.matrix_world @ v.co
        lo = Vector(map(min, lo, p))
        hi = Vector(map(max, hi, p))
    ev.to_mesh_clear()
centre, size = (lo + hi) / 2, hi - lo

cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
sc.collection.objects.link(cam)
cam.data.type = "ORTHO"
cam.data.ortho_scale = 1.1 * max(size.y, size.z)
# glTF's +z (the lion's left side) is Blender's -y; the head points to -y:
# from +x, a little above and in front, the head is on the left.
cam.location = centre + Vector((3 * max(size), -0.35 * size.y, 0.5 * size.z))
cam.rotation_euler = (centre - cam.location).to_track_quat("-Z", "Y").to_euler()
sc.camera = cam
sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
sc.collection.objects.link(sun)
sun.data.energy = 3.0
sun.rotation_euler = (0.9, 0.2, -0.6)
world = bpy.data.worlds.new("world")
sc.world = world
world.use_nodes = True
world.node_tree.nodes["Background"].inputs["Color"].default_value = (1, 1, 1, 1)
world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.35

sc.render.engine = "CYCLES"
sc.cycles.device = "CPU"
sc.cycles.samples = 32
sc.cycles.use_denoising = False  # Debian builds Blender without OpenImageDenoise
sc.render.resolution_x, sc.render.resolution_y = W, H
sc.render.resolution_percentage = 100
sc.render.film_transparent = True  # composited onto white below
sc.view_settings.view_transform = "Standard"

tmp = tempfile.mkdtemp()
pix = []
for f in frames:
    sc.frame_set(f)
    path = os.path.join(tmp, "f%d.png" % f)
    sc.render.filepath = path
    bpy.ops.render.render(write_still=True)
    img = bpy.data.images.load(path)
    a = np.empty(W * H * 4, dtype=np.float32)
    img.pixels.foreach_get(a)
    a = a.reshape(H, W, 4)
    a[:, :, :3] = a[:, :, :3] * a[:, :, 3:] + (1.0 - a[:, :, 3:])  # over white
    a[:, :, 3] = 1.0
    pix.append(np.round(a * 255) / 255)
both = np.concatenate(pix, axis=1)  # rows bottom up, as Blender stores them
res = bpy.data.images.new("both", width=2 * W, height=H)
res.pixels.foreach_set(both.ravel())
res.filepath_raw = out
res.file_format = "PNG"
res.save()
print("blender-picture: wrote %s (frames %d and %d)" % (out, frames[0], frames[1]))
