#!/usr/bin/env bash
# Valgrind memcheck of dtx end to end: the bundled cat and lion imported,
# then, on small generated meshes (a 242-vertex sphere with two deformed
# frames onto an egg of another resolution, six markers), a run with the
# correspondence computed, --resume of a finished output, validate, export,
# a bad job, a run failing half-way, and a springs run (the sphere onto
# itself): zero errors and zero bytes lost in dtx, HDF5 or CHOLMOD
# (tests/valgrind.supp only holds OpenMPI's own start-up allocations).  The
# sanitizer pass runs the same code on the real meshes.  Skipped in the
# sanitizer build (ASan and valgrind do not mix).
set -euo pipefail
if [[ $(ldd "$DTX") == *libasan* ]]; then echo "skipped: sanitizer build"; exit 0; fi
command -v valgrind > /dev/null || { echo "FAILED: valgrind is not installed"; exit 1; }
D="$DTX_BUILD/data/sumner-cat-lion"
W="$DTX_TESTDATA"
rm -rf "${W:?}"/*
fails=0
vg() { # vg [!] NAME ARGS...: dtx under memcheck; fails on any error or leak ("!": dtx must fail)
    local expect=0 name rc
    if [ "$1" = "!" ]; then expect=1; shift; fi
    name=$1; shift
    set +e
    valgrind -q --num-callers=60 --error-exitcode=99 --leak-check=full \
        --show-leak-kinds=definite,indirect,possible --errors-for-leak-kinds=definite,indirect,possible \
        --suppressions="$DTX_SRC/tests/valgrind.supp" --log-file="$W/$name.vg" "$DTX" "$@" \
        > "$W/$name.out" 2>&1
    rc=$?
    set -e
    local failed=$((rc != 0))
    if [ $rc -ne 99 ] && [ $failed -eq $expect ]; then
        echo "ok: $name: exit $rc, no memcheck error, no leak"
    else
        echo "FAILED: $name (exit $rc):"; cat "$W/$name.vg" "$W/$name.out" | head -n 60
        fails=$((fails + 1))
    fi
}
export OMP_NUM_THREADS=1
# The real meshes' import (OBJ, welding, checks); the jobs run on small
# generated meshes, where memcheck takes seconds instead of minutes for the
# same code: a UV sphere of 242 vertices with two deformed frames, and an
# egg of another resolution as the target, with markers at the extremes.
vg import-cat import mesh "$D/source/cat-reference.obj" -o "$W/cat.h5" --name cat
vg import-lion import mesh "$D/target/lion-reference.obj" -o "$W/cat.h5" --name lion
/usr/bin/python3 - "$W" << 'PY'
import math, sys
w = sys.argv[1]
def sphere(path, sx, sy, sz, nu=22, nv=12):
    V = [(0.0, 0.0, sz)]
    for i in range(1, nv - 1):
        t = math.pi * i / (nv - 1)
        for j in range(nu):
            p = 2 * math.pi * j / nu
            V.append((sx * math.sin(t) * math.cos(p), sy * math.sin(t) * math.sin(p), sz * math.cos(t)))
    V.append((0.0, 0.0, -sz))
    F, last = [], len(V) - 1
    for j in range(nu):
        F.append((0, 1 + j, 1 + (j + 1) % nu))
    for i in range(nv - 3):
        for j in range(nu):
            a, b = 1 + i * nu + j, 1 + i * nu + (j + 1) % nu
            F += [(a, a + nu, b), (b, a + nu, b + nu)]
    base = 1 + (nv - 3) * nu
    for j in range(nu):
        F.append((base + j, last, base + (j + 1) % nu))
    with open(path, "w") as f:
        f.writelines("v %.9g %.9g %.9g\n" % v for v in V)
        f.writelines("f %d %d %d\n" % (a + 1, b + 1, c + 1) for a, b, c in F)
sphere(w + "/ball.obj", 1.0, 1.0, 1.0)
sphere(w + "/ball-1.obj", 1.3, 0.9, 0.8)
sphere(w + "/ball-2.obj", 0.8, 1.2, 1.1)
# The target: an egg of another resolution; markers at the six extremes.
sphere(w + "/egg.obj", 1.5, 1.0, 0.9, 17, 10)
def extremes(path):
    V = [tuple(map(float, l.split()[1:])) for l in open(path) if l.startswith("v ")]
    return [max(range(len(V)), key=lambda i: s * V[i][k]) for k in range(3) for s in (1, -1)]
with open(w + "/m.csv", "w") as f:
    f.write("source_vertex,target_vertex,label\n")
    for k, (a, b) in enumerate(zip(extremes(w + "/ball.obj"), extremes(w + "/egg.obj"))):
        f.write("%d,%d,x%d\n" % (a, b, k))
PY
vg import-ball import mesh "$W/ball.obj" -o "$W/in.h5" --name ball
vg import-egg import mesh "$W/egg.obj" -o "$W/in.h5" --name egg
vg import-seq import sequence "$W"/ball-[12].obj -o "$W/in.h5" --name poses --mesh /meshes/ball
vg import-markers import markers "$W/m.csv" --index-base 0 -o "$W/in.h5" --name m \
    --source /meshes/ball --target /meshes/egg
cat > "$W/job.json" <<JOB
{
  "dtx_job": 1,
  "method": "sp04",
  "source": {"file": "in.h5", "mesh": "/meshes/ball", "sequences": ["/sequences/*"]},
  "targets": [{"name": "egg", "file": "in.h5", "mesh": "/meshes/egg",
               "markers": {"file": "in.h5", "path": "/markers/m"}}],
  "output": {"file": "out.h5", "block_frames": 8}
}
JOB
vg run run "$W/job.json"
vg resume-finished run --resume "$W/job.json"
vg validate validate "$W/out.h5"
vg export export "$W/out.h5" /results/egg/poses --obj-dir "$W/obj"
vg ! bad-job run "$W/missing.json"
# A failure inside the run (injected at the transfer) frees everything too.
DTX_FAULT=transfer@0 vg ! failed-run run "$W/job.json"
vg validate-after-failure validate "$W/out.h5"
# Method springs on the sphere onto itself: the springs with bending and
# internal springs, the sp04 start (levels is not used then) with the
# barrier, Newton, frame_stats.
vg import-one import sequence "$W/ball-1.obj" -o "$W/in.h5" --name one --mesh /meshes/ball
cat > "$W/springs.json" <<JOB
{
  "dtx_job": 1,
  "method": "springs",
  "source": {"file": "in.h5", "mesh": "/meshes/ball", "sequences": ["/sequences/one"]},
  "targets": [{"name": "self", "file": "in.h5", "mesh": "/meshes/ball"}],
  "output": {"file": "springs.h5"},
  "springs": {"levels": 1, "coarse_min": 50, "max_iter": 3, "coarse_max_iter": 3}
}
JOB
vg springs run "$W/springs.json"
vg validate-springs validate "$W/springs.h5"
echo "valgrind: $fails failed"
test "$fails" -eq 0
