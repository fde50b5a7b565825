#!/usr/bin/env python3
"""make_glb.py IN.obj OUT.glb OUT.obj [MARKERS.csv OUT-MARKERS.csv]

Writes the OBJ asset IN.obj (v/vt/vn faces, usemtl groups) as a glTF 2.0
binary the way a DCC exporter does: one mesh with a primitive per material,
each with its own vertices (POSITION, NORMAL, TEXCOORD_0 with glTF's v down,
uint32 indices), and the same asset as OUT.obj in the glb's vertex order
(primitives concatenated) with positions and normals rounded to float32 and
UVs to multiples of 2^-16 (exact in float32, also after v -> 1 - v), so that
both files hold exactly the same numbers.  Only python3's struct and json:
no new dependency.  With MARKERS.csv (source,target pairs on IN.obj's
vertices), writes them with the targets renumbered for the new order."""
import json
import struct
import sys


def f32(x):
    return struct.unpack("<f", struct.pack("<f", x))[0]


def q16(x):
    return round(x * 65536) / 65536


src, glb_path, obj_path = sys.argv[1:4]
V, VT, VN, faces, mtllib = [], [], [], [], None
cur = None
for line in open(src):
    w = line.split()
    if not w:
        continue
    if w[0] == "v":
        V.append([f32(float(x)) for x in w[1:4]])
    elif w[0] == "vt":
        VT.append([q16(float(x)) for x in w[1:3]])
    elif w[0] == "vn":
        VN.append([f32(float(x)) for x in w[1:4]])
    elif w[0] == "usemtl":
        cur = w[1]
    elif w[0] == "mtllib":
        mtllib = line.split(None, 1)[1].strip()
    elif w[0] == "f":
        corners = [tuple(int(p) - 1 for p in c.split("/")) for c in w[1:4]]
        faces.append((cur, corners))

materials = []
for m, _ in faces:
    if m not in materials:
        materials.append(m)
# One primitive per material; its vertices are the distinct (v, t, n)
# corners of its faces, in ascending order.
prims = []
for m in materials:
    fs = [c for mm, c in faces if mm == m]
    keys = sorted(set(k for c in fs for k in c))
    index = {k: i for i, k in enumerate(keys)}
    prims.append((m, keys, [[index[k] for k in c] for c in fs]))

# ---- the OBJ in the glb's order
with open(obj_path, "w") as o:
    if mtllib:
        o.write(f"mtllib {mtllib}\n")
    for _, keys, _ in prims:
        for v, t, n in keys:
            o.write("v %.17g %.17g %.17g\n" % tuple(V[v]))
    for _, keys, _ in prims:
        for v, t, n in keys:
            o.write("vt %.17g %.17g\n" % tuple(VT[t]))
    for _, keys, _ in prims:
        for v, t, n in keys:
            o.write("vn %.17g %.17g %.17g\n" % tuple(VN[n]))
    base = 1
    for m, keys, fs in prims:
        o.write(f"usemtl {m}\n")
        for c in fs:
            o.write("f " + " ".join("%d/%d/%d" % (base + i, base + i, base + i) for i in c) + "\n")
        base += len(keys)

# ---- the glb
blob = bytearray()
views, accessors, primitives = [], [], []


def add(data, count, comp, typ, target, minmax=None):
    while len(blob) % 4:
        blob.append(0)
    views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data),
                  "target": target})
    blob.extend(data)
    acc = {"bufferView": len(views) - 1, "componentType": comp, "count": count, "type": typ}
    if minmax:
        acc["min"], acc["max"] = minmax
    accessors.append(acc)
    return len(accessors) - 1


for mi, (m, keys, fs) in enumerate(prims):
    pos = [V[v] for v, _, _ in keys]
    lo = [min(p[k] for p in pos) for k in range(3)]
    hi = [max(p[k] for p in pos) for k in range(3)]
    a_pos = add(b"".join(struct.pack("<3f", *p) for p in pos), len(keys), 5126, "VEC3", 34962,
                (lo, hi))
    a_nrm = add(b"".join(struct.pack("<3f", *VN[n]) for _, _, n in keys), len(keys), 5126,
                "VEC3", 34962)
    a_uv = add(b"".join(struct.pack("<2f", VT[t][0], 1.0 - VT[t][1]) for _, t, _ in keys),
               len(keys), 5126, "VEC2", 34962)
    a_ix = add(b"".join(struct.pack("<3I", *c) for c in fs), 3 * len(fs), 5125, "SCALAR", 34963)
    primitives.append({"attributes": {"POSITION": a_pos, "NORMAL": a_nrm, "TEXCOORD_0": a_uv},
                       "indices": a_ix, "material": mi, "mode": 4})
while len(blob) % 4:
    blob.append(0)
gltf = {"asset": {"version": "2.0", "generator": "dtx tests/cli/make_glb.py"},
        "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0, "name": "asset"}],
        "meshes": [{"name": "asset", "primitives": primitives}],
        "materials": [{"name": m, "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.7, 0.5, 1]}}
                      for m in materials],
        "buffers": [{"byteLength": len(blob)}], "bufferViews": views, "accessors": accessors}
js = json.dumps(gltf, separators=(",", ":")).encode()
js += b" " * (-len(js) % 4)
with open(glb_path, "wb") as g:
    g.write(struct.pack("<III", 0x46546C67, 2, 12 + 8 + len(js) + 8 + len(blob)))
    g.write(struct.pack("<II", len(js), 0x4E4F534A) + js)
    g.write(struct.pack("<II", len(blob), 0x004E4942) + bytes(blob))
print(f"{glb_path}: {sum(len(k) for _, k, _ in prims)} vertices, {len(faces)} triangles, "
      f"{len(prims)} primitives ({', '.join(materials)})")

if len(sys.argv) > 5:
    first = {}
    base = 0
    for _, keys, _ in prims:
        for i, (v, _, _) in enumerate(keys):
            first.setdefault(v, base + i)
        base += len(keys)
    with open(sys.argv[5], "w") as o:
        for line in open(sys.argv[4]):
            p = line.rstrip("\n").split(",")
            if len(p) >= 2 and p[1].strip().isdigit():
                p[1] = str(first[int(p[1])])
            o.write(",".join(p) + "\n")
