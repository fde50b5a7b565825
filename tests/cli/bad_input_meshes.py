#!/usr/bin/env python3
"""Small OBJ meshes with one defect each, written into the current directory,
for tests/cli/test_bad_input_table.sh and tests/driver/test_mesh_degenerate.sh
(run with /usr/bin/python3 in the test's scratch directory).

    bad_input_meshes.py table     the clean source, target and poses, and the
                                  topology and zero-area variants
    bad_input_meshes.py needles   the same, plus needle variants of the target
                                  and of the source (with poses), one per
                                  height in NEEDLE_HEIGHTS

The source is a UV sphere (86 vertices, 168 triangles), the target an
ellipsoid with the same connectivity (so marker i -> i is a valid marker);
pose k bends the source (x += 0.2 k z^2) and stretches it along z.  Every
variant adds vertices at the end, so the first 86 vertices keep their
numbers.
"""
import math
import sys

# Needle triangles: a vertex at this height above the opposite edge.
NEEDLE_HEIGHTS = {"h0": 0.0, "h1e-12": 1e-12, "h1e-9": 1e-9, "h1e-6": 1e-6}


def sphere(nu=12, nv=8, s=(1.0, 1.0, 1.0)):
    """A UV sphere with semi-axes s: poles 0 and last, nv - 1 rings of nu."""
    V = [(0.0, 0.0, s[2])]
    for i in range(1, nv):
        th = math.pi * i / nv
        for j in range(nu):
            ph = 2 * math.pi * j / nu
            V.append((s[0] * math.sin(th) * math.cos(ph), s[1] * math.sin(th) * math.sin(ph),
                      s[2] * math.cos(th)))
    V.append((0.0, 0.0, -s[2]))
    F = [(0, 1 + j, 1 + (j + 1) % nu) for j in range(nu)]
    for i in range(nv - 2):
        for j in range(nu):
            a, b = 1 + i * nu + j, 1 + i * nu + (j + 1) % nu
            F += [(a, a + nu, b + nu), (a, b + nu, b)]
    base, south = 1 + (nv - 2) * nu, len(V) - 1
    F += [(base + j, south, base + (j + 1) % nu) for j in range(nu)]
    return V, F


def write(path, V, F):
    with open(path, "w") as f:
        f.writelines("v %.17g %.17g %.17g\n" % v for v in V)
        f.writelines("f %d %d %d\n" % (a + 1, b + 1, c + 1) for a, b, c in F)


def pose(V, k):
    return [(x + 0.2 * k * z * z, y, z * (1 + 0.1 * k)) for x, y, z in V]


def frames(name, V, F):
    """Poses 1, 2, 3 of V as name-1.obj, name-2.obj, name-3.obj."""
    for k in (1, 2, 3):
        write("%s-%d.obj" % (name, k), pose(V, k), F)


def needle(X, t, h):
    """Vertex t[1] moved to height h above the middle of edge t[0]-t[2],
    towards where it was: h = 0 gives a zero-area triangle."""
    X = list(X)
    m = [(X[t[0]][k] + X[t[2]][k]) / 2 for k in range(3)]
    d = [X[t[1]][k] - m[k] for k in range(3)]
    n = math.sqrt(sum(x * x for x in d))
    X[t[1]] = tuple(m[k] + h * d[k] / n for k in range(3))
    return X


def main(mode):
    V, F = sphere()
    T, _ = sphere(s=(1.5, 0.8, 1.2))
    n = len(V)
    write("src.obj", V, F)
    frames("src", V, F)
    write("tgt.obj", T, F)

    # Two copies side by side: two connected components.
    shift = lambda X: [(x + 4, y, z) for x, y, z in X]
    F2 = F + [(a + n, b + n, c + n) for a, b, c in F]
    write("tgt_two.obj", T + shift(T), F2)
    write("src_two.obj", V + shift(V), F2)
    frames("src_two", V + shift(V), F2)

    # Split along ring 3 (vertices 25..36): the faces below it use copies of
    # its vertices (86..97), so the mesh falls into two pieces at a seam.
    lo, hi = 25, 37
    write("tgt_seam.obj", T + [T[v] for v in range(lo, hi)],
          [tuple(v + n - lo if lo <= v < hi and max(t) >= hi else v for v in t) for t in F])

    # A vertex in no face.
    write("tgt_unref.obj", T + [(5.0, 5.0, 5.0)], F)
    write("src_unref.obj", V + [(5.0, 5.0, 5.0)], F)
    frames("src_unref", V + [(5.0, 5.0, 5.0)], F)

    # Vertex 40 duplicated, the copy used by two of its faces: a partial
    # seam that leaves the mesh connected.
    Fd, k = [], 0
    for t in F:
        if 40 in t and k < 2:
            t = tuple(n if v == 40 else v for v in t)
            k += 1
        Fd.append(t)
    write("tgt_dup.obj", T + [T[40]], Fd)

    # A fin triangle on an edge of face 20: a non-manifold edge.
    a, b, _ = F[20]
    fin = lambda X: X + [tuple(0.75 * (X[a][k] + X[b][k]) for k in range(3))]
    write("tgt_nonman.obj", fin(T), F + [(a, b, n)])
    write("src_nonman.obj", fin(V), F + [(a, b, n)])
    frames("src_nonman", fin(V), F + [(a, b, n)])

    # Face 7 twice.
    write("tgt_dupface.obj", T, F + [F[7]])

    # Zero-area triangles (face 20 of the target, face 30 of the source).
    write("tgt_zero.obj", needle(T, F[20], 0.0), F)
    write("src_zero.obj", needle(V, F[30], 0.0), F)
    frames("src_zero", needle(V, F[30], 0.0), F)

    # Poses in which face 50 collapses to a point, and in which all do.
    P = pose(V, 2)
    a, b, c = F[50]
    P[b] = P[a]
    P[c] = P[a]
    write("pose_collapsed.obj", P, F)
    write("pose_point.obj", [(0.0, 0.0, 0.0)] * n, F)

    if mode == "needles":
        for name, h in NEEDLE_HEIGHTS.items():
            write("tgt_%s.obj" % name, needle(T, F[20], h), F)
            S = needle(V, F[30], h)
            write("src_%s.obj" % name, S, F)
            frames("src_%s" % name, S, F)


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "table")
