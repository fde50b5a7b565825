# tests/lib.sh: helpers shared by the shell tests, sourced after `set -euo pipefail`:
#   . "$DTX_SRC/tests/lib.sh"
#
#   check DESCRIPTION COMMAND...   run COMMAND; print "ok: DESCRIPTION" or
#                                  "FAILED: DESCRIPTION" and count the failure
#   finish                         print the summary line; fails (status 1)
#                                  when any check failed: end the test with it
fails=0
check() { # check DESCRIPTION COMMAND...
    local what=$1; shift
    if "$@"; then echo "ok: $what"; else echo "FAILED: $what"; fails=$((fails + 1)); fi
}
finish() {
    echo "$((fails == 0 ? 1 : 0)) passed, $fails failed"
    [ "$fails" -eq 0 ]
}

# census ROW OUTCOME: with DTX_CENSUS=FILE set, one line "ROW OUTCOME" per
# bad input tried (scripts/bad-input-census.sh tallies them); OUTCOME is one
# of clear-error, accepted, false-success, crash, hang, unclear-message,
# leftovers, accept-failed.
census() { [ -z "${DTX_CENSUS:-}" ] || echo "$1 $2" >> "$DTX_CENSUS"; }

# bounded COMMAND...: COMMAND under a 120 s timeout (exit 124 when it hangs),
# unless it is a shell function or already a timeout.
bounded() {
    if [ "$1" != timeout ] && [ "$(type -t "$1")" = file ]; then timeout 120 "$@"; else "$@"; fi
}

# cat_lion_result: in the current folder, cl.h5 (the bundled cat and lion,
# the 9 cat poses as /sequences/cat-poses, the 55 markers as
# /markers/cat-lion), job.json and out.h5 holding its sp04 result
# /results/lion/cat-poses.  Needs DTX and D (the unpacked cat-lion data);
# returns non-zero, saying so, when the job does not run.
cat_lion_result() {
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
    "$DTX" run --quiet job.json || { echo "FAILED: the job did not run"; return 1; }
}
