#!/usr/bin/env bash
# glTF 2.0 rest meshes through assimp (issue 17): the split lion (`dtx
# generate uvsplit`: UV seam, two materials) written as a glb the way a DCC
# exports it (a primitive per material, each with its own vertices; written
# by tests/cli/make_glb.py with python3's struct and json) imports with the
# same vertices in the same order, the same faces, UVs, normals and
# materials as the OBJ of the same asset, and transfers to exactly the same
# result.  A truncated glb is refused with a message and nothing written.
set -euo pipefail
D="$DTX_BUILD/data/sumner-cat-lion"
W="$DTX_TESTDATA"
. "$DTX_SRC/tests/lib.sh"
cd "$W"

"$DTX" generate uvsplit "$D/target/lion-reference.obj" lion-uv.obj 2> /dev/null
python3 "$DTX_SRC/tests/cli/make_glb.py" lion-uv.obj lion.glb lion-glb.obj \
    "$D/markers.csv" markers-glb.csv
"$DTX" import mesh lion-glb.obj -o in.h5 --name obj 2> /dev/null
"$DTX" import mesh lion.glb -o in.h5 --name glb 2> glb.log
check "the glb's two primitives are concatenated, with a warning" \
    grep -q "lion.glb: 2 meshes in the scene, concatenated" glb.log
check "glb import: 5116 vertices like the OBJ" bash -c \
    "'$DTX' inspect in.h5 | grep -E '/meshes/glb' | grep -q 5116"
# h5diff exits 0 on datasets of different shapes ("not comparable"): that
# is a failure here.
same() { # same FILE1 FILE2 PATH1 PATH2
    local out
    out=$(h5diff -c "$@" 2>&1) && ! grep -qi "not comparable" <<< "$out"
}
for d in vertices faces uv uv_faces normals normal_faces material; do
    check "glb import: $d equal to the OBJ import's" same in.h5 in.h5 /meshes/obj/$d /meshes/glb/$d
done
h5dump -a /meshes/glb/material/material_names in.h5 > names.txt
check "glb import: the material names, in order" bash -c \
    "grep -q '\"dtx_lower\$' names.txt && grep -q '^ *dtx_upper\"' names.txt"
check "the file validates" "$DTX" validate in.h5

# The same transfer onto both.
"$DTX" import mesh "$D/source/cat-reference.obj" -o in.h5 --name cat 2> /dev/null
mkdir -p poses
for k in 1 2; do ln -s "$D/source/cat-0$k.obj" "poses/cat-$k.obj"; done
"$DTX" import sequence poses -o in.h5 --name cat-poses --mesh /meshes/cat --dtype float64 2> /dev/null
cat > job.json <<JOB
{"dtx_job": 1, "method": "sp04",
 "source": {"file": "in.h5", "mesh": "/meshes/cat", "sequences": ["/sequences/cat-poses"]},
 "targets": [
  {"file": "in.h5", "mesh": "/meshes/obj", "markers": {"csv": "markers-glb.csv", "index_base": 0}},
  {"file": "in.h5", "mesh": "/meshes/glb", "markers": {"csv": "markers-glb.csv", "index_base": 0}}],
 "output": {"file": "out.h5", "dtype": "float64"}}
JOB
"$DTX" run --quiet job.json
check "the glb asset's transfer equals the OBJ asset's exactly" \
    same out.h5 out.h5 /results/obj/cat-poses/positions /results/glb/cat-poses/positions
check "the output keeps the glb's UVs" \
    same out.h5 in.h5 /meshes/glb/uv /meshes/glb/uv

# Bad input: a truncated glb.
head -c 5000 lion.glb > cut.glb
check_fails_clean() {
    if "$DTX" import mesh cut.glb -o bad.h5 --name cut 2> cut.log; then return 1; fi
    grep -q "cut.glb" cut.log && [ ! -e bad.h5 ]
}
check "a truncated glb is refused with its name, nothing written" check_fails_clean
# FBX: assimp's own exporter (assimp-utils, when installed) writes the glb
# as ASCII FBX (its binary FBX is not read back by assimp 5.2); assimp's
# FBX importer gives one vertex per face corner, so the import is compared
# corner by corner: same faces and materials, positions, UVs and normals to
# the 6 digits ASCII FBX keeps (1e-6 here: the lion's coordinates are < 1).
if command -v assimp > /dev/null; then
    assimp export lion.glb lion.fbx -ffbxa > /dev/null
    "$DTX" import mesh lion.fbx -o in.h5 --name fbx 2> /dev/null
    for m in glb fbx; do
        for d in vertices faces uv normals material; do
            h5dump -d /meshes/$m/$d -b LE -o $m-$d.bin in.h5 > /dev/null
        done
    done
    check "fbx import: every face corner as in the glb import" \
        python3 "$DTX_SRC/tests/cli/corner_compare.py" . glb fbx 1e-6
    # Its transfer (welded: 29988 corners -> 5116 positions; markers on the
    # first corner of each glb vertex) equals the glb's at every corner to
    # 1e-9 (the solve sees another vertex numbering, so rounding differs).
    python3 "$DTX_SRC/tests/cli/corner_compare.py" --markers glb-faces.bin markers-glb.csv \
        markers-fbx.csv
    sed 's|/meshes/obj"|/meshes/fbx"|; s|markers-glb.csv", "index_base": 0}},|markers-fbx.csv", "index_base": 0}},|; s|out.h5|fbx.h5|' \
        job.json > fbx.json
    "$DTX" run --quiet fbx.json
    h5dump -d /results/glb/cat-poses/positions -b LE -o rglb-vertices.bin out.h5 > /dev/null
    h5dump -d /results/fbx/cat-poses/positions -b LE -o rfbx-vertices.bin fbx.h5 > /dev/null
    check "fbx: the transfer equals the glb's at every face corner (1e-9)" \
        python3 "$DTX_SRC/tests/cli/corner_compare.py" --frames 2 . glb fbx 1e-9
else
    echo "note: no assimp CLI (assimp-utils): the FBX part is skipped"
fi
finish
