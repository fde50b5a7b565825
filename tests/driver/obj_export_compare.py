#!/usr/bin/env python3
"""obj_export_compare.py ASSET.obj EXPORTED.obj FRAME.bin [--rest]

Checks an OBJ frame that dtx wrote (dtx export --obj-dir, or a job's
export_obj_dir) for a target asset with attributes against the asset's OBJ:
  - the asset's vertex count and order: positions equal FRAME.bin (the
    frame of the HDF5 result as little-endian float64, from h5dump -b LE)
    exactly;
  - the same mtllib, the same vt values, the same face corners (vertex and
    UV indices) and the same usemtl group of every face;
  - normals: one per face corner, unit length, and equal (to 1e-9) to the
    area-weighted normals of the frame's faces around each rest position
    (twins along a seam together: the asset's normals are smooth), so
    twins' normals are identical; the asset's per-vertex normal indexing
    is kept (corner normal index = vertex index).  With --rest (the frame
    is the asset's rest shape), they also equal the asset's vn to 1e-9.
Prints the figures; exits 1 on failure."""
import math
import struct
import sys


def parse(path):
    o = {"v": [], "vt": [], "vn": [], "f": [], "mat": [], "mtllib": None}
    cur = None
    with open(path) as fh:
        for line in fh:
            w = line.split()
            if not w:
                continue
            if w[0] == "v":
                o["v"].append(tuple(float(x) for x in w[1:4]))
            elif w[0] == "vt":
                o["vt"].append(tuple(float(x) for x in w[1:3]))
            elif w[0] == "vn":
                o["vn"].append(tuple(float(x) for x in w[1:4]))
            elif w[0] == "usemtl":
                cur = w[1]
            elif w[0] == "mtllib":
                o["mtllib"] = line.split(None, 1)[1].strip()
            elif w[0] == "f":
                corners = []
                for c in w[1:]:
                    p = c.split("/") + ["", ""]
                    corners.append(tuple(int(x) - 1 if x else None for x in p[:3]))
                o["f"].append(corners)
                o["mat"].append(cur)
    return o


asset, out = parse(sys.argv[1]), parse(sys.argv[2])
raw = open(sys.argv[3], "rb").read()
X = [struct.unpack_from("<3d", raw, 24 * i) for i in range(len(raw) // 24)]
rest = "--rest" in sys.argv
bad = []
nv = len(asset["v"])
if len(out["v"]) != nv or len(X) != nv:
    bad.append(f"vertex counts: asset {nv}, export {len(out['v'])}, HDF5 frame {len(X)}")
else:
    diff = sum(1 for a, b in zip(out["v"], X) if a != b)
    if diff:
        bad.append(f"{diff} exported positions differ from the HDF5 frame")
if out["mtllib"] != asset["mtllib"]:
    bad.append(f"mtllib {out['mtllib']!r}, asset {asset['mtllib']!r}")
if out["vt"] != asset["vt"]:
    bad.append(f"vt: {len(out['vt'])} values, asset {len(asset['vt'])}, or values differ")
if len(out["f"]) != len(asset["f"]):
    bad.append(f"{len(out['f'])} faces, asset {len(asset['f'])}")
else:
    for i, (a, b) in enumerate(zip(asset["f"], out["f"])):
        if [c[:2] for c in a] != [c[:2] for c in b]:
            bad.append(f"face {i}: corners {b}, asset {a}")
            break
    if out["mat"] != asset["mat"]:
        bad.append("usemtl groups differ")
groups = {}
if out["vn"] and not bad:
    # Area-weighted normals of the frame around each rest position.
    pos = {}
    for i, v in enumerate(asset["v"]):
        pos.setdefault(v, []).append(i)
    acc = {}
    for f in out["f"]:
        a, b, c = (X[k[0]] for k in f)
        e1 = [b[j] - a[j] for j in range(3)]
        e2 = [c[j] - a[j] for j in range(3)]
        n = (e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
             e1[0] * e2[1] - e1[1] * e2[0])
        for k in f:
            s = acc.setdefault(asset["v"][k[0]], [0.0, 0.0, 0.0])
            for j in range(3):
                s[j] += n[j]
    worst = worst_rest = 0.0
    for f in out["f"]:
        for k in f:
            if k[2] is None or k[2] != k[0]:
                bad.append(f"corner {k}: normal index is not the vertex index")
                break
            n = out["vn"][k[2]]
            s = acc[asset["v"][k[0]]]
            ln = math.sqrt(sum(x * x for x in s))
            worst = max(worst, max(abs(n[j] - s[j] / ln) for j in range(3)))
            if rest:
                worst_rest = max(worst_rest, max(abs(n[j] - asset["vn"][k[0]][j])
                                                 for j in range(3)))
        if bad:
            break
    print(f"normals: {len(out['vn'])}, worst difference from the frame's area-weighted "
          f"normals {worst:.3g}" + (f", from the asset's vn {worst_rest:.3g}" if rest else ""))
    if not worst <= 1e-9:
        bad.append(f"normals differ from the frame's area-weighted normals by {worst:.3g}")
    if rest and not worst_rest <= 1e-9:
        bad.append(f"rest normals differ from the asset's vn by {worst_rest:.3g}")
elif asset["vn"] and not bad:
    bad.append("the asset has normals, the export none")
print(f"{nv} vertices, {len(out['vt'])} vt, {len(out['f'])} faces, "
      f"materials {sorted(set(m for m in out['mat'] if m))}")
for b in bad:
    print("FAIL:", b)
sys.exit(1 if bad else 0)
