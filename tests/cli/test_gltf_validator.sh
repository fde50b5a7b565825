#!/usr/bin/env bash
# The Khronos glTF validator (npm package gltf-validator, its validateBytes
# API) on .glb files `dtx export` writes: the cat -> lion result (9 frames,
# LINEAR), every 2nd frame with STEP, the 7207-vertex source sequence and a
# 68,121-vertex grid sequence (32-bit indices), and sequences of 2,500,
# 5,000 and 10,000 frames of a tetrahedron (the animation's weights are a
# sparse accessor, so the size grows linearly with the frames: the bytes
# per frame between 2,500 and 5,000 frames equal those between 5,000 and
# 10,000).  The lion split along a UV seam with two materials (dtx
# generate uvsplit, a checker PNG on one of them through map_Kd) and its
# result: TEXCOORD_0, the asset's normals, morph normals, two primitives,
# two materials and an embedded image; the same without its .mtl (a
# warning, materials without colour); and an OBJ whose UVs are per corner
# (vt indices unlike v indices), whose glb splits vertices and says so in
# extras.  Any error or warning fails; infos and hints are printed.  A
# copy with a broken accessor must be refused, so the check itself can
# fail.  Exits 77 (ctest: skipped) without node or the validator, except
# under CI=true, where that is a failure: scripts/setup.sh installs both
# (Debian's nodejs and npm, then the validator into build-tools/;
# DTX_GLTF_VALIDATOR_DIR overrides where to look).
set -uo pipefail
. "$DTX_SRC/tests/lib.sh"
D="$DTX_BUILD/data/sumner-cat-lion"
W="$DTX_TESTDATA"
VDIR=${DTX_GLTF_VALIDATOR_DIR:-$DTX_SRC/build-tools}
cd "$W" || exit 1
# skip WHY: exit 77 (skipped), or fail under CI, where scripts/setup.sh
# has installed everything this test needs.
skip() {
    if [ "${CI:-}" = true ]; then echo "FAILED (CI=true, so this is not skipped): $1"; exit 1; fi
    echo "skipped: $1"; exit 77
}
command -v node > /dev/null || skip "node is not installed (the glTF validator is a node package)"
[ -f "$VDIR/node_modules/gltf-validator/package.json" ] ||
    skip "gltf-validator not found in $VDIR/node_modules (scripts/setup.sh installs it with npm, or set DTX_GLTF_VALIDATOR_DIR)"

pass=0 fails=0
ok() { echo "ok: $1"; pass=$((pass + 1)); }
bad() { echo "FAILED: $1"; fails=$((fails + 1)); }

cat > validate.js <<'EOF'
// node validate.js VALIDATOR_DIR FILE.glb: prints the validator's counts and
// messages; exit 0 without errors and warnings, 1 with any, 2 if it could
// not run.
const fs = require('fs');
const validator = require(process.argv[2] + '/node_modules/gltf-validator');
const file = process.argv[3];
validator.validateBytes(new Uint8Array(fs.readFileSync(file)), {maxIssues: 100})
  .then((r) => {
    const i = r.issues;
    console.log(`${file}: ${i.numErrors} errors, ${i.numWarnings} warnings, ` +
                `${i.numInfos} infos, ${i.numHints} hints (gltf-validator ${validator.version()})`);
    for (const m of i.messages)
      console.log(`  [${['error', 'warning', 'info', 'hint'][m.severity]}] ${m.code}` +
                  ` at ${m.pointer || m.offset}: ${m.message}`);
    process.exit(i.numErrors > 0 || i.numWarnings > 0 ? 1 : 0);
  }, (e) => { console.log(`${file}: the validator failed: ${e}`); process.exit(2); });
EOF
# valid FILE: the validator finds no error and no warning.
valid() {
    local out rc
    out=$(node validate.js "$VDIR" "$1" 2>&1); rc=$?
    echo "$out"
    if [ $rc -eq 0 ]; then ok "$1 is valid glTF 2.0 (no warning)"; else bad "$1: validator exit $rc"; fi
}

# ---- the cat -> lion result
cat_lion_result || exit 1
R=/results/lion/cat-poses
"$DTX" export out.h5 $R --glb lion.glb && valid lion.glb
"$DTX" export out.h5 $R --glb lion-step.glb --stride 2 --step --fps 30 && valid lion-step.glb
"$DTX" export cl.h5 /sequences/cat-poses --glb cat.glb && valid cat.glb

# ---- the asset: the uvsplit lion, two materials, a texture on one
mkdir -p asset
"$DTX" generate uvsplit "$D/target/lion-reference.obj" asset/lion-uv.obj 2>/dev/null
python3 "$DTX_SRC/scripts/uv-checker.py" asset/checker.png 64 8
sed -i '/^newmtl dtx_lower/a map_Kd checker.png' asset/lion-uv.mtl
"$DTX" import mesh asset/lion-uv.obj -o cl.h5 --name lion-uv 2>/dev/null
sed 's#"/meshes/lion"#"/meshes/lion-uv"#; s#"out.h5"#"out-uv.h5"#' job.json > job-uv.json
"$DTX" run --quiet job-uv.json || { echo "FAILED: the uvsplit job did not run"; exit 1; }
"$DTX" export out-uv.h5 $R --glb lion-uv.glb 2> export-uv.log && valid lion-uv.glb
# What the validator saw is what was asked for (the JSON chunk, read by node).
if node -e '
    const b = require("fs").readFileSync(process.argv[1]);
    const j = JSON.parse(b.slice(20, 20 + b.readUInt32LE(12)).toString());
    const p = j.meshes[0].primitives, m = j.materials || [];
    const c = (m[1] || {}).pbrMetallicRoughness || {};
    const kd = [0.2, 0.5, 0.8, 1], f = c.baseColorFactor || [];
    const ok = p.length === 2 && p.every((q) => "TEXCOORD_0" in q.attributes &&
        "NORMAL" in q.attributes && q.targets.every((t) => "NORMAL" in t)) &&
        m.length === 2 && m[0].name === "dtx_lower" && m[1].name === "dtx_upper" &&
        m[0].pbrMetallicRoughness.baseColorTexture !== undefined &&
        (j.images || []).length === 1 && j.images[0].mimeType === "image/png" &&
        f.length === 4 && f.every((x, i) => Math.abs(x - kd[i]) < 1e-6);
    console.log("  " + p.length + " primitives, materials " + m.map((x) => x.name).join(", ") +
                ", " + (j.images || []).length + " image(s)");
    process.exit(ok ? 0 : 1);' lion-uv.glb; then
    ok "lion-uv.glb: two primitives with TEXCOORD_0, NORMAL and morph normals, the .mtl's materials, the PNG embedded"
else
    bad "lion-uv.glb: primitives, materials or image not as asked"; cat export-uv.log
fi

# Without its .mtl the export still works, with a warning naming what is
# missing, and materials without colour.
mv asset/lion-uv.mtl asset/lion-uv.mtl.away
if "$DTX" export out-uv.h5 $R --glb lion-nomtl.glb 2> nomtl.log &&
    grep -q "warning: lion-nomtl.glb: material library lion-uv.mtl not found beside .*asset/lion-uv.obj" nomtl.log &&
    ! grep -q baseColor <(head -c 400000 lion-nomtl.glb | tr -d '\0'); then
    ok "no .mtl beside the asset: a warning naming it, materials without colour"
    valid lion-nomtl.glb
else
    bad "no .mtl beside the asset: $(cat nomtl.log)"
fi
mv asset/lion-uv.mtl.away asset/lion-uv.mtl

# ---- per-corner UVs: a quad of two triangles whose shared edge has
# different UVs on its two sides, so two vertices get copies
cat > corner.obj <<'EOF2'
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
vt 0 0
vt 1 0
vt 1 1
vt 0 1
vt 0.5 0.5
vt 0.25 0.75
f 1/1 2/2 3/3
f 1/5 3/6 4/4
EOF2
"$DTX" import mesh corner.obj -o corner.h5 --name q 2>/dev/null
awk '/^v / { $4 = 0.5 } { print }' corner.obj > corner-up.obj
"$DTX" import sequence corner.obj corner-up.obj -o corner.h5 --name up --mesh /meshes/q 2>/dev/null
"$DTX" export corner.h5 /sequences/up --glb corner.glb && valid corner.glb
if grep -q '"dtx_vertex_copies":{"vertices":4,"copy_of":\[0,2\]}' <(head -c 4096 corner.glb | tr -d '\0'); then
    ok "corner.glb: vertices 0 and 2 are split, and extras say which glTF vertex copies which"
else
    bad "corner.glb: no dtx_vertex_copies [0,2] in its JSON"
fi

# ---- a grid of 261 x 261 vertices: more than 65535, so 32-bit indices
awk -v n=261 'BEGIN {
    for (j = 0; j < n; j++) for (i = 0; i < n; i++) printf "v %g %g 0\n", i / n, j / n
    for (j = 0; j < n - 1; j++) for (i = 0; i < n - 1; i++) {
        a = j * n + i + 1; printf "f %d %d %d\nf %d %d %d\n", a, a + 1, a + n + 1, a, a + n + 1, a + n
    } }' /dev/null > grid.obj
awk '/^v / { printf "v %s %s %g\n", $2, $3, 0.1 * sin(6 * $2) * cos(4 * $3); next } { print }' \
    grid.obj > grid-bent.obj
"$DTX" import mesh grid.obj -o grid.h5 --name grid 2>/dev/null
"$DTX" import sequence grid.obj grid-bent.obj -o grid.h5 --name bend --mesh /meshes/grid 2>/dev/null
"$DTX" export grid.h5 /sequences/bend --glb grid.glb && valid grid.glb
if grep -q '"componentType":5125' <(head -c 4096 grid.glb | tr -d '\0'); then
    ok "grid.glb has 32-bit indices"
else
    bad "grid.glb: no UNSIGNED_INT (5125) indices"
fi

# ---- long animations: a tetrahedron sliding along x, 10,000 frames
# (frame files written by one awk), exported whole and as its first 2,500
# and 5,000 frames; the size must be linear in the frames.
mkdir -p tet
awk 'BEGIN { for (k = 1; k <= 10000; k++) {
    f = sprintf("tet/f%05d.obj", k)
    printf "v %.4f 0 0\nv %.4f 0 0\nv %.4f 1 0\nv %.4f 0 1\n", k / 1000, 1 + k / 1000, k / 1000, k / 1000 > f
    print "f 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4" > f; close(f) } }' /dev/null
cp tet/f00001.obj tet.obj
"$DTX" import mesh tet.obj -o tet.h5 --name tet 2>/dev/null
"$DTX" import sequence tet -o tet.h5 --name slide --mesh /meshes/tet 2>/dev/null
"$DTX" export tet.h5 /sequences/slide --glb tet10000.glb && valid tet10000.glb
for n in 2500 5000; do
    "$DTX" import sequence $(ls tet/*.obj | head -n $n) -o tet.h5 --name s$n --mesh /meshes/tet 2>/dev/null
    "$DTX" export tet.h5 /sequences/s$n --glb tet$n.glb 2>/dev/null
done
s1=$(stat -c %s tet2500.glb) s2=$(stat -c %s tet5000.glb) s3=$(stat -c %s tet10000.glb)
# Bytes per frame on each interval; they agree to 1% (JSON numbers vary
# in length); N x N weights would add 4 N bytes a frame (40 KB at 10,000).
if awk -v a="$s1" -v b="$s2" -v c="$s3" 'BEGIN {
        p = (b - a) / 2500; q = (c - b) / 5000
        printf "  sizes %d, %d, %d bytes: %.1f and %.1f bytes per frame\n", a, b, c, p, q
        exit !(p > 0 && q > 0 && (p - q) / q < 0.01 && (q - p) / q < 0.01) }'; then
    ok "the .glb size is linear in the frames (2,500 / 5,000 / 10,000 frames)"
else
    bad "the .glb size is not linear in the frames"
fi

# ---- the check can fail: a copy whose POSITION accessor overruns its view
perl -0777 -pe 's/"count":5000,/"count":9000,/' lion.glb > broken.glb
if node validate.js "$VDIR" broken.glb > broken.log 2>&1; then
    bad "the validator accepted a broken file"; cat broken.log
elif grep -q "ACCESSOR_TOO_LONG" broken.log; then
    ok "an accessor longer than its view is an error: $(head -n 1 broken.log)"
else
    bad "broken.glb: unexpected validator output"; cat broken.log
fi

echo "$pass passed, $fails failed"
[ "$fails" -eq 0 ]
