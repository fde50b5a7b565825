#!/usr/bin/env python3
"""split_poses.py SPLIT_REST.obj ORIG_REST.obj POSE.obj... OUTDIR

Applies the split of `dtx generate uvsplit` to poses of the original mesh:
the split mesh's vertex s copies the original vertex with the same rest
position (uvsplit keeps the first nv vertices in order and appends the
duplicates, so positions identify them; an ambiguous position is an
error).  Writes OUTDIR/<pose name> with the split mesh's faces and each
split vertex at its original vertex's pose position (%.17g: exact)."""
import os
import sys


def read(path):
    v, f = [], []
    for line in open(path):
        w = line.split()
        if w and w[0] == "v":
            v.append(tuple(w[1:4]))
        elif w and w[0] == "f":
            f.append([c.split("/")[0] for c in w[1:]])
    return v, f


split_v, split_f = read(sys.argv[1])
orig_v, _ = read(sys.argv[2])
at = {}
for i, p in enumerate(orig_v):
    key = tuple(float(x) for x in p)
    if key in at:
        sys.exit(f"{sys.argv[2]}: vertices {at[key]} and {i} share a position: ambiguous")
    at[key] = i
orig = [at[tuple(float(x) for x in p)] for p in split_v]
out = sys.argv[-1]
os.makedirs(out, exist_ok=True)
for pose in sys.argv[3:-1]:
    pv, _ = read(pose)
    with open(os.path.join(out, os.path.basename(pose)), "w") as o:
        for s in orig:
            o.write("v %.17g %.17g %.17g\n" % tuple(float(x) for x in pv[s]))
        for f in split_f:
            o.write("f " + " ".join(f) + "\n")
print(f"{len(sys.argv) - 4} poses split: {len(split_v)} vertices ({len(split_v) - len(orig_v)} "
      f"duplicates), {len(split_f)} faces")
