#!/usr/bin/env python3
"""corner_compare.py DIR A B [TOL]

A and B name dumps DIR/A-{vertices,faces,uv,normals,material}.bin (h5dump -b
LE of a mesh's datasets: f64, i32, f64, f64, i32) of two imports of one
asset whose vertices may be numbered differently (an FBX import has one
vertex per face corner).  Checks that they have the same faces, and that
every face corner has the same position, UV and normal and every face the
same material, exactly or within TOL (absolute; an ASCII FBX keeps about
6 significant digits).  Prints the counts; exits 1 on failure."""
import struct
import sys


def load(d, name, part, fmt, width):
    raw = open(f"{d}/{name}-{part}.bin", "rb").read()
    n = len(raw) // struct.calcsize("<" + fmt)
    vals = struct.unpack("<%d%s" % (n, fmt), raw)
    return [vals[i:i + width] for i in range(0, n, width)]


d, a, b = sys.argv[1:4]
tol = float(sys.argv[4]) if len(sys.argv) > 4 else 0.0
m = {}
for name in (a, b):
    m[name] = {"V": load(d, name, "vertices", "d", 3), "F": load(d, name, "faces", "i", 3),
               "uv": load(d, name, "uv", "d", 2), "n": load(d, name, "normals", "d", 3),
               "mat": load(d, name, "material", "i", 1)}
A, B = m[a], m[b]
print(f"{a}: {len(A['V'])} vertices, {len(A['F'])} faces; {b}: {len(B['V'])} vertices, "
      f"{len(B['F'])} faces")
bad = 0
if len(A["F"]) != len(B["F"]) or A["mat"] != B["mat"]:
    print("FAIL: face counts or materials differ")
    sys.exit(1)
for fa, fb in zip(A["F"], B["F"]):
    for ia, ib in zip(fa, fb):
        for key in ("V", "uv", "n"):
            if not all(abs(x - y) <= tol for x, y in zip(A[key][ia], B[key][ib])):
                bad += 1
if bad:
    print(f"FAIL: {bad} corner values differ")
sys.exit(1 if bad else 0)
