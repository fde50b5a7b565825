#!/usr/bin/env bash
# `dtx render` on the bundled cat -> lion data: a contact sheet of a result
# (source row above the target row), a sequence, a mesh of a file, a mesh
# file; PNG signature and size; the same bytes twice; and bad arguments
# rejected with exit status 2 (usage) or 1 (error), a message naming the
# problem, and no output or temporary file left behind (an existing output
# is left untouched).
set -uo pipefail
D="$DTX_BUILD/data/sumner-cat-lion"
W="$DTX_TESTDATA"
cd "$W" || exit 1
pass=0 fails=0
ok() { echo "ok: $1"; pass=$((pass + 1)); }
bad() { echo "FAILED: $1"; fails=$((fails + 1)); }
check() { # check DESCRIPTION COMMAND...
    local what=$1; shift
    if "$@"; then ok "$what"; else bad "$what"; fi
}
# png_size FILE: "WIDTH HEIGHT" from the IHDR chunk, or nothing if FILE is
# not a PNG.
png_size() {
    [ "$(head -c 8 "$1" | od -An -tx1 | tr -d ' \n')" = 89504e470d0a1a0a ] || return 1
    local hex
    hex=$(od -An -tx1 -j16 -N8 "$1" | tr -d ' \n')
    echo "$((16#${hex:0:8})) $((16#${hex:8:8}))"
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
    ok "rejected ($rc): $msg"
}

# ---- a small result: three cat poses onto the lion
"$DTX" import mesh "$D/source/cat-reference.obj" -o cl.h5 --name cat 2>/dev/null
"$DTX" import mesh "$D/target/lion-reference.obj" -o cl.h5 --name lion 2>/dev/null
"$DTX" import sequence "$D/source/cat-01.obj" "$D/source/cat-04.obj" "$D/source/cat-05.obj" \
    -o cl.h5 --name cat-poses --mesh /meshes/cat 2>/dev/null
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

# ---- pictures
check "result contact sheet" "$DTX" render out.h5 $R -o sheet.png
check "sheet is a 600-pixel-wide PNG (3 frames x 200)" test "$(png_size sheet.png | cut -d' ' -f1)" = 600
check "the only result is found without naming it" "$DTX" render out.h5 -o auto.png
check "same picture both ways" cmp -s sheet.png auto.png
check "the target's group names its one result" "$DTX" render out.h5 /results/lion -o grp.png
check "same picture again" cmp -s sheet.png grp.png
check "result alone (--no-source)" "$DTX" render out.h5 $R --no-source -o target.png
h2=$(png_size sheet.png | cut -d' ' -f2) h1=$(png_size target.png | cut -d' ' -f2)
check "two rows are twice as high as one ($h2 vs $h1)" test "$h2" -ge $((2 * h1 - 4))
check "sequence, chosen frames, given size" \
    "$DTX" render cl.h5 /sequences/cat-poses --frames 2,0 --width 640 --height 300 -o seq.png
check "sequence picture is 640 x 300" test "$(png_size seq.png)" = "640 300"
check "one frame, flat, one colour, top view" \
    "$DTX" render cl.h5 /sequences/cat-poses --frames 1 --flat --color '#8899aa' --view top \
    -o one.png
check "a mesh of a file" "$DTX" render cl.h5 /meshes/lion --view 30,20 --up y -o lion.png
check "a mesh file" "$DTX" render "$D/target/lion-reference.obj" --width 300 -o obj.png
check "mesh file picture is 300 wide" test "$(png_size obj.png | cut -d' ' -f1)" = 300
check "two columns wrap three frames into two blocks" \
    "$DTX" render out.h5 $R --cols 2 --supersample 1 --no-labels -o wrap.png
check "deterministic" bash -c "'$DTX' render out.h5 $R -o again.png 2>/dev/null && cmp -s sheet.png again.png"
check "deterministic across thread counts" bash -c \
    "OMP_NUM_THREADS=1 '$DTX' render out.h5 $R -o t1.png 2>/dev/null && cmp -s sheet.png t1.png"

# ---- bad arguments
echo old > keep.png
reject 2 "needs -o" none.png "$DTX" render out.h5 $R
reject 2 "unknown option --fast" none.png "$DTX" render out.h5 $R -o none.png --fast
reject 2 "--frames must be" none.png "$DTX" render out.h5 $R -o none.png --frames 1,x
reject 2 "--frames or --count, not both" none.png \
    "$DTX" render out.h5 $R -o none.png --frames 1 --count 2
reject 2 "--view must be" none.png "$DTX" render out.h5 $R -o none.png --view 10,95
reject 2 "--width must be" none.png "$DTX" render out.h5 $R -o none.png --width 0
reject 2 "--supersample must be" none.png "$DTX" render out.h5 $R -o none.png --supersample 8
reject 2 "--color must be" none.png "$DTX" render out.h5 $R -o none.png --color red
reject 2 "--count must be" none.png "$DTX" render out.h5 $R -o none.png --count 0
reject 2 "need a sequence or a result" none.png "$DTX" render cl.h5 /meshes/cat --count 2 -o none.png
reject 1 "out\\.h5: $R has 3 frames \\(0\\.\\.2\\): frame 3 is out of range" keep.png \
    "$DTX" render out.h5 $R --frames 0,3 -o keep.png
reject 1 "out\\.h5: no object /results/nope" keep.png "$DTX" render out.h5 /results/nope -o keep.png
reject 1 "cl\\.h5: /markers/cat-lion is not a mesh, a sequence or a result" keep.png \
    "$DTX" render cl.h5 /markers/cat-lion -o keep.png
reject 1 "cl\\.h5 holds 2 results or sequences|name one" keep.png \
    bash -c "'$DTX' import sequence '$D/source/cat-02.obj' -o cl.h5 --name more --mesh /meshes/cat 2>/dev/null; '$DTX' render cl.h5 -o keep.png"
reject 1 "missing\\.h5" keep.png "$DTX" render missing.h5 -o keep.png
reject 1 "missing\\.obj" keep.png "$DTX" render missing.obj -o keep.png
reject 1 "no-dir/x\\.png" no-dir/x.png "$DTX" render out.h5 $R -o no-dir/x.png
check "the existing output is untouched" test "$(cat keep.png)" = old
# The source sequence's file has moved away: say so, and --no-source works.
mv cl.h5 moved.h5
reject 1 "source sequence .*cl\\.h5:/sequences/cat-poses.* --no-source" keep.png \
    "$DTX" render out.h5 $R -o keep.png
check "--no-source still draws the result" "$DTX" render out.h5 $R --no-source -o alone.png
check "same as before" cmp -s target.png alone.png
mv moved.h5 cl.h5

echo "$pass passed, $fails failed"
[ "$fails" -eq 0 ]
