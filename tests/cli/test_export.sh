#!/usr/bin/env bash
# `dtx export` on the bundled cat -> lion data (a 9-frame result, made as in
# test_pipeline.sh) and on its source sequence: PC2 (header fields, size,
# samples equal to the OBJ frames and, with h5py, bitwise equal to the
# stored float32 result), the rest OBJ, the .glb container and its JSON
# (targets, frame names, times, interpolation), --stride and --fps; and bad
# inputs (missing path, wrong kind of object, a group of results, an
# incomplete result, unwritable or directory outputs, bad options, too many
# frames for a .glb) rejected with exit status 1 (error) or 2 (usage), a
# message naming the problem, no output and no temporary file left behind,
# and an existing output untouched.  The Khronos validator runs in
# test_gltf_validator.sh.
set -uo pipefail
. "$DTX_SRC/tests/lib.sh"
D="$DTX_BUILD/data/sumner-cat-lion"
W="$DTX_TESTDATA"
PY=/usr/bin/python3
cd "$W" || exit 1
pass=0 fails=0
ok() { echo "ok: $1"; pass=$((pass + 1)); }
bad() { echo "FAILED: $1"; fails=$((fails + 1)); }
check() { # check DESCRIPTION COMMAND...
    local what=$1; shift
    if "$@"; then ok "$what"; else bad "$what"; fi
}
# reject STATUS PATTERN OUTPUT COMMAND...: exits with STATUS, the message
# matches PATTERN, OUTPUT is absent afterwards (or unchanged when it
# existed), and no temporary file is left in the output's directory.
reject() {
    local want=$1 pattern=$2 out=$3 msg rc before="" after=""; shift 3
    [ -e "$out" ] && before=$(cksum < "$out")
    msg=$("$@" 2>&1); rc=$?
    [ -e "$out" ] && after=$(cksum < "$out")
    if [ "$rc" -ne "$want" ]; then bad "exit $rc (want $want): $*: $msg"; return; fi
    if ! grep -qE -- "$pattern" <<<"$msg"; then bad "message lacks /$pattern/: $msg"; return; fi
    if [ "$before" != "$after" ]; then bad "$out was changed or left behind: $*"; return; fi
    if compgen -G "$(dirname "$out")/.*.tmp-*" > /dev/null; then bad "temporary file left: $*"; return; fi
    ok "rejected ($rc): $(head -n 1 <<<"$msg")"
}
# hex32 FILE OFFSET: the little-endian 32-bit word at OFFSET, as 8 hex digits.
hex32() { od -An -tx4 -j "$2" -N4 "$1" | tr -d ' \n'; }

# ---- a 9-frame result: the cat poses onto the lion
cat_lion_result || exit 1
R=/results/lion/cat-poses

# ---- everything at once
check "export PC2, rest OBJ, glb and OBJ frames" \
    "$DTX" export out.h5 $R --pc2 lion.pc2 --obj-rest lion.obj --glb lion.glb --obj-dir frames

# PC2: "POINTCACHE2\0", version 1, 5000 points, start 0.0, rate 1.0, 9 samples
check "PC2 signature" test "$(head -c 12 lion.pc2 | od -An -c | tr -d ' \n')" = 'POINTCACHE2\0'
check "PC2 version 1" test "$(hex32 lion.pc2 12)" = 00000001
check "PC2 5000 points" test "$((16#$(hex32 lion.pc2 16)))" -eq 5000
check "PC2 start frame 0.0" test "$(hex32 lion.pc2 20)" = 00000000
check "PC2 sample rate 1.0" test "$(hex32 lion.pc2 24)" = 3f800000
check "PC2 9 samples" test "$((16#$(hex32 lion.pc2 28)))" -eq 9
check "PC2 size 32 + 12 x 5000 x 9" test "$(stat -c %s lion.pc2)" -eq $((32 + 12 * 5000 * 9))
# Each sample equals the OBJ frame of the same number, to float32.
check "PC2 samples = OBJ frames 1, 4, 9" "$PY" - lion.pc2 frames/cat-poses-00001.obj \
    frames/cat-poses-00004.obj frames/cat-poses-00009.obj <<'EOF'
import struct, sys
data = open(sys.argv[1], "rb").read()
n = struct.unpack_from("<i", data, 16)[0]
for path, s in zip(sys.argv[2:], (0, 3, 8)):
    v = [tuple(map(float, l.split()[1:4])) for l in open(path) if l.startswith("v ")]
    assert len(v) == n, (path, len(v), n)
    got = struct.unpack_from("<%df" % (3 * n), data, 32 + 12 * n * s)
    want = struct.unpack("<%df" % (3 * n), struct.pack("<%df" % (3 * n), *sum(v, ())))
    assert got == want, (path, [i for i in range(3 * n) if got[i] != want[i]][:3])
EOF
if "$PY" -c 'import h5py' 2> /dev/null; then
    check "PC2 bitwise equal to the stored float32 result" "$PY" - lion.pc2 out.h5 $R <<'EOF'
import sys, h5py, numpy as np
X = h5py.File(sys.argv[2], "r")[sys.argv[3] + "/positions"][...]
P = np.fromfile(sys.argv[1], dtype="<f4", offset=32).reshape(X.shape)
assert X.dtype == np.float32 and np.array_equal(P.view("<u4"), X.astype("<f4").view("<u4"))
EOF
else
    echo "note: no h5py; the PC2 - HDF5 comparison is not run"
fi
check "rest OBJ: 5000 vertices, 9996 faces" \
    test "$(grep -c '^v ' lion.obj) $(grep -c '^f ' lion.obj)" = "5000 9996"
check "9 OBJ frames" test "$(ls frames | wc -l)" -eq 9

# glb: "glTF", version 2, length = file size; JSON: 9 targets, names, times
check "glb magic" test "$(head -c 4 lion.glb)" = glTF
check "glb version 2" test "$(hex32 lion.glb 4)" = 00000002
check "glb length = file size" test "$((16#$(hex32 lion.glb 8)))" -eq "$(stat -c %s lion.glb)"
# glb_json FILE PYTHON-EXPRESSION: evaluates the expression with j = the JSON chunk.
glb_json() {
    "$PY" - "$1" "$2" <<'EOF'
import json, struct, sys
b = open(sys.argv[1], "rb").read()
n, kind = struct.unpack_from("<II", b, 12)
assert kind == 0x4E4F534A and n % 4 == 0
j = json.loads(b[20:20 + n])
assert eval("(" + sys.argv[2] + ")"), sys.argv[2]
EOF
}
check "glb: 9 morph targets, LINEAR, 24 fps" glb_json lion.glb \
    'len(j["meshes"][0]["primitives"][0]["targets"]) == 9 and
     j["animations"][0]["samplers"][0]["interpolation"] == "LINEAR" and
     abs(j["accessors"][-2]["max"][0] - 8 / 24) < 1e-6 and j["accessors"][-1]["count"] == 81 and
     j["meshes"][0]["extras"]["targetNames"][8] == "frame-00009" and
     j["accessors"][0]["count"] == 5000'

# ---- --stride, --fps, --step, --start-frame; re-export replaces the files
check "export every 4th frame" "$DTX" export out.h5 $R --pc2 lion.pc2 --glb lion.glb \
    --obj-dir strided --stride 4 --fps 12 --step --start-frame 0
check "stride: PC2 3 samples, rate 4.0, start 0" test \
    "$((16#$(hex32 lion.pc2 28))) $(hex32 lion.pc2 24) $(hex32 lion.pc2 20)" = "3 40800000 00000000"
check "stride: PC2 size" test "$(stat -c %s lion.pc2)" -eq $((32 + 12 * 5000 * 3))
check "stride: OBJ frames 1, 5, 9" test "$(ls strided | tr '\n' ' ')" = \
    "cat-poses-00001.obj cat-poses-00005.obj cat-poses-00009.obj "
check "stride: glb names, STEP, times 0, 1/3, 2/3 s" glb_json lion.glb \
    'j["meshes"][0]["extras"]["targetNames"] == ["frame-00001", "frame-00005", "frame-00009"]
     and j["animations"][0]["samplers"][0]["interpolation"] == "STEP" and
     abs(j["accessors"][-2]["max"][0] - 8 / 12) < 1e-6 and j["accessors"][-1]["count"] == 9'

# ---- a sequence exports too (its rest mesh is the cat)
check "export a sequence" "$DTX" export cl.h5 /sequences/cat-poses --pc2 cat.pc2 --glb cat.glb
check "sequence: PC2 7207 points x 9" test "$(stat -c %s cat.pc2)" -eq $((32 + 12 * 7207 * 9))
check "sequence: glb 7207 vertices" glb_json cat.glb 'j["accessors"][0]["count"] == 7207'

# ---- bad inputs
reject 1 'missing\.h5: cannot open' x.glb "$DTX" export missing.h5 $R --glb x.glb
reject 1 'job\.json: not an HDF5 file' x.glb "$DTX" export job.json $R --glb x.glb
reject 1 '/results/lion/nope: no such object' x.glb "$DTX" export out.h5 /results/lion/nope --glb x.glb
reject 1 '/meshes/lion is a mesh, not a result or a sequence' x.pc2 \
    "$DTX" export out.h5 /meshes/lion --pc2 x.pc2
reject 1 'is a marker set' x.pc2 "$DTX" export cl.h5 /markers/cat-lion --pc2 x.pc2
reject 1 'is a correspondence' x.pc2 "$DTX" export out.h5 /correspondences/lion --pc2 x.pc2
reject 1 '/results/lion is a group of results, not one; name one: /results/lion/cat-poses' \
    x.glb "$DTX" export out.h5 /results/lion --glb x.glb
reject 1 'is not a result \(/results/...\) or a sequence' x.glb "$DTX" export out.h5 / --glb x.glb
reject 1 'no-such-dir/x\.glb: cannot create' no-such-dir/x.glb \
    "$DTX" export out.h5 $R --glb no-such-dir/x.glb
reject 1 'no-such-dir/x\.pc2: cannot create' no-such-dir/x.pc2 \
    "$DTX" export out.h5 $R --pc2 no-such-dir/x.pc2
mkdir -p adir
reject 1 'adir \(--glb\) is a directory: give a file name for it \(nothing was read or written\)' adir/.keep "$DTX" export out.h5 $R --glb adir
reject 1 '9 frames to export, more than --max-frames 4.*--stride 3' lion.glb \
    "$DTX" export out.h5 $R --glb lion.glb --max-frames 4
# Checks come before any output: the PC2 of the same call is not written.
reject 1 'more than --max-frames 2' y.pc2 "$DTX" export out.h5 $R --pc2 y.pc2 --glb y.glb --max-frames 2
check "  ... nor the glb" test ! -e y.glb
reject 2 'at least one of --obj-dir' x.glb "$DTX" export out.h5 $R
reject 2 'needs FILE\.h5 and a result or sequence path' x.glb "$DTX" export out.h5 --glb x.glb
reject 2 '--stride must be a whole number >= 1' x.glb "$DTX" export out.h5 $R --glb x.glb --stride 0
reject 2 '--stride must be' x.glb "$DTX" export out.h5 $R --glb x.glb --stride 2x
reject 2 '--fps must be a number > 0' x.glb "$DTX" export out.h5 $R --glb x.glb --fps 0
reject 2 '--fps must be' x.glb "$DTX" export out.h5 $R --glb x.glb --fps nan
reject 2 '--max-frames must be a whole number from 1 to 65535' x.glb \
    "$DTX" export out.h5 $R --glb x.glb --max-frames 65536
reject 2 '--fps goes with --glb or --mdd' x.pc2 \
    "$DTX" export out.h5 $R --pc2 x.pc2 --fps 30
reject 2 '--step and --max-frames go with --glb' x.mdd \
    "$DTX" export out.h5 $R --mdd x.mdd --step
reject 2 '--start-frame goes with --pc2' x.glb "$DTX" export out.h5 $R --glb x.glb --start-frame 2
reject 2 'unknown option --frobnicate' x.glb "$DTX" export out.h5 $R --glb x.glb --frobnicate
reject 2 '--glb needs a value' x.glb "$DTX" export out.h5 $R --glb
reject 2 '--pc2 given twice' x.pc2 "$DTX" export out.h5 $R --pc2 x.pc2 --pc2 x.pc2
if "$PY" -c 'import h5py' 2> /dev/null; then
    cp out.h5 incomplete.h5
    "$PY" -c 'import h5py, sys; h5py.File(sys.argv[1], "r+")[sys.argv[2] + "/frame_done"][4] = 0' \
        incomplete.h5 $R
    reject 1 'is incomplete: frame 4 \(0-based\) is not done' x.pc2 \
        "$DTX" export incomplete.h5 $R --pc2 x.pc2
else
    echo "note: no h5py; the incomplete-result case is not run"
fi
check "no temporary file left" test -z "$(find . -name '.*.tmp-*')"

echo "$pass passed, $fails failed"
[ "$fails" -eq 0 ]
