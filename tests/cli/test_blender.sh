#!/usr/bin/env bash
# Blender as the client of `dtx export`: Debian's Blender 3.4, headless,
# runs tests/cli/blender_check.py, which performs the README's "Using
# results in Blender" steps on a 9-frame cat -> lion result (5,000
# vertices) exported as rest OBJ, glb (stored at 30 fps), PC2 and MDD, and
# compares what Blender shows with the HDF5 frames by vertex index, within
# float32 precision.  Then the asset's attributes: the lion split along a
# UV seam with two materials (dtx generate uvsplit; a checker texture on
# one of them, map_Kd in its .mtl) transferred the same way and exported as
# glb: Blender's UV layer, materials, base colours and packed image must be
# the OBJ's and the .mtl's.  Exits 77 (skipped) without blender, except under
# CI=true, where that is a failure (scripts/setup.sh installs it).
set -uo pipefail
. "$DTX_SRC/tests/lib.sh"
D="$DTX_BUILD/data/sumner-cat-lion"
cd "$DTX_TESTDATA" || exit 1
if ! command -v blender > /dev/null; then
    if [ "${CI:-}" = true ]; then echo "FAILED (CI=true, so this is not skipped): blender is not installed"; exit 1; fi
    echo "skipped: blender is not installed (Debian: apt-get install blender; scripts/setup.sh does)"
    exit 77
fi

# ---- a 9-frame result, made as in test_gltf_validator.sh
cat_lion_result || exit 1
R=/results/lion/cat-poses
rm -rf frames
check "export rest OBJ, glb, PC2, MDD and the frames as OBJ" \
    "$DTX" export out.h5 $R --obj-rest lion-rest.obj --glb lion.glb --pc2 lion.pc2 \
    --mdd lion.mdd --obj-dir frames --fps 30

# ---- the asset: uvsplit lion with a texture on material dtx_lower
mkdir -p asset
"$DTX" generate uvsplit "$D/target/lion-reference.obj" asset/lion-uv.obj 2>/dev/null
python3 "$DTX_SRC/scripts/uv-checker.py" asset/checker.png 64 8
sed -i '/^newmtl dtx_lower/a map_Kd checker.png' asset/lion-uv.mtl
"$DTX" import mesh asset/lion-uv.obj -o cl.h5 --name lion-uv 2>/dev/null
sed 's#"/meshes/lion"#"/meshes/lion-uv"#; s#"out.h5"#"out-uv.h5"#' job.json > job-uv.json
"$DTX" run --quiet job-uv.json || { echo "FAILED: the uvsplit job did not run"; exit 1; }
check "export the uvsplit lion's result as glb with its UVs, materials and texture" \
    "$DTX" export out-uv.h5 $R --glb lion-uv.glb
rm -rf uvframes
check "export the uvsplit lion's result as OBJ frames with vt, vn, usemtl and mtllib" \
    "$DTX" export out-uv.h5 $R --obj-dir uvframes
cp asset/lion-uv.mtl asset/checker.png uvframes/ 2>/dev/null

# ---- Blender (its own messages go to blender.log; the checks are printed)
blender -b --factory-startup --python-exit-code 1 --python "$DTX_SRC/tests/cli/blender_check.py" \
    -- 30 frames lion-rest.obj lion.glb lion.pc2 lion.mdd lion-uv.glb asset/lion-uv.obj \
    uvframes/cat-poses-00005.obj \
    > blender.log 2>&1
rc=$?
grep -E '^(ok|FAILED|blender_check):' blender.log
check "Blender 3.4 plays the OBJ, glb, PC2 and MDD as the HDF5 result and reads the glb's and the OBJ's UVs, materials and texture (exit $rc)" \
    test "$rc" -eq 0 -a "$(grep -c '^ok:' blender.log)" -eq 23
[ "$rc" -eq 0 ] || tail -n 30 blender.log
finish
