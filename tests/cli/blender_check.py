# blender_check.py: run by test_blender.sh inside Debian's Blender 3.4:
#   blender -b --factory-startup --python-exit-code 1 --python blender_check.py -- \
#       FPS FRAMES_DIR REST.obj RESULT.glb RESULT.pc2 RESULT.mdd
# FRAMES_DIR holds the result's frames as OBJ (`dtx export --obj-dir`, the
# HDF5 positions as text), frame-NNNNN.obj in order.  Performs what the
# README's "Using results in Blender" says, then compares vertex positions
# by index with the HDF5 frames, within float32 precision:
#   - the rest OBJ, imported without axis conversion or splitting;
#   - the glb, imported with the scene at the result's frame rate, at scene
#     frames 0, k and last (glTF is Y-up: Blender stores (x, -z, y));
#   - the rest OBJ with a Mesh Cache modifier on the PC2, then on the MDD,
#     at the same scene frames.
# Scene frame f shows the result's frame f (0-based, the HDF5 index): the
# scene starts at frame 0.  A check that frame 1 does not match frame 0
# makes sure the frames differ, so an off-by-one cannot pass.
import glob
import os
import sys

import numpy as np

np.bool = bool  # Debian's Blender 3.4 glTF importer still uses np.bool (numpy 1.24 removed it)

import bpy  # noqa: E402

args = sys.argv[sys.argv.index("--") + 1:]
fps, frames_dir, rest_obj, glb, pc2, mdd = int(args[0]), args[1], args[2], args[3], args[4], args[5]
fails = 0


def report(ok, what):
    global fails
    print(("ok: " if ok else "FAILED: ") + what)
    fails += 0 if ok else 1


def read_obj(path):
    return np.array([[float(t) for t in line.split()[1:4]]
                     for line in open(path) if line.startswith("v ")], dtype=np.float64)


H = [read_obj(p) for p in sorted(glob.glob(os.path.join(frames_dir, "*.obj")))]
T = len(H)
scale = max(float(np.abs(h).max()) for h in H)
tol = 8 * np.finfo(np.float32).eps * scale  # a few float32 ulps of the largest coordinate
check_frames = [0, T // 2, T - 1]


def evaluated(obj):
    """World-space positions of obj's evaluated mesh (modifiers, shape keys)."""
    dg = bpy.context.evaluated_depsgraph_get()
    ev = obj.evaluated_get(dg)
    me = ev.to_mesh()
    co = np.empty(3 * len(me.vertices))
    me.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3)
    M = np.array(ev.matrix_world)
    ev.to_mesh_clear()
    return co @ M[:3, :3].T + M[:3, 3]


def compare(got, want, what):
    if got.shape != want.shape:
        report(False, "%s: %s vertices, the HDF5 frame has %s" % (what, got.shape, want.shape))
        return
    err = float(np.abs(got - want).max())
    report(err <= tol, "%s: max |difference| %.3g (tolerance %.3g)" % (what, err, tol))


def differs(got, want, what):
    err = float(np.abs(got - want).max())
    report(err > tol, "%s differs from it (max %.3g > %.3g)" % (what, err, tol))


def fresh_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    sc.render.fps = fps
    sc.render.fps_base = 1.0
    sc.frame_start = 0
    sc.frame_end = T - 1
    return sc


def import_obj(path):
    # Blender 3.4's OBJ importer has no split options: it makes one object
    # per "o" line (dtx writes none) and keeps the file's vertex order.
    bpy.ops.wm.obj_import(filepath=path, forward_axis="Y", up_axis="Z",
                          import_vertex_groups=False, validate_meshes=False)
    return bpy.context.selected_objects[0]


# ---- the rest OBJ (the result's frame 0 is not the rest: compare with the target mesh)
sc = fresh_scene()
rest = import_obj(rest_obj)
R = read_obj(rest_obj)
compare(evaluated(rest), R, "OBJ %s: vertex positions by index" % os.path.basename(rest_obj))

# ---- the glb
sc = fresh_scene()
bpy.ops.import_scene.gltf(filepath=glb)
obj = [o for o in bpy.context.scene.objects if o.type == "MESH"][0]
yup = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]], dtype=np.float64)  # glTF -> Blender
for f in check_frames:
    sc.frame_set(f)
    compare(evaluated(obj), H[f] @ yup.T, "glb at scene frame %d = HDF5 frame %d" % (f, f))
sc.frame_set(1)
differs(evaluated(obj), H[0] @ yup.T, "glb at scene frame 1: HDF5 frame 0")

# ---- the rest OBJ with a Mesh Cache modifier: PC2, then MDD
for path, fmt in ((pc2, "PC2"), (mdd, "MDD")):
    sc = fresh_scene()
    obj = import_obj(rest_obj)
    mod = obj.modifiers.new("cache", "MESH_CACHE")
    mod.cache_format = fmt
    mod.filepath = path
    for f in check_frames:
        sc.frame_set(f)
        compare(evaluated(obj), H[f], "%s on the rest OBJ at scene frame %d = HDF5 frame %d"
                % (fmt, f, f))
    sc.frame_set(1)
    differs(evaluated(obj), H[0], "%s at scene frame 1: HDF5 frame 0" % fmt)

print("blender_check: %d failed" % fails)
sys.exit(1 if fails else 0)
