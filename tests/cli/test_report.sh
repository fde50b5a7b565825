#!/usr/bin/env bash
# `dtx report` on a small cat -> lion result: the page names the method,
# the target's size, every frame's residual (the same numbers as the file
# holds), the run's timings from the run summary, and links a contact sheet
# that exists and is a PNG; without a summary the page says so; beyond 100
# frames the solver figures name the largest final gradient norms; bad input
# (no results, a missing file, an unreadable summary, an unwritable report)
# gives exit 1 with a message naming the problem and leaves no report.
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
# reject PATTERN OUTPUT COMMAND...: exit 1, message matches, OUTPUT absent.
reject() {
    local pattern=$1 out=$2 msg rc; shift 2
    msg=$("$@" 2>&1); rc=$?
    if [ "$rc" -ne 1 ]; then bad "exit $rc (want 1): $*: $msg"; return; fi
    if ! grep -qE -- "$pattern" <<<"$msg"; then bad "message lacks /$pattern/: $msg"; return; fi
    if [ -e "$out" ]; then bad "$out left behind: $*"; return; fi
    if compgen -G "$(dirname "$out")/.*.tmp-*" > /dev/null; then bad "temporary file left: $*"; return; fi
    ok "rejected: $msg"
}

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

check "report written" "$DTX" report out.h5
M=out.report.md
check "report file" test -s $M
check "section of the result" grep -q '^## /results/lion/cat-poses$' $M
check "method" grep -q '^- method: sp04$' $M
check "target size" grep -q '^- target: /meshes/lion (5000 vertices, 9996 faces)$' $M
check "complete" grep -q '^- frames: 3, 3 done, complete$' $M
check "timings table" grep -qE '^\| [0-9]+ \| [0-9]+ \| 3 \| [0-9.]+ \|' $M
check "timings table has the key-point phase" grep -q "| key points s |" $M
pic=$(sed -n 's/^!\[.*\](\(.*\))$/\1/p' $M)
check "picture linked ($pic)" test -n "$pic"
check "picture is a PNG" test "$(head -c 8 "$pic" 2>/dev/null | od -An -tx1 | tr -d ' \n')" = 89504e470d0a1a0a
check "the page says what an sp04 residual is and its unit" \
    grep -q '^Residual per frame (sqrt(E / pairs), E the minimised deformation-gradient mismatch.*dimensionless' $M
# The residuals on the page are the file's (h5dump when available, else
# only their count and finiteness).
rows=$(grep -cE '^\| [0-2] \| [0-9.e+-]+ \|$' $M)
check "a residual row per frame ($rows)" test "$rows" -eq 3
if command -v h5dump > /dev/null; then
    want=$(h5dump -m '%.6g' -d /results/lion/cat-poses/residual -y out.h5 2>/dev/null |
           sed -n '/DATA {/,/}/p' | grep -oE '[0-9][0-9.e+-]*' | tr '\n' ' ')
    got=$(grep -E '^\| [0-2] \| [0-9.e+-]+ \|$' $M | awk -F'|' '{gsub(/ /,"",$3); printf "%s ", $3}')
    check "residuals match the file ($got)" test "$want" = "$got"
fi

# Options: -o, --no-pictures, without a summary.
mkdir -p sub
check "report -o --no-pictures" "$DTX" report out.h5 -o sub/r.md --no-pictures
check "no picture without pictures" bash -c '! grep -q "^!\[" sub/r.md && [ ! -d sub/r-pictures ]'
mv out.h5.summary.json saved.json
check "report without a summary" "$DTX" report out.h5 -o nosum.md --no-pictures
check "says the summary is missing" grep -q 'No run summary' nosum.md
check "--summary FILE" "$DTX" report out.h5 -o withsum.md --no-pictures --summary saved.json
check "timings from --summary" grep -q '^## Run$' withsum.md
# Every rank's phases: one row per rank of the summary's seconds_per_rank,
# rank 0's total the Run table's.  A one-rank run gives one row; a summary
# with two ranks (rank 1 waiting 0.25 s) gives two, in rank order.
check "phases per rank" grep -q '^Phases per rank' withsum.md
# rank_rows FILE: the rows of the per-rank table.
rank_rows() { awk '/^Phases per rank/ {f = 1} f && /^\| rank \|/ {t = 1; next} t && /^$/ {exit} t && /^\| [0-9]+ \|/ {print}' "$1"; }
rows=$(rank_rows withsum.md | wc -l)
check "one row per rank at 1 rank ($rows)" test "$rows" -eq 1
t0=$(rank_rows withsum.md | grep -E '^\| 0 \|' | awk -F'|' '{gsub(/ /,"",$3); print $3}')
trun=$(grep -A2 '^| ranks |' withsum.md | tail -1 | awk -F'|' '{gsub(/ /,"",$5); print $5}')
check "rank 0's total is the run's ($t0, $trun)" test -n "$t0" -a "$t0" = "$trun"
if /usr/bin/python3 -c 'import json' 2> /dev/null; then
    /usr/bin/python3 - <<'PY'
import json
d = json.load(open("saved.json"))
r0 = dict(d["seconds_per_rank"][0])
r1 = dict(r0); r1["wait"] = 0.25; r1["total"] = 7.5
d["ranks"] = 2; d["seconds_per_rank"] = [r0, r1]
json.dump(d, open("two.json", "w"))
PY
    check "report with a 2-rank summary" "$DTX" report out.h5 -o two.md --no-pictures --summary two.json
    rows=$(rank_rows two.md | wc -l)
    check "one row per rank at 2 ranks ($rows)" test "$rows" -eq 2
    check "rank 1's row: its total and its wait" \
        bash -c "grep -A6 '^Phases per rank' two.md | grep -E '^\| 1 \| 7.500 \|' | grep -qE '\| 0.250 \| [0-9.]+ \|\$'"
    # dtx inspect reads the summary beside the file and names every phase it holds.
    cp out.h5 insp.h5 && cp saved.json insp.h5.summary.json
    check "inspect names output, finish and wait" \
        bash -c "'$DTX' inspect insp.h5 | grep -E '^  seconds: total' | grep 'output [0-9]' | grep 'finish [0-9]' | grep -q 'wait [0-9]'"
fi

# Solver figures beyond TABLE_MAX (100) frames: a 102-frame result given
# frame_stats and frame_grad_norm by h5py (as springs writes them; sp04
# runs in milliseconds).  The summary names the largest norm and its
# frame, the table lists the ten largest, largest first, ties by frame; a
# frame not done is left out.
if /usr/bin/python3 -c 'import h5py, numpy' 2> /dev/null; then
    mkdir -p many
    for k in $(seq 1 34); do for p in 01 04 05; do ln -sf "$D/source/cat-$p.obj" "many/cat-$k-$p.obj"; done; done
    "$DTX" import sequence many -o cl.h5 --name many --mesh /meshes/cat 2> /dev/null
    sed -e 's/cat-poses/many/' -e 's/out.h5/many.h5/' job.json > many.json
    "$DTX" run --quiet many.json
    /usr/bin/python3 - <<'PY'
import h5py, numpy as np
with h5py.File("many.h5", "r+") as f:
    g = f["/results/lion/many"]
    T = g["frame_done"].shape[0]
    st = np.zeros((T, 3), np.int32); st[:, 0] = 7; st[:, 1] = 1; st[40, 1] = 0
    gn = np.arange(T, dtype=np.float64) * 1e-3
    gn[57] = gn[90] = 5.0   # the largest, tied: frame 57 first
    gn[99] = 9.0            # larger still, but not done
    g["frame_done"][99] = 0
    g.attrs["complete"] = np.int32(0)
    g.create_dataset("frame_stats", data=st)
    g.create_dataset("frame_grad_norm", data=gn)
    g.attrs["method"] = "springs"
PY
    "$DTX" report many.h5 -o many.md --no-pictures 2> /dev/null
    check "report, 102 frames: the largest final gradient norm of a frame done" \
        grep -q '^Newton solves (frame_stats): 7.0 iterations .*1 of 101 frames stopped before converging (frame 40); 0 frames have inverted triangles; final gradient norm at most 5 (frame 57)\.$' many.md
    check "report, 102 frames: the ten largest, largest first" bash -c \
        "grep -A 13 '^Largest final gradient norms:' many.md | grep -E '^\| [0-9]+ \|' | awk -F'|' '{print \$2+0}' | paste -sd' ' | grep -qx '57 90 101 100 98 97 96 95 94 93'"
    check "inspect, 102 frames: the same largest norm and frame" bash -c \
        "'$DTX' inspect many.h5 | grep -q 'final gradient norm at most 5 (frame 57)'"
    # A NaN in a frame done (a damaged file) is the largest for both, not skipped.
    cp many.h5 nan.h5
    /usr/bin/python3 -c 'import h5py, numpy as np; h5py.File("nan.h5", "r+")["/results/lion/many/frame_grad_norm"][20] = np.nan'
    "$DTX" report nan.h5 -o nan.md --no-pictures 2> /dev/null
    check "report: a NaN norm in a frame done is named as the largest" \
        grep -q 'final gradient norm at most nan (frame 20)\.$' nan.md
    check "inspect: a NaN norm in a frame done is named as the largest" bash -c \
        "'$DTX' inspect nan.h5 | grep -q 'final gradient norm at most nan (frame 20)'"
else
    echo "skipped: the report beyond 100 frames (no python3-h5py)"
fi

# Bad input.
reject "no results" bad1.md "$DTX" report cl.h5 -o bad1.md --no-pictures
reject "missing.h5" bad2.md "$DTX" report missing.h5 -o bad2.md
echo '{"ranks": 2,' > broken.json
reject "broken.json: the run summary is not valid JSON" bad3.md \
    "$DTX" report out.h5 -o bad3.md --summary broken.json --no-pictures
reject "nodir/r.md" nodir/r.md "$DTX" report out.h5 -o nodir/r.md --no-pictures
msg=$("$DTX" report out.h5 --count 0 2>&1); rc=$?
check "--count 0 is a usage error ($rc: $msg)" test "$rc" -eq 2

echo "$pass passed, $fails failed"
[ "$fails" -eq 0 ]
