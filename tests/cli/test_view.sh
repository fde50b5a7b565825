#!/usr/bin/env bash
# `dtx view` in a real browser (Debian's chromium driven by puppeteer-core,
# tests/cli/view/*.js), on cat -> lion:
# - the player page (cat poses 1-9 and the sp04 result) loads with no console
#   error, failed request or dialog, and after moving the slider to frame k
#   every pane shows frame k of the HDF5 file (read with h5py) within the
#   page's quantisation; the same with a frame budget that strides;
# - on a --pick page, clicking the 55 shipped marker pairs again (at the
#   projected positions of their vertices) gives exactly those vertices, and
#   the downloaded CSV, less its "# index_base: 0" line, is the shipped file;
#   it imports with `dtx import markers` and `dtx run` with it gives the same
#   result as with the shipped markers;
# - a page from a file with hostile names and labels (markup, quotes,
#   </script>) runs none of it and shows it as written;
# - `dtx report out.h5 -o report.html`: the player with the report's text;
# - bad input: exit 1, a message naming the problem, no page left.
# Screenshots (player.png, player-strided.png, pick.png, hostile.png,
# report.png) stay in
# the scratch directory as artefacts.  Without chromium, node or
# puppeteer-core the test is skipped, except in CI (CI=true), where it fails.
# The sanitizer pass writes every page under ASan but leaves the browser to
# the plain pass.
set -uo pipefail
. "$DTX_SRC/tests/lib.sh"
D="$DTX_BUILD/data/sumner-cat-lion"
W="$DTX_TESTDATA"
V="$DTX_SRC/tests/cli/view"
export DTX_SRC
cd "$W" || exit 1

missing() {
    if [ "${CI:-}" = true ]; then
        echo "FAILED: $1 (CI runs this test: install it with scripts/setup.sh)"
        exit 1
    fi
    echo "skipped: $1"
    exit 77
}
command -v node > /dev/null || missing "node not found"
[ -x "${DTX_CHROMIUM:-/usr/bin/chromium}" ] || missing "chromium not found"
node -e "require('$V/browser.js'); require(require('path').join('$DTX_SRC','build-tools','node_modules','puppeteer-core'))" \
    2> /dev/null || missing "puppeteer-core not found in build-tools/"
/usr/bin/python3 -c 'import h5py' 2> /dev/null || missing "python3 h5py not found"
if "$DTX" view /dev/null -o x.html 2>&1 | grep -q "built without three.js"; then
    missing "this dtx was built without three.js"
fi

# The browser checks look at the pages, not at dtx's memory: the sanitizer
# pass writes every page (dtx under ASan) and leaves the browser, and the
# steps that need what it downloads, to the plain pass.
sanitized() { [ "${DTX_SANITIZED:-0}" = 1 ]; }
bcheck() { # bcheck DESCRIPTION SCRIPT ARGS...: check DESCRIPTION node SCRIPT ARGS...
    local what=$1; shift
    if sanitized; then echo "skipped in the sanitizer pass (the plain pass runs it): $what"; return 0; fi
    check "$what" node "$@"
}

# ---- data: cat poses 1-9 on the lion
"$DTX" import mesh "$D/source/cat-reference.obj" -o cl.h5 --name cat 2> /dev/null
"$DTX" import mesh "$D/target/lion-reference.obj" -o cl.h5 --name lion 2> /dev/null
"$DTX" import sequence "$D"/source/cat-0[1-9].obj -o cl.h5 --name cat-poses --mesh /meshes/cat 2> /dev/null
"$DTX" import markers "$D/markers.csv" --index-base 0 -o cl.h5 --name cat-lion \
    --source /meshes/cat --target /meshes/lion 2> /dev/null
job() { # job MARKERS OUT
    cat > "job-$2.json" << JOB
{"dtx_job": 1, "method": "sp04",
 "source": {"file": "cl.h5", "mesh": "/meshes/cat", "sequences": ["/sequences/cat-poses"]},
 "targets": [{"name": "lion", "file": "cl.h5", "mesh": "/meshes/lion",
              "markers": {"file": "cl.h5", "path": "$1"}}],
 "output": {"file": "$2"}}
JOB
    "$DTX" run --quiet "job-$2.json"
}
job /markers/cat-lion out.h5 || { echo "FAILED: the job did not run"; exit 1; }

# ---- the player
check "player page written" "$DTX" view out.h5 -o player.html --markers cl.h5:/markers/cat-lion
bcheck "player: slider and frames" "$V/test_player.js" player.html "$W/player.png" \
    "0=$W/cl.h5:/sequences/cat-poses" "1=$W/out.h5:/results/lion/cat-poses"
check "strided page written" "$DTX" view out.h5 /results/lion/cat-poses cl.h5:/sequences/cat-poses \
    --max-frames 4 -o strided.html
check "strided page embeds frames 0,3,6 (stride 3)" grep -q '"stride":3,"maxFrames":4' strided.html
bcheck "strided player: slider and frames" "$V/test_player.js" strided.html "$W/player-strided.png" \
    "0=$W/out.h5:/results/lion/cat-poses" "1=$W/cl.h5:/sequences/cat-poses"

# ---- dtx report in HTML: the player above the report's text
check "HTML report written" "$DTX" report out.h5 -o report.html
bcheck "HTML report: player and report text, nothing else runs" "$V/test_hostile.js" report.html \
    "$W/report.png" "dtx report: out.h5" "/results/lion/cat-poses" "method: sp04" "frames: 9, 9 done, complete"
check "HTML report: no pictures directory" test ! -e report-pictures

# ---- picking the 55 markers again
check "pick page written" "$DTX" view cl.h5 --pick /meshes/cat /meshes/lion -o pick.html
bcheck "pick: 55 pairs by clicking, CSV downloaded" "$V/test_pick.js" pick.html "$D/markers.csv" "$W"
if ! sanitized; then
    check "downloaded CSV imports" "$DTX" import markers markers.csv --index-base 0 -o cl.h5 --name picked \
        --source /meshes/cat --target /meshes/lion
    check "dtx run with the picked markers" job /markers/picked out-picked.h5
    check "same result as with the shipped markers" "$DTX" diff out.h5 out-picked.h5 /results/lion/cat-poses --tol 0
fi

# ---- key points: each is offered as the next source, one click per pair
cp cl.h5 kp.h5
/usr/bin/python3 - << 'PY'
import h5py, numpy as np
with h5py.File("kp.h5", "r+") as f:
    v = np.array([2653, 2620, 2141], dtype="<i4")
    g = f.create_group("/keypoints/cat-keys")
    g["vertex"] = v
    g["position"] = f["/meshes/cat/vertices"][:][v]
    g.create_dataset("label", data=["paw a", "paw b", "paw c"], dtype=h5py.string_dtype())
    g["error"] = np.array([0.5, 0.25], dtype="<f8")
    for k, x in (("source_mesh", "/meshes/cat"), ("source_sequences", "/sequences/cat-poses"),
                 ("dtx_version", "test")):
        g.attrs.create(k, x, dtype=h5py.string_dtype())
    g.attrs.create("candidates", 3, dtype="<i4")
    g.attrs.create("eps", 0.0, dtype="<f8")
    g.attrs.create("error", 0.25, dtype="<f8")
PY
check "key-point page written" "$DTX" view kp.h5 --pick /meshes/cat /meshes/lion -o keypoints.html
bcheck "key points: one click per pair" "$V/test_keypoints.js" keypoints.html 2653,1316 2620,1412 2141,920
check "player with key points written" "$DTX" view out.h5 -o player-kp.html --keypoints kp.h5:/keypoints/cat-keys
bcheck "player shows the key points' labels" "$V/test_hostile.js" player-kp.html "$W/player-kp.png" \
    "key 1 paw a" "key 3 paw c"

# ---- hostile names and labels
N1='c"a<t>&'"'"'x'
N2='<img src=x onerror=alert(3)>lion'
L1='</script><script>window.dtxPwned=1;alert(1)</script>'
L2='<img src=x onerror="alert(2)">'
M='x<y>"z'
"$DTX" import mesh "$D/source/cat-reference.obj" -o h.h5 --name "$N1" 2> /dev/null
"$DTX" import mesh "$D/target/lion-reference.obj" -o h.h5 --name "$N2" 2> /dev/null
printf '# index_base: 0\nsource_vertex,target_vertex,label\n2653,1316,%s\n2620,1412,%s\n' "$L1" "$L2" > hm.csv
"$DTX" import markers hm.csv --index-base 0 -o h.h5 --name "$M" 2> /dev/null
check "hostile page written" "$DTX" view h.h5 --pick "/meshes/$N1" "/meshes/$N2" --markers "/markers/$M" -o hostile.html
bcheck "hostile names and labels show as text, run nothing" "$V/test_hostile.js" hostile.html "$W/hostile.png" \
    "/meshes/$N1" "/meshes/$N2" "$L1" "$L2" "/markers/$M"

# ---- bad input: exit 1, the message, no page
reject() { # reject PATTERN OUT COMMAND...
    local pattern=$1 out=$2 msg rc; shift 2
    msg=$("$@" 2>&1); rc=$?
    check "exit 1 ($rc): $msg" test "$rc" -eq 1
    check "message names the problem (/$pattern/)" grep -qE -- "$pattern" <<< "$msg"
    check "no $out left" test ! -e "$out"
    check "no temporary file left" bash -c "! compgen -G '$(dirname "$out")/.*.tmp-*' > /dev/null"
}
reject "nope.h5" bad1.html "$DTX" view nope.h5 -o bad1.html
reject "out.h5: /results/none: no such object" bad2.html "$DTX" view out.h5 /results/none -o bad2.html
reject "--pick takes meshes" bad3.html "$DTX" view cl.h5 --pick /sequences/cat-poses /meshes/lion -o bad3.html
reject "--stride 1 gives 9 frames, more than --max-frames 4" bad4.html "$DTX" view out.h5 --stride 1 --max-frames 4 -o bad4.html
reject "/markers/cat-lion: marker 4: vertex 6855 is out of range of /meshes/lion" bad5.html \
    "$DTX" view cl.h5 --pick /meshes/lion /meshes/cat --markers /markers/cat-lion -o bad5.html
reject "no-such-dir" no-such-dir/p.html "$DTX" view out.h5 -o no-such-dir/p.html
finish
