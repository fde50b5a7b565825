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
#
# With two more arguments, ASSET.glb ASSET.obj (a glb exported from a result
# whose target was imported from ASSET.obj, an OBJ with vt, usemtl and a
# .mtl): the glb's UV layer at every loop equals the OBJ's vt of that face
# corner (Blender makes one polygon per glTF triangle, primitives -- one per
# material, in the order of first use -- one after the other, faces in the
# OBJ's order within each), the loop's vertex is at the OBJ corner's
# position, the materials are the .mtl's, by name, with its Kd as base
# colour, or, for one with map_Kd, an image texture feeding the base colour
# that is packed in the .blend (embedded in the glb) with the PNG's size.
import glob
import os
import sys

import numpy as np

np.bool = bool  # Debian's Blender 3.4 glTF importer still uses np.bool (numpy 1.24 removed it)

import bpy  # noqa: E402

args = sys.argv[sys.argv.index("--") + 1:]
fps, frames_dir, rest_obj, glb, pc2, mdd = int(args[0]), args[1], args[2], args[3], args[4], args[5]
asset_glb, asset_obj = (args[6], args[7]) if len(args) >= 8 else (None, None)
# A frame of the asset's result exported by `dtx export --obj-dir` (with vt/usemtl).
asset_frame_obj = args[8] if len(args) >= 9 else None
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



def read_asset(path):
    """Positions, UVs, triangles (v, t indices, material) and mtllib of an
    OBJ whose faces are triangles with v/t/n references."""
    V, VT, tris, mats, lib, cur = [], [], [], [], None, -1
    for line in open(path):
        w = line.split()
        if not w:
            continue
        if w[0] == "v":
            V.append([float(x) for x in w[1:4]])
        elif w[0] == "vt":
            VT.append([float(x) for x in w[1:3]])
        elif w[0] == "usemtl":
            if w[1] not in mats:
                mats.append(w[1])
            cur = mats.index(w[1])
        elif w[0] == "mtllib":
            lib = w[1]
        elif w[0] == "f":
            c = [[int(x) - 1 for x in r.split("/")[:2]] for r in w[1:4]]
            tris.append((c, cur))
    return np.array(V), np.array(VT), tris, mats, lib


def read_mtl(path):
    out, cur = {}, None
    for line in open(path):
        w = line.split()
        if len(w) >= 2 and w[0] == "newmtl":
            cur = out.setdefault(w[1], {})
        elif cur is not None and len(w) >= 4 and w[0] == "Kd":
            cur["Kd"] = [float(x) for x in w[1:4]]
        elif cur is not None and len(w) >= 2 and w[0] == "map_Kd":
            cur["map_Kd"] = w[-1]
    return out


def png_size(path):
    with open(path, "rb") as f:
        head = f.read(24)
    return int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big")


if asset_glb:
    sc = fresh_scene()
    bpy.ops.import_scene.gltf(filepath=asset_glb)
    obj = [o for o in bpy.context.scene.objects if o.type == "MESH"][0]
    me = obj.data
    AV, AT, tris, mat_names, lib = read_asset(asset_obj)
    mtl = read_mtl(os.path.join(os.path.dirname(asset_obj), lib))
    name = os.path.basename(asset_glb)
    # Expected faces in Blender's order: material by material, file order within.
    order = [t for m in range(len(mat_names)) for t in tris if t[1] == m]
    report(len(me.uv_layers) == 1, "%s: %d UV layer(s)" % (name, len(me.uv_layers)))
    report(len(me.polygons) == len(order),
           "%s: %d polygons for the OBJ's %d triangles" % (name, len(me.polygons), len(order)))
    if len(me.uv_layers) == 1 and len(me.polygons) == len(order):
        nl = len(me.loops)
        uv = np.empty(2 * nl)
        me.uv_layers[0].data.foreach_get("uv", uv)
        lv = np.empty(nl, dtype=np.int64)
        me.loops.foreach_get("vertex_index", lv)
        co = np.empty(3 * len(me.vertices))
        me.vertices.foreach_get("co", co)
        co = co.reshape(-1, 3) @ np.linalg.inv(np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]])).T
        want_uv = np.array([AT[c[1]] for t in order for c in t[0]])
        want_co = np.array([AV[c[0]] for t in order for c in t[0]])
        uv_err = float(np.abs(uv.reshape(-1, 2) - want_uv).max())
        co_err = float(np.abs(co[lv] - want_co).max())
        uv_tol = 4 * np.finfo(np.float32).eps
        co_tol = 8 * np.finfo(np.float32).eps * float(np.abs(AV).max())
        report(uv_err <= uv_tol, "%s: UVs at all %d loops = the OBJ's vt, max |difference| %.3g "
               "(tolerance %.3g)" % (name, nl, uv_err, uv_tol))
        report(co_err <= co_tol, "%s: each loop's vertex is at its OBJ corner's rest position, "
               "max |difference| %.3g (tolerance %.3g)" % (name, co_err, co_tol))
    got = [m.name for m in me.materials]
    report(got == mat_names, "%s: materials %s (the OBJ's: %s)" % (name, got, mat_names))
    for m in me.materials:
        want = mtl.get(m.name, {})
        bsdf = [n for n in m.node_tree.nodes if n.type == "BSDF_PRINCIPLED"][0]
        base = bsdf.inputs["Base Color"]
        if "map_Kd" in want:
            img = [lk.from_node.image for lk in base.links if lk.from_node.type == "TEX_IMAGE"]
            size = png_size(os.path.join(os.path.dirname(asset_obj), want["map_Kd"]))
            ok = (len(img) == 1 and img[0].packed_file is not None
                  and tuple(img[0].size) == size)
            report(ok, "%s: material %s: base colour from the image %s, packed, %s pixels" % (
                name, m.name, img[0].name if img else None, tuple(img[0].size) if img else None))
        else:
            c = list(base.default_value)[:3]
            ok = not base.links and "Kd" in want and max(abs(a - b) for a, b in zip(c, want["Kd"])) < 1e-6
            report(ok, "%s: material %s: base colour %s = the .mtl's Kd %s" % (
                name, m.name, ["%.3g" % x for x in c], want.get("Kd")))

if asset_frame_obj:
    # The OBJ export of the asset's result: Blender's OBJ importer reads its
    # UVs and materials, and they are the asset's own.
    sc = fresh_scene()
    obj = import_obj(asset_frame_obj)
    me = obj.data
    AV, AT, tris, mat_names, lib = read_asset(asset_obj)
    EV, ET, etris, emats, elib = read_asset(asset_frame_obj)
    name = os.path.basename(asset_frame_obj)
    report(len(me.uv_layers) == 1 and len(me.loops) == 3 * len(tris),
           "%s: %d UV layer(s), %d loops for the asset's %d triangles"
           % (name, len(me.uv_layers), len(me.loops), len(tris)))
    if len(me.uv_layers) == 1 and len(me.loops) == 3 * len(tris):
        uv = np.empty(2 * len(me.loops))
        me.uv_layers[0].data.foreach_get("uv", uv)
        # Blender keeps the file's face order: loop k is corner k of the file.
        want = np.array([AT[c[1]] for t in tris for c in t[0]])
        err = float(np.abs(uv.reshape(-1, 2) - want).max())
        tol = 4 * np.finfo(np.float32).eps
        report(err <= tol, "%s: UVs at all %d loops = the asset's vt, max |difference| %.3g "
               "(tolerance %.3g)" % (name, len(me.loops), err, tol))
    got = [m.name for m in me.materials]
    report(got == mat_names and elib == lib,
           "%s: materials %s and mtllib %s (the asset's: %s, %s)" % (name, got, elib, mat_names, lib))

print("blender_check: %d failed" % fails)
sys.exit(1 if fails else 0)
