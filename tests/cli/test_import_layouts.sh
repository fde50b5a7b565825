#!/usr/bin/env bash
# Dataset layouts in (README, "Your own data" and "Bad input"): the same
# animation as OBJ frames, a .npy (T, V, 3) float32 array, a big-endian
# float64 Fortran-order .npy, PC2 and MDD caches, and DFAUST's HDF5 layout
# (one (V, 3, T) dataset per sequence and a shared int32 faces dataset,
# made here with h5py).  Each is imported, the stored frames must equal the
# OBJ import bit for bit, and a short sp04 transfer of each must give a
# result equal to the OBJ one under `dtx diff --tol 0`; the whole DFAUST
# file becomes every sequence of one job with one wildcard.  Then the bad
# inputs of the table, each tagged [row-id]: a non-zero exit, a message
# naming the file, the item and the problem, and an existing output file
# left as it was (same size, no new group, still valid).
set -uo pipefail
. "$DTX_SRC/tests/lib.sh"
W="$DTX_TESTDATA"
PY=/usr/bin/python3
cd "$W" || exit 1
if ! "$PY" -c 'import h5py, numpy' 2>/dev/null; then
    echo "skipped: needs python3-h5py and python3-numpy"
    exit 77
fi
"$PY" "$DTX_SRC/tests/cli/layout_fixtures.py" || { echo "FAILED: making the fixtures"; exit 1; }

# ------------------------------------------------------------- imports
# The target and its markers (shared by every job), then one source file
# per layout, each with the OBJ rest mesh /meshes/body.
q() { "$DTX" "$@" 2>>import.log || { echo "FAILED: dtx $*"; fails=$((fails + 1)); }; }
q import mesh tgt.obj -o tgt.h5 --name tgt
q import markers markers.csv --index-base 0 -o tgt.h5 --name m
for l in obj npy npy64 pc2 mdd; do q import mesh rest.obj -o $l.h5 --name body; done
q import sequence obj-walk -o obj.h5 --name walk --mesh /meshes/body
q import sequence obj-jump -o obj.h5 --name jump --mesh /meshes/body
q import sequence walk.npy -o npy.h5 --name walk --mesh /meshes/body
q import sequence walk-f8be-fortran.npy -o npy64.h5 --name walk --mesh /meshes/body
q import sequence walk.pc2 -o pc2.h5 --name walk --mesh /meshes/body
q import sequence walk.mdd -o mdd.h5 --name walk --mesh /meshes/body
q import sequence walk-frame0.npy -o npy.h5 --name rest --mesh /meshes/body
# DFAUST: the rest mesh is frame 0 of /walk with /faces; then every
# sequence of the file with one wildcard (the faces dataset left out).
q import mesh dfaust.hdf5 --dataset /walk --axes VCT --faces /faces -o dfaust.h5 --name body
out=$("$DTX" import sequence dfaust.hdf5 --dataset '/*' --axes VCT --faces /faces -o dfaust.h5 \
    --mesh /meshes/body 2>&1); rc=$?
check "the DFAUST file imports with one wildcard (exit 0)" test "$rc" -eq 0
check "... each dataset as /sequences/NAME: jump (3 frames)" \
    grep -q "^dtx: dfaust.hdf5:/jump: 3 frames -> dfaust.h5:/sequences/jump (float32)" <<<"$out"
check "... and walk (5 frames)" \
    grep -q "^dtx: dfaust.hdf5:/walk: 5 frames -> dfaust.h5:/sequences/walk (float32)" <<<"$out"
check "... the rest mesh's source names the dataset and frame" \
    grep -q "source *dfaust.hdf5:/walk frame 0" <<<"$("$DTX" inspect dfaust.h5 2>&1)"
# Faces from another file, a dataset of one sequence.
q import sequence dfaust.hdf5 --dataset /walk --axes VCT --faces other-faces.h5:/tri \
    -o dfaust.h5 --name walk-faces-elsewhere --mesh /meshes/body

check "every import validates" bash -c 'for f in obj npy npy64 pc2 mdd dfaust; do
    "$0" validate $f.h5 > /dev/null || exit 1; done' "$DTX"
msg=$("$PY" - <<'PY' 2>&1
import h5py, numpy as np
obj = h5py.File("obj.h5", "r")
walk = obj["/sequences/walk/positions"][...]
jump = obj["/sequences/jump/positions"][...]
assert walk.shape == (5, 86, 3) and jump.shape == (3, 86, 3), (walk.shape, jump.shape)
assert not np.array_equal(walk[0], walk[4]), "the frames move"
def same(path, ref, what):
    with h5py.File(path.split(":")[0], "r") as f:
        got = f[path.split(":")[1]][...]
    assert got.shape == ref.shape and np.array_equal(got, ref), "%s: %s differs from the OBJ import" % (what, path)
for l in ("npy", "npy64", "pc2", "mdd"):
    same(l + ".h5:/sequences/walk/positions", walk, l)
same("npy.h5:/sequences/rest/positions", walk[:1], "(V, 3) npy")
same("dfaust.h5:/sequences/walk/positions", walk, "DFAUST walk")
same("dfaust.h5:/sequences/jump/positions", jump, "DFAUST jump")
same("dfaust.h5:/sequences/walk-faces-elsewhere/positions", walk, "faces in another file")
same("dfaust.h5:/meshes/body/vertices", obj["/meshes/body/vertices"][...], "DFAUST rest vertices")
same("dfaust.h5:/meshes/body/faces", obj["/meshes/body/faces"][...], "DFAUST rest faces")
with h5py.File("dfaust.h5", "r") as f:
    assert sorted(f["/sequences"]) == ["jump", "walk", "walk-faces-elsewhere"], list(f["/sequences"])
PY
)
check "the stored frames and meshes equal the OBJ import bit for bit${msg:+: $msg}" test -z "$msg"

# --------------------------------------------------------------- transfers
# job NAME SEQUENCES: a job on NAME.h5's sequences onto the target, output
# out-NAME.h5.
job() {
    cat > "job-$1.json" <<JOB
{"dtx_job": 1, "method": "sp04",
 "source": {"file": "$1.h5", "mesh": "/meshes/body", "sequences": $2},
 "targets": [{"name": "tgt", "file": "tgt.h5", "mesh": "/meshes/tgt",
              "markers": {"file": "tgt.h5", "path": "/markers/m"}}],
 "output": {"file": "out-$1.h5"}}
JOB
    "$DTX" run --quiet "job-$1.json" || { echo "FAILED: dtx run job-$1.json"; fails=$((fails + 1)); }
}
# The sanitizer pass (DTX_SANITIZED=1) runs the .npy and DFAUST jobs only:
# the plain pass transfers every layout, and the stored frames of all of
# them are already checked equal above.
layouts="npy npy64 pc2 mdd"
[ -z "${DTX_SANITIZED:-}" ] || layouts=npy
job obj '["/sequences/*"]'
for l in $layouts; do job $l '["/sequences/walk"]'; done
job dfaust '["/sequences/*"]'
for l in $layouts dfaust; do
    check "$l: the transfer equals the OBJ import's (dtx diff --tol 0)" \
        "$DTX" diff out-obj.h5 out-$l.h5 /results/tgt/walk --tol 0
done
check "dfaust: the second sequence of the wildcard job too" \
    "$DTX" diff out-obj.h5 out-dfaust.h5 /results/tgt/jump --tol 0
check "... and the result is not the target at rest (the check can fail)" "$PY" -c '
import h5py, numpy as np
f = h5py.File("out-dfaust.h5", "r")
p, t = f["/results/tgt/walk/positions"][...], f["/results/tgt/walk/target/vertices"][...]
assert np.isfinite(p).all() and np.abs(p[4] - t).max() > 1e-3'

# -------------------------------------------------------------- bad input
# reject ROW PATTERN COMMAND...: non-zero exit (not a crash) and a message
# matching PATTERN (extended regex).
reject() {
    local row=$1 pattern=$2 msg rc; shift 2
    msg=$(bounded "$@" 2>&1); rc=$?
    if [ $rc -eq 0 ] || [ $rc -gt 2 ]; then
        census "$row" "$([ $rc -eq 0 ] && echo false-success || echo crash)"
        echo "FAILED: [$row] exit $rc: $msg"; fails=$((fails + 1)); return 1
    fi
    if ! grep -qE -- "$pattern" <<<"$msg"; then
        census "$row" unclear-message; echo "FAILED: [$row] message lacks /$pattern/: $msg"
        fails=$((fails + 1)); return 1
    fi
    [ -n "${CENSUS_LATER:-}" ] || census "$row" clear-error
    echo "ok: [$row] $(head -1 <<<"$msg")"
}
# into_existing ROW PATTERN ARGS...: `dtx import sequence ARGS... -o e.h5
# --mesh /meshes/body` is rejected and e.h5 keeps its size, gains no
# sequence and still validates.
cp npy.h5 e.h5
into_existing() {
    local row=$1 pattern=$2 before; shift 2
    before=$(stat -c %s e.h5)
    CENSUS_LATER=1 reject "$row" "$pattern" "$DTX" import sequence "$@" -o e.h5 --mesh /meshes/body ||
        return
    if [ "$(stat -c %s e.h5)" != "$before" ] ||
       [ "$("$PY" -c 'import h5py; print(sorted(h5py.File("e.h5", "r")["/sequences"]))')" != "['rest', 'walk']" ] ||
       ! "$DTX" validate e.h5 > /dev/null 2>&1; then
        census "$row" leftovers; echo "FAILED: [$row] e.h5 changed by the failed import"
        fails=$((fails + 1))
    else
        census "$row" clear-error; echo "ok: [$row] e.h5 left as it was"
    fi
}
into_existing layout-npy-shape 'bad-shape\.npy: shape \(2, 86, 4\): expected \(frames, vertices, 3\) or \(vertices, 3\)' \
    bad-shape.npy --name s
into_existing layout-npy-dtype "bad-dtype\.npy: dtype '<i4': only float32 or float64 positions" \
    bad-dtype.npy --name s
into_existing layout-npy-truncated 'bad-truncated\.npy: 5153 data bytes, but 5 frames x 86 vertices x 3 float32 need 5160 \(truncated\)' \
    bad-truncated.npy --name s
into_existing layout-nv 'bad-nv\.npy: 80 vertices per frame but the rest mesh /meshes/body has 86' \
    bad-nv.npy --name s
into_existing layout-nv 'bad-nv\.pc2: 80 vertices per frame but the rest mesh /meshes/body has 86' \
    bad-nv.pc2 --name s
into_existing layout-nonfinite 'bad-nan\.npy: frame 1 \(0-based\), vertex 3 has a non-finite coordinate' \
    bad-nan.npy --name s
into_existing layout-mdd-truncated 'bad-truncated\.mdd: .* bytes, but 5 samples x 86 points need .* \(truncated\)' \
    bad-truncated.mdd --name s
into_existing layout-h5-dtype 'bad\.hdf5:/ints: expected floating-point positions, found integer values' \
    bad.hdf5 --dataset /ints --axes VCT --name s
into_existing layout-h5-axes 'bad\.hdf5:/walk: shape \(86 x 3 x 5\) with axis order TVC has 5 coordinates per vertex, not 3 \(is --axes right\?\)' \
    bad.hdf5 --dataset /walk --name s
into_existing layout-h5-axes 'axis order "VXT": use each of T \(frames\), V \(vertices\) and C' \
    bad.hdf5 --dataset /walk --axes VXT --name s
into_existing layout-h5-missing 'bad\.hdf5:/nowalk: no such dataset' \
    bad.hdf5 --dataset /nowalk --axes VCT --name s
into_existing layout-h5-faces-missing 'faces bad\.hdf5:/nofaces: no such dataset' \
    bad.hdf5 --dataset /walk --axes VCT --faces /nofaces --name s
into_existing layout-h5-faces-missing '--faces: missing\.h5: no such file or directory' \
    bad.hdf5 --dataset /walk --axes VCT --faces missing.h5:/faces --name s
into_existing layout-h5-faces-differ 'faces bad\.hdf5:/faces_other differ from the rest mesh /meshes/body' \
    bad.hdf5 --dataset /walk --axes VCT --faces /faces_other --name s
into_existing layout-h5-faces-range 'faces bad\.hdf5:/faces_range: face [0-9]+ \(0-based\): vertex index 86 out of range \[0, 86\)' \
    bad.hdf5 --dataset /walk --axes VCT --faces /faces_range --name s
# A wildcard meeting the integer faces (not named by --faces) writes none
# of the sequences, even those checked before.
into_existing layout-h5-wildcard "--dataset '/\\*' matched it .*bad\\.hdf5:/faces: expected floating-point positions" \
    bad.hdf5 --dataset '/*' --axes VCT
into_existing layout-exists 'e\.h5:/sequences/walk exists already \(dtx rm e\.h5 /sequences/walk removes it first\)' \
    walk.npy --name walk
reject layout-h5-mesh-faces 'a mesh from an HDF5 dataset needs --faces' \
    "$DTX" import mesh dfaust.hdf5 --dataset /walk --axes VCT -o new.h5 --name b
check "[layout-h5-mesh-faces] ... and no file written" test ! -e new.h5
reject layout-h5-mesh-faces 'faces dfaust\.hdf5:/walk: expected integer vertex indices' \
    "$DTX" import mesh dfaust.hdf5 --dataset /jump --axes VCT --faces /walk -o new.h5 --name b
check "[layout-h5-mesh-faces] ... and no file written" test ! -e new.h5
reject layout-usage '--axes and --faces go with --dataset' \
    "$DTX" import sequence walk.npy --axes VCT -o e.h5 --name s --mesh /meshes/body
reject layout-usage '--name goes with one sequence' \
    "$DTX" import sequence dfaust.hdf5 --dataset '/*' --axes VCT -o e.h5 --name s --mesh /meshes/body
reject layout-usage 'a \.npy, \.pc2 or \.mdd file is a whole sequence: import one at a time' \
    "$DTX" import sequence walk.npy walk.pc2 -o e.h5 --name s --mesh /meshes/body
finish
