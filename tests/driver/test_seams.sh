#!/usr/bin/env bash
# Seam-split targets (issue 17): the lion split the way a DCC/glTF export
# splits it (`dtx generate uvsplit`: a cylindrical UV seam, and two
# materials whose boundary cuts the lion into pieces) transfers as the
# welded lion: every output keeps the asset's vertex count and order, twins
# move together exactly and the positions equal the welded (= original)
# lion's transfer to 1e-12 of the diagonal.  sp04 no longer refuses the
# piecewise split; weld_tolerance -1 (no welding) shows the torn seam the
# weld prevents; multicomponent gives the same as on the welded lion.
set -euo pipefail
D="$DTX_BUILD/data/sumner-cat-lion"
W="$DTX_TESTDATA"
. "$DTX_SRC/tests/lib.sh"
cmp="$DTX_SRC/tests/driver/seam_compare.py"
cd "$W"

"$DTX" generate uvsplit "$D/target/lion-reference.obj" lion-uv.obj 2> gen.log
"$DTX" generate uvsplit "$D/target/lion-reference.obj" lion-seam.obj --materials 1 2>> gen.log
check "uvsplit: the two-material split duplicates seam and boundary vertices" \
    grep -Eq 'lion-uv.obj: 5[0-9]{3} vertices \([1-9][0-9]* at the UV seam, [1-9][0-9]* at the material boundary' gen.log
check "uvsplit: OBJ with vt, vn, usemtl and mtllib" bash -c \
    'grep -q "^vt " lion-uv.obj && grep -q "^vn " lion-uv.obj && grep -q "^usemtl dtx_upper" lion-uv.obj && grep -q "^mtllib lion-uv.mtl" lion-uv.obj && grep -q "^newmtl dtx_upper" lion-uv.mtl'

"$DTX" import mesh "$D/source/cat-reference.obj" -o in.h5 --name cat
mkdir -p poses
for k in 1 2 3; do ln -s "$D/source/cat-0$k.obj" "poses/cat-$k.obj"; done
"$DTX" import sequence poses -o in.h5 --name cat-poses --mesh /meshes/cat --dtype float64
"$DTX" import mesh "$D/target/lion-reference.obj" -o in.h5 --name lion
"$DTX" import mesh lion-seam.obj -o in.h5 --name lion-seam
"$DTX" import mesh lion-uv.obj -o in.h5 --name lion-uv

job() { # job NAME METHOD EXTRA-TARGET-KEYS
    cat > "$1.json" <<JOB
{"dtx_job": 1, "method": "$2",
 "source": {"file": "in.h5", "mesh": "/meshes/cat", "sequences": ["/sequences/cat-poses"]},
 "targets": [
  {"file": "in.h5", "mesh": "/meshes/lion", "markers": {"csv": "$D/markers.csv", "index_base": 0}},
  {"file": "in.h5", "mesh": "/meshes/lion-seam", "markers": {"csv": "$D/markers.csv", "index_base": 0}$3},
  {"file": "in.h5", "mesh": "/meshes/lion-uv", "markers": {"csv": "$D/markers.csv", "index_base": 0}}],
 "output": {"file": "$1.h5", "dtype": "float64", "export_obj_dir": "$1-obj"},
 "multicomponent": {"max_iter": 5}}
JOB
}
job sp04 sp04 ""
job mc multicomponent ""
"$DTX" run --quiet sp04.json
check "sp04 result validates" "$DTX" validate sp04.h5
for t in lion-seam lion-uv; do
    for k in 1 3; do
        check "sp04 $t frame $k: twins together, equal to the welded transfer" \
            python3 "$cmp" $t.obj sp04-obj/$t/cat-poses/$t-0000$k.obj sp04-obj/lion/cat-poses/lion-0000$k.obj
    done
done
check "the output's target mesh is the asset's (5116 vertices)" bash -c \
    "'$DTX' inspect sp04.h5 | grep -E 'lion-uv' | grep -q 5116"
check "import keeps uv, normals, materials and mtllib; the output's target mesh has them" bash -c \
    "for f in in.h5 sp04.h5; do h5dump -n \$f | grep -q '/meshes/lion-uv/uv_faces' && h5dump -n \$f | grep -q '/meshes/lion-uv/normal_faces' && h5dump -a /meshes/lion-uv/material/material_names \$f | grep -q dtx_upper && h5dump -a /meshes/lion-uv/mtllib \$f | grep -q lion-uv.mtl || exit 1; done"

# Exports keep the asset: `dtx export --obj-dir` and the job's own OBJ
# frames have the asset's vertex order, vt, usemtl groups, mtllib and
# per-frame normals (recomputed, area-weighted around each position), and
# positions equal to the HDF5 result.
oxc="$DTX_SRC/tests/driver/obj_export_compare.py"
"$DTX" export sp04.h5 /results/lion-uv/cat-poses --obj-dir sp04-exp 2> exp.log
for k in 1 3; do
    h5dump -d /results/lion-uv/cat-poses/positions -s "$((k - 1)),0,0" -c "1,5116,3" -b LE \
        -o f$k.bin sp04.h5 > /dev/null
    check "export --obj-dir frame $k: the asset's order, vt, usemtl, normals; positions = HDF5" \
        python3 "$oxc" lion-uv.obj sp04-exp/cat-poses-0000$k.obj f$k.bin
    check "the job's OBJ frame $k: the same" \
        python3 "$oxc" lion-uv.obj sp04-obj/lion-uv/cat-poses/lion-uv-0000$k.obj f$k.bin
done
"$DTX" export sp04.h5 /results/lion-uv/cat-poses --obj-rest sp04-rest.obj 2>> exp.log
h5dump -d /meshes/lion-uv/vertices -b LE -o rest-v.bin sp04.h5 > /dev/null
check "export --obj-rest: the asset with its vt, usemtl and own normals" \
    python3 "$oxc" lion-uv.obj sp04-rest.obj rest-v.bin --rest
check "a mesh without attributes exports without them" bash -c \
    "! grep -Eq '^(vt|vn|usemtl|mtllib) ' sp04-obj/lion/cat-poses/lion-00001.obj"

# The silent failure of the issue: without welding (weld_tolerance -1) the
# one-piece split is accepted with a warning and its seam tears open.
job torn sp04 ', "weld_tolerance": -1'
python3 - torn.json <<'PY'
import json, sys
j = json.load(open(sys.argv[1])); j["targets"] = j["targets"][:2]
json.dump(j, open(sys.argv[1], "w"))
PY
"$DTX" run torn.json 2> torn.log
check "no welding: the duplicates are reported" grep -q "at exactly the position of another vertex" torn.log
check "no welding: the seam tears (what welding prevents)" \
    python3 "$cmp" lion-seam.obj torn-obj/lion-seam/cat-poses/lion-seam-00003.obj torn-obj/lion/cat-poses/lion-00003.obj --expect-torn

"$DTX" run --quiet mc.json
for t in lion-seam lion-uv; do
    check "multicomponent $t frame 3: twins together, equal to the welded transfer" \
        python3 "$cmp" $t.obj mc-obj/$t/cat-poses/$t-00003.obj mc-obj/lion/cat-poses/lion-00003.obj
done
# A sequence stored in the asset's split order exports with the asset's
# attributes; at the rest shape the recomputed normals are the asset's vn.
mkdir -p restseq && cp lion-uv.obj restseq/lion-uv-rest.obj
"$DTX" import sequence restseq -o in.h5 --name lion-uv-rest --mesh /meshes/lion-uv --dtype float64 2> /dev/null
"$DTX" export in.h5 /sequences/lion-uv-rest --obj-dir rest-exp 2> /dev/null
h5dump -d /sequences/lion-uv-rest/positions -b LE -o rest.bin in.h5 > /dev/null
check "export of a split-order sequence at rest: its normals are the asset's vn" \
    python3 "$oxc" lion-uv.obj rest-exp/lion-uv-rest-00001.obj rest.bin --rest
finish
