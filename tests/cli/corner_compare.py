#!/usr/bin/env python3
"""corner_compare.py DIR A B [TOL]
   corner_compare.py --frames T DIR A B TOL
   corner_compare.py --markers FACES.bin IN.csv OUT.csv

A and B name dumps DIR/A-{vertices,faces,uv,normals,material}.bin (h5dump -b
LE of a mesh's datasets: f64, i32, f64, f64, i32) of two imports of one
asset whose vertices may be numbered differently (an FBX import has one
vertex per face corner).  Checks that they have the same faces, and that
every face corner has the same position, UV and normal and every face the
same material, exactly or within TOL (absolute; an ASCII FBX keeps about
6 significant digits).

--frames T: compares T result frames DIR/rA-vertices.bin and
DIR/rB-vertices.bin (T x nv x 3 f64) corner by corner instead, through the
meshes' faces.  --markers: rewrites a marker CSV's target vertices (on A's
vertices, FACES.bin = A's faces) to the first face corner of each, the
vertex numbering of a per-corner import.  Prints the figures; exits 1 on
failure."""
import struct
import sys


def load(path, fmt, width):
    raw = open(path, "rb").read()
    n = len(raw) // struct.calcsize("<" + fmt)
    vals = struct.unpack("<%d%s" % (n, fmt), raw)
    return [vals[i:i + width] for i in range(0, n, width)]


def close(p, q, tol):
    return all(abs(x - y) <= tol for x, y in zip(p, q))


args = sys.argv[1:]
if args[0] == "--markers":
    first = {}
    for c, v in enumerate(x for f in load(args[1], "i", 3) for x in f):
        first.setdefault(v, c)
    with open(args[3], "w") as o:
        for line in open(args[2]):
            p = line.rstrip("\n").split(",")
            if len(p) >= 2 and p[1].strip().isdigit():
                p[1] = str(first[int(p[1])])
            o.write(",".join(p) + "\n")
    sys.exit(0)
frames = 0
if args[0] == "--frames":
    frames, args = int(args[1]), args[2:]
d, a, b = args[:3]
tol = float(args[3]) if len(args) > 3 else 0.0
m = {}
for name in (a, b):
    m[name] = {"V": load(f"{d}/{name}-vertices.bin", "d", 3),
               "F": load(f"{d}/{name}-faces.bin", "i", 3)}
    if frames:
        m[name]["R"] = load(f"{d}/r{name}-vertices.bin", "d", 3)
    else:
        m[name].update(uv=load(f"{d}/{name}-uv.bin", "d", 2),
                       n=load(f"{d}/{name}-normals.bin", "d", 3),
                       mat=load(f"{d}/{name}-material.bin", "i", 1))
A, B = m[a], m[b]
print(f"{a}: {len(A['V'])} vertices, {len(A['F'])} faces; {b}: {len(B['V'])} vertices, "
      f"{len(B['F'])} faces")
if len(A["F"]) != len(B["F"]) or (not frames and A["mat"] != B["mat"]):
    print("FAIL: face counts or materials differ")
    sys.exit(1)
bad, worst = 0, 0.0
for fa, fb in zip(A["F"], B["F"]):
    for ia, ib in zip(fa, fb):
        if frames:
            na, nb = len(A["V"]), len(B["V"])
            for t in range(frames):
                p, q = A["R"][t * na + ia], B["R"][t * nb + ib]
                worst = max(worst, max(abs(x - y) for x, y in zip(p, q)))
                bad += not close(p, q, tol)
        else:
            for key in ("V", "uv", "n"):
                bad += not close(A[key][ia], B[key][ib], tol)
if frames:
    print(f"{frames} frames: worst corner difference {worst:.3g}")
if bad:
    print(f"FAIL: {bad} corner values differ by more than {tol}")
sys.exit(1 if bad else 0)
