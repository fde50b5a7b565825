#!/usr/bin/env python3
"""The same small animation in every layout `dtx import sequence` reads, for
tests/cli/test_import_layouts.sh (run with /usr/bin/python3 in the test's
scratch directory; needs numpy and h5py).

The source is the UV sphere of bad_input_meshes.py (86 vertices), the
target an ellipsoid of the same connectivity.  Two sequences, "walk" (5
frames) and "jump" (3 frames), of float32 positions whose first frame of
"walk" is the rest pose, written as:

  rest.obj, tgt.obj, markers.csv    the rest mesh, the target, markers i -> i
  obj-walk/, obj-jump/              one OBJ per frame (exact float32 values)
  walk.npy                          (T, V, 3) float32, little-endian, C order
  walk-f8be-fortran.npy             the same values as big-endian float64 in
                                    Fortran order
  walk-frame0.npy                   (V, 3): frame 0 alone
  walk.pc2, walk.mdd                PC2 and MDD point caches of "walk"
  dfaust.hdf5                       DFAUST's layout: /walk and /jump as
                                    (V, 3, T) float32, /faces (F, 3) int32,
                                    0-based
  other-faces.h5                    /tri: the faces in a file of their own
and the bad inputs the test feeds to dtx (bad-*.npy, bad.hdf5, bad-*.pc2,
bad-*.mdd).
"""
import os
import struct
import sys

import h5py
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bad_input_meshes import sphere  # noqa: E402

V, F = sphere()
V = np.array(V, dtype=np.float32)
F = np.array(F, dtype=np.int32)


def write(path, V, F):
    """An OBJ whose coordinates read back as exactly the same doubles."""
    with open(path, "w") as f:
        f.writelines("v %.17g %.17g %.17g\n" % tuple(v) for v in V)
        f.writelines("f %d %d %d\n" % (a + 1, b + 1, c + 1) for a, b, c in F)


T, _ = sphere(s=(1.3, 0.8, 1.6))
write("tgt.obj", T, F.tolist())
with open("markers.csv", "w") as f:
    f.write("source_vertex,target_vertex,label\n")
    for i in (0, 85, 1, 4, 40, 60):
        f.write("%d,%d,m%d\n" % (i, i, i))


def animate(n, bend):
    """n float32 frames of V, frame 0 the rest pose itself."""
    out = []
    for k in range(n):
        x, y, z = V[:, 0].astype(np.float64), V[:, 1].astype(np.float64), V[:, 2].astype(np.float64)
        out.append(np.stack([x + bend * k * z * z, y + 0.05 * k * x, z * (1 + 0.1 * k)], axis=1))
    return np.array(out, dtype=np.float32)


walk, jump = animate(5, 0.2), animate(3, -0.15)
write("rest.obj", walk[0].astype(np.float64).tolist(), F.tolist())
for name, seq in (("walk", walk), ("jump", jump)):
    os.makedirs("obj-" + name, exist_ok=True)
    for k, fr in enumerate(seq):
        write("obj-%s/%s-%d.obj" % (name, name, k), fr.astype(np.float64).tolist(), F.tolist())

np.save("walk.npy", walk)
np.save("walk-f8be-fortran.npy", np.asfortranarray(walk.astype(">f8")))
np.save("walk-frame0.npy", walk[0])
assert np.load("walk-f8be-fortran.npy").dtype.str == ">f8"
assert np.load("walk-f8be-fortran.npy", mmap_mode="r").flags.f_contiguous


def pc2(path, frames, npoints=None):
    n = frames.shape[1] if npoints is None else npoints
    with open(path, "wb") as f:
        f.write(b"POINTCACHE2\0" + struct.pack("<iiffi", 1, n, 0.0, 1.0, frames.shape[0]))
        f.write(frames.astype("<f4").tobytes())


pc2("walk.pc2", walk)
with open("walk.mdd", "wb") as f:
    f.write(struct.pack(">ii", walk.shape[0], walk.shape[1]))
    f.write((np.arange(walk.shape[0]) / 24.0).astype(">f4").tobytes())
    f.write(walk.astype(">f4").tobytes())

# DFAUST's registrations: one (V, 3, T) dataset per sequence, shared faces.
with h5py.File("dfaust.hdf5", "w") as h:
    h["walk"] = np.ascontiguousarray(walk.transpose(1, 2, 0))
    h["jump"] = np.ascontiguousarray(jump.transpose(1, 2, 0))
    h["faces"] = F
with h5py.File("other-faces.h5", "w") as h:
    h["tri"] = F

# ---- bad inputs
np.save("bad-shape.npy", np.zeros((2, 86, 4), np.float32))
np.save("bad-dtype.npy", np.zeros((2, 86, 3), np.int32))
np.save("bad-nv.npy", walk[:, :80])
nan = walk.copy()
nan[1, 3, 2] = np.nan
np.save("bad-nan.npy", nan)
with open("walk.npy", "rb") as f:
    whole = f.read()
with open("bad-truncated.npy", "wb") as f:
    f.write(whole[:-7])
pc2("bad-nv.pc2", walk[:, :80])
with open("walk.mdd", "rb") as f:
    whole = f.read()
with open("bad-truncated.mdd", "wb") as f:
    f.write(whole[:-12])
with h5py.File("bad.hdf5", "w") as h:
    h["walk"] = np.ascontiguousarray(walk.transpose(1, 2, 0))
    h["ints"] = np.zeros((86, 3, 2), np.int32)
    h["faces"] = F
    h["faces_other"] = F[:, ::-1]  # every triangle turned over
    h["faces_range"] = F + 1       # 1-based: index 86 is out of range
