#!/usr/bin/env bash
# The h5py example of schemas/hdf5-layout-v1.md ("Reading a result with
# h5py"), extracted from the document and run with python3 against a real
# result (the 9-frame cat -> lion, at out/cat-lion.h5 as the example
# expects), so the document cannot go stale: it must run, print the
# result's method, shapes, source and frame rate, and write frame 0 equal to
# `dtx export --obj-dir`'s.  Also the frame rate's path: `import sequence
# --fps 30` stores it, `dtx run` copies it to the result, inspect and export
# use it, validate accepts it, and a file without it (older files) too.
# Needs Debian's python3 with h5py and numpy: skipped without them, a failure under
# CI=true (scripts/setup.sh installs them).
set -uo pipefail
. "$DTX_SRC/tests/lib.sh"
D="$DTX_BUILD/data/sumner-cat-lion"
PY=/usr/bin/python3 # Debian's, with python3-h5py (a pyenv python3 on PATH may lack it)
cd "$DTX_TESTDATA" || exit 1
if ! "$PY" -c 'import h5py, numpy' 2> /dev/null; then
    if [ "${CI:-}" = true ]; then echo "FAILED (CI=true, so this is not skipped): python3 h5py/numpy missing"; exit 1; fi
    echo "skipped: python3 h5py and numpy are needed (Debian: python3-h5py)"; exit 77
fi

"$DTX" import mesh "$D/source/cat-reference.obj" -o cl.h5 --name cat 2>/dev/null
"$DTX" import mesh "$D/target/lion-reference.obj" -o cl.h5 --name lion 2>/dev/null
mkdir -p poses out
for k in 1 2 3 4 5 6 7 8 9; do ln -sf "$D/source/cat-0$k.obj" "poses/cat-$k.obj"; done
"$DTX" import sequence poses -o cl.h5 --name cat-poses --mesh /meshes/cat --fps 30 2>/dev/null
"$DTX" import sequence poses -o cl.h5 --name no-fps --mesh /meshes/cat 2>/dev/null
"$DTX" import markers "$D/markers.csv" --index-base 0 -o cl.h5 --name cat-lion \
    --source /meshes/cat --target /meshes/lion 2>/dev/null
cat > job.json <<'JOB'
{"dtx_job": 1, "method": "sp04",
 "source": {"file": "cl.h5", "mesh": "/meshes/cat", "sequences": ["/sequences/cat-poses"]},
 "targets": [{"name": "lion", "file": "cl.h5", "mesh": "/meshes/lion",
              "markers": {"file": "cl.h5", "path": "/markers/cat-lion"}}],
 "output": {"file": "out/cat-lion.h5"}}
JOB
"$DTX" run --quiet job.json || { echo "FAILED: the job did not run"; exit 1; }

# ---- the document's example
awk '/^## Reading a result with h5py/ { s = 1 } s && /^```python$/ { c = 1; next }
     c && /^```$/ { exit } c { print }' "$DTX_SRC/schemas/hdf5-layout-v1.md" > example.py
check "the example was found in the document ($(wc -l < example.py) lines)" \
    grep -q 'h5py.File("out/cat-lion.h5"' example.py
out=$("$PY" example.py 2>&1); rc=$?
echo "$out"
check "the example runs (exit $rc)" test "$rc" -eq 0
check "  ... and prints method, shapes, source and 30 fps" \
    grep -qxE "sp04 \(9, 5000, 3\) \(9996, 3\) \S*cl\.h5:/sequences/cat-poses 30\.0" <<<"$out"
"$DTX" export out/cat-lion.h5 /results/lion/cat-poses --obj-dir frames 2>/dev/null
check "  ... and its frame0.obj has the positions of dtx export's first frame" "$PY" - <<'PY'
import numpy as np
a = np.array([l.split()[1:4] for l in open("frame0.obj") if l.startswith("v ")], float)
b = np.array([l.split()[1:4] for l in open("frames/cat-poses-00001.obj") if l.startswith("v ")], float)
raise SystemExit(not (a.shape == b.shape == (5000, 3) and np.abs(a - b).max() <= 1e-6 * np.abs(b).max()))
PY

# ---- the frame rate from import to export
check "inspect: the result has the sequence's 30 fps" \
    grep -qE '^ +fps +30$' <("$DTX" inspect out/cat-lion.h5)
check "inspect: a sequence without fps says 24 is assumed" \
    grep -qE '^ +fps +24 \(none stored' <("$DTX" inspect cl.h5)
msg=$("$DTX" export out/cat-lion.h5 /results/lion/cat-poses --mdd a.mdd 2>&1)
check "export uses the stored rate: $(head -n 1 <<<"$msg")" grep -q '30 frames per second (stored' <<<"$msg"
check "  ... MDD times 0, 1/30 s" "$PY" -c "
import struct; b = open('a.mdd', 'rb').read(); t = struct.unpack('>2f', b[8:16])
raise SystemExit(not (t[0] == 0.0 and t[1] == struct.unpack('f', struct.pack('f', 1 / 30))[0]))"
quiet() { "$@" > /dev/null; }
check "validate accepts files with fps" quiet "$DTX" validate out/cat-lion.h5
check "  ... and without (cl.h5:/sequences/no-fps)" quiet "$DTX" validate cl.h5
msg=$("$DTX" import sequence poses -o cl.h5 --name bad --mesh /meshes/cat --fps 0 2>&1); rc=$?
check "import --fps 0 is a usage error (exit $rc)" test "$rc" -eq 2
finish
