#!/usr/bin/env bash
# The Khronos glTF validator (npm package gltf-validator, its validateBytes
# API) on .glb files `dtx export` writes: the cat -> lion result (9 frames,
# LINEAR), every 2nd frame with STEP, the 7207-vertex source sequence and a
# 68,121-vertex grid sequence (32-bit indices).  Any error (severity 0)
# fails; warnings, infos and hints are printed.  A copy with a broken
# accessor must be refused, so the check itself can fail.
# Exits 77 (ctest: skipped) without node or the validator;
# scripts/setup.sh installs it into build-tools/ when npm is present
# (DTX_GLTF_VALIDATOR_DIR overrides where to look).
set -uo pipefail
D="$DTX_BUILD/data/sumner-cat-lion"
W="$DTX_TESTDATA"
VDIR=${DTX_GLTF_VALIDATOR_DIR:-$DTX_SRC/build-tools}
cd "$W" || exit 1
if ! command -v node > /dev/null; then
    echo "skipped: node is not installed (the glTF validator is a node package)"
    exit 77
fi
if [ ! -f "$VDIR/node_modules/gltf-validator/package.json" ]; then
    echo "skipped: gltf-validator not found in $VDIR/node_modules (scripts/setup.sh installs it" \
        "with npm, or set DTX_GLTF_VALIDATOR_DIR)"
    exit 77
fi
pass=0 fails=0
ok() { echo "ok: $1"; pass=$((pass + 1)); }
bad() { echo "FAILED: $1"; fails=$((fails + 1)); }

cat > validate.js <<'EOF'
// node validate.js VALIDATOR_DIR FILE.glb: prints the validator's counts and
// messages; exit 0 without errors, 1 with errors, 2 if it could not run.
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
    process.exit(i.numErrors > 0 ? 1 : 0);
  }, (e) => { console.log(`${file}: the validator failed: ${e}`); process.exit(2); });
EOF
# valid FILE: the validator finds no error.
valid() {
    local out rc
    out=$(node validate.js "$VDIR" "$1" 2>&1); rc=$?
    echo "$out"
    if [ $rc -eq 0 ]; then ok "$1 is valid glTF 2.0"; else bad "$1: validator exit $rc"; fi
}

# ---- the cat -> lion result
"$DTX" import mesh "$D/source/cat-reference.obj" -o cl.h5 --name cat 2>/dev/null
"$DTX" import mesh "$D/target/lion-reference.obj" -o cl.h5 --name lion 2>/dev/null
mkdir -p poses
for k in 1 2 3 4 5 6 7 8 9; do ln -sf "$D/source/cat-0$k.obj" "poses/cat-$k.obj"; done
"$DTX" import sequence poses -o cl.h5 --name cat-poses --mesh /meshes/cat 2>/dev/null
"$DTX" import markers "$D/markers.csv" --index-base 0 -o cl.h5 --name cat-lion \
    --source /meshes/cat --target /meshes/lion 2>/dev/null
cat > job.json <<'JOB'
{"dtx_job": 1, "method": "sp04",
 "source": {"file": "cl.h5", "mesh": "/meshes/cat", "sequences": ["/sequences/cat-poses"]},
 "targets": [{"name": "lion", "file": "cl.h5", "mesh": "/meshes/lion",
              "markers": {"file": "cl.h5", "path": "/markers/cat-lion"}}],
 "output": {"file": "out.h5"}}
JOB
"$DTX" run --quiet job.json || { echo "FAILED: the job did not run"; exit 1; }
R=/results/lion/cat-poses
"$DTX" export out.h5 $R --glb lion.glb && valid lion.glb
"$DTX" export out.h5 $R --glb lion-step.glb --stride 2 --step --fps 30 && valid lion-step.glb
"$DTX" export cl.h5 /sequences/cat-poses --glb cat.glb && valid cat.glb

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
