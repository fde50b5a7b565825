#!/usr/bin/env python3
"""seam_compare.py SPLIT_REST.obj SPLIT_FRAME.obj WELDED_FRAME.obj [--expect-torn]

Checks a result frame of a seam-split target against the result frame of
the welded target: the split frame keeps the asset's vertex count, twins
(vertices at the same rest position) have identical positions, and every
vertex equals its welded vertex (the lowest index at its rest position) to
1e-12 relative to the welded frame's bounding-box diagonal.  With
--expect-torn, checks the opposite (the unwelded result of the issue: twins
apart by more than 1e-4 of the diagonal) so the test shows it can fail.
Prints the figures; exits 1 on failure."""
import math
import sys


def read_v(path):
    out = []
    with open(path) as f:
        for line in f:
            if line.startswith("v "):
                out.append(tuple(float(x) for x in line.split()[1:4]))
    return out


rest, split, welded = (read_v(p) for p in sys.argv[1:4])
torn = "--expect-torn" in sys.argv
ok = True
if len(split) != len(rest):
    print(f"split frame has {len(split)} vertices, the asset {len(rest)}")
    sys.exit(1)
first = {}
orig = []
for i, p in enumerate(rest):
    orig.append(first.setdefault(p, i))
lo = [min(p[k] for p in welded) for k in range(3)]
hi = [max(p[k] for p in welded) for k in range(3)]
diag = math.dist(lo, hi)
twin_gap = max((math.dist(split[i], split[orig[i]]) for i in range(len(rest)) if orig[i] != i),
               default=0.0)
ntwins = sum(1 for i in range(len(rest)) if orig[i] != i)
# Welded index of orig[i]: the originals come first in the asset's order.
welded_of = {}
for i in range(len(rest)):
    if orig[i] == i:
        welded_of[i] = len(welded_of)
if len(welded_of) != len(welded):
    print(f"{len(welded_of)} distinct rest positions but the welded frame has {len(welded)}")
    sys.exit(1)
shift = max(math.dist(split[i], welded[welded_of[orig[i]]]) for i in range(len(rest)))
print(f"{ntwins} twins; twin gap {twin_gap / diag:.3g}, max shift from the welded transfer "
      f"{shift / diag:.3g} (of the diagonal {diag:.4g})")
if torn:
    ok = twin_gap > 1e-4 * diag
else:
    ok = ntwins > 0 and twin_gap == 0.0 and shift <= 1e-12 * diag
sys.exit(0 if ok else 1)
