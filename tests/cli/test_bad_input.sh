#!/usr/bin/env bash
# Bad input through the command line: each case must fail with a non-zero
# exit, a message naming the file and the problem, and leave no output.
set -uo pipefail
. "$DTX_SRC/tests/lib.sh"
W="$DTX_TESTDATA"
D="$DTX_BUILD/data/sumner-cat-lion"
pass=0 fails=0
expect_fail() { # expect_fail NAME OUTPUT-THAT-MUST-NOT-EXIST PATTERN COMMAND...
    local name=$1 out=$2 pattern=$3 row; shift 3
    local msg rc
    row="cli-bad-input:${name// /-}"
    msg=$(bounded "$@" 2>&1); rc=$?
    if [ $rc -eq 0 ]; then census "$row" false-success; echo "FAILED: $name: exit 0"; fails=$((fails + 1)); return; fi
    if [ $rc -eq 124 ]; then census "$row" hang; echo "FAILED: $name: no answer in 120 s"; fails=$((fails + 1)); return; fi
    if [ $rc -gt 2 ]; then census "$row" crash; echo "FAILED: $name: exit $rc (a crash?)"; fails=$((fails + 1)); return; fi
    if ! grep -qE -- "$pattern" <<<"$msg"; then
        census "$row" unclear-message
        echo "FAILED: $name: message lacks /$pattern/: $msg"; fails=$((fails + 1)); return
    fi
    if [ -n "$out" ] && [ -e "$out" ]; then census "$row" leftovers; echo "FAILED: $name: $out was left behind"; fails=$((fails + 1)); return; fi
    census "$row" clear-error
    echo "ok: $name: $msg" | head -1; pass=$((pass + 1))
}

printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 x\nf 1 2 3\n' > "$W/malformed.obj"
expect_fail "malformed OBJ line" "$W/a.h5" 'malformed.obj:4' \
    "$DTX" import mesh "$W/malformed.obj" -o "$W/a.h5" --name m
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n' > "$W/range.obj"
expect_fail "face index out of range" "$W/b.h5" 'range.obj:4.*range' \
    "$DTX" import mesh "$W/range.obj" -o "$W/b.h5" --name m
printf 'v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n' > "$W/nan.obj"
expect_fail "NaN coordinate" "$W/c.h5" 'nan.obj:2.*finite' \
    "$DTX" import mesh "$W/nan.obj" -o "$W/c.h5" --name m

# A frame with a different vertex count.
"$DTX" import mesh "$D/source/cat-reference.obj" -o "$W/s.h5" --name cat 2>/dev/null
expect_fail "frame with another vertex count" "" 'lion-reference.obj.*vertices' \
    "$DTX" import sequence "$D/source/cat-01.obj" "$D/target/lion-reference.obj" -o "$W/s.h5" \
    --name bad --mesh /meshes/cat
if "$DTX" validate "$W/s.h5" >/dev/null 2>&1 && ! h5ls "$W/s.h5/sequences/bad" >/dev/null 2>&1; then
    echo "ok: failed import left the file valid and without the sequence"; pass=$((pass + 1))
else
    echo "FAILED: failed import damaged $W/s.h5"; fails=$((fails + 1))
fi

# Markers out of range, or given in the wrong base.
"$DTX" import mesh "$D/target/lion-reference.obj" -o "$W/s.h5" --name lion 2>/dev/null
printf 'source_vertex,target_vertex,label\n1,2,a\n7207,3,b\n' > "$W/range.csv"
expect_fail "marker out of range" "" 'range.csv.*7207.*range' \
    "$DTX" import markers "$W/range.csv" --index-base 0 -o "$W/s.h5" --name m \
    --source /meshes/cat --target /meshes/lion
printf '0,2,a\n5,3,b\n' > "$W/base.csv"
expect_fail "index 0 in a 1-based marker file" "" 'base.csv:1.*1-based' \
    "$DTX" import markers "$W/base.csv" --index-base 1 -o "$W/s.h5" --name m

# Invalid job files.
printf '{"dtx_job": 1, "method": "sp04", "sourc": {}}\n' > "$W/badkey.json"
expect_fail "job with an unknown key" "" 'badkey.json.*sourc' "$DTX" run "$W/badkey.json"
printf '{"dtx_job": 1,\n "method": sp04}\n' > "$W/syntax.json"
expect_fail "job with a syntax error" "" 'syntax.json:2:[0-9]+: JSON syntax error' "$DTX" run "$W/syntax.json"
cat > "$W/same.json" <<'JOB'
{"dtx_job": 1, "method": "sp04",
 "source": {"file": "s.h5", "mesh": "/meshes/cat", "sequences": ["/sequences/x"]},
 "targets": [{"file": "s.h5", "mesh": "/meshes/lion", "markers": {"csv": "base.csv", "index_base": 0}}],
 "output": {"file": "s.h5"}}
JOB
expect_fail "job whose output is an input" "" 'same.json.*output' "$DTX" run "$W/same.json"
cat > "$W/missing.json" <<'JOB'
{"dtx_job": 1, "method": "sp04",
 "source": {"file": "nowhere.h5", "mesh": "/meshes/cat", "sequences": ["/sequences/x"]},
 "targets": [{"file": "s.h5", "mesh": "/meshes/lion", "markers": {"csv": "base.csv", "index_base": 0}}],
 "output": {"file": "out.h5"}}
JOB
expect_fail "job naming a missing file" "$W/out.h5" 'missing.json.*nowhere.h5' \
    "$DTX" run "$W/missing.json"
cat > "$W/noseq.json" <<'JOB'
{"dtx_job": 1, "method": "sp04",
 "source": {"file": "s.h5", "mesh": "/meshes/cat", "sequences": ["/sequences/none"]},
 "targets": [{"file": "s.h5", "mesh": "/meshes/lion", "markers": {"csv": "range.csv", "index_base": 0}}],
 "output": {"file": "out2.h5"}}
JOB
expect_fail "job with markers out of range" "$W/out2.h5" '7207.*range' "$DTX" run "$W/noseq.json"

echo "$pass passed, $fails failed"
[ "$fails" -eq 0 ]
