#!/usr/bin/env bash
# The main job end to end on the bundled cat -> lion data: import, run under
# mpirun at 1, 2 and 3 ranks (3: collective writes) and 1 and 2 threads
# (float64 output), check that
# every run gives the same result to 1e-12 relative, validate, export.
set -euo pipefail
D="$DTX_BUILD/data/sumner-cat-lion"
W="$DTX_TESTDATA"
. "$DTX_SRC/tests/lib.sh"

"$DTX" import mesh "$D/source/cat-reference.obj" -o "$W/cl.h5" --name cat
"$DTX" import mesh "$D/target/lion-reference.obj" -o "$W/cl.h5" --name lion
mkdir -p "$W/poses"
for k in 1 2 3 4 5 6 7 8 9; do ln -s "$D/source/cat-0$k.obj" "$W/poses/cat-$k.obj"; done
"$DTX" import sequence "$W/poses" -o "$W/cl.h5" --name cat-poses --mesh /meshes/cat --dtype float64
"$DTX" import markers "$D/markers.csv" --index-base 0 -o "$W/cl.h5" --name cat-lion \
    --source /meshes/cat --target /meshes/lion

job() { # job OUTPUT [EXTRA-OUTPUT-KEYS]
    cat > "$W/$1.json" <<JOB
{
  "dtx_job": 1,
  "method": "sp04",
  "source": {"file": "cl.h5", "mesh": "/meshes/cat", "sequences": ["/sequences/cat-poses"]},
  "targets": [{"name": "lion", "file": "cl.h5", "mesh": "/meshes/lion",
               "markers": {"file": "cl.h5", "path": "/markers/cat-lion"}}],
  "output": {"file": "$1.h5", "dtype": "float64", "block_frames": 8${2:-}}
}
JOB
}
job np1
job np2 ', "export_obj_dir": "obj"'
job np3 ', "io": "collective"'
job np1t2
OMP_NUM_THREADS=1 mpirun -np 1 "$DTX" run --quiet "$W/np1.json"
OMP_NUM_THREADS=1 mpirun -np 2 "$DTX" run "$W/np2.json" 2> "$W/np2.log"
OMP_NUM_THREADS=1 mpirun --oversubscribe -np 3 "$DTX" run --quiet "$W/np3.json"
OMP_NUM_THREADS=2 mpirun -np 1 "$DTX" run --quiet "$W/np1t2.json"

R=/results/lion/cat-poses
check "1 rank == 2 ranks (1e-12)" "$DTX" diff "$W/np1.h5" "$W/np2.h5" $R --tol 1e-12
check "1 rank == 3 ranks (1e-12)" "$DTX" diff "$W/np1.h5" "$W/np3.h5" $R --tol 1e-12
check "1 thread == 2 threads, bitwise" "$DTX" diff "$W/np1.h5" "$W/np1t2.h5" $R --tol 0
check "result file validates" "$DTX" validate "$W/np2.h5"
check "9 OBJ frames exported by the job" test "$(ls "$W/obj/lion/cat-poses" | wc -l)" -eq 9
check "summary written" grep -q '"frames": 9' "$W/np2.h5.summary.json"
# Every rank's phases: one object per rank, each with every phase as a
# number >= 0, rank 0's equal to "seconds", and on stderr one line per rank.
phases_per_rank() { # phases_per_rank SUMMARY RANKS
    /usr/bin/python3 - "$1" "$2" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
n = int(sys.argv[2])
keys = ["read", "keypoints", "correspondence", "factor", "output", "transfer", "write",
        "finish", "wait", "total", "cpu"]
per = d.get("seconds_per_rank")
bad = []
if not isinstance(per, list) or len(per) != n:
    bad.append("seconds_per_rank %r, expected a list of %d" % (per, n))
else:
    for q, p in enumerate(per):
        if sorted(p) != sorted(keys):
            bad.append("rank %d: keys %s" % (q, sorted(p)))
        elif not all(isinstance(p[k], (int, float)) and p[k] >= 0 for k in keys):
            bad.append("rank %d: %r" % (q, p))
        elif not p["total"] > 0 or not p["transfer"] > 0 or not p["cpu"] > 0:
            bad.append("rank %d: no total or transfer time: %r" % (q, p))
    if per[0] != d["seconds"]:
        bad.append("rank 0 %r is not seconds %r" % (per[0], d["seconds"]))
print("\n".join(bad))
sys.exit(1 if bad else 0)
PY
}
check "summary: each of 2 ranks' phases" phases_per_rank "$W/np2.h5.summary.json" 2
check "summary: each of 3 ranks' phases" phases_per_rank "$W/np3.h5.summary.json" 3
check "summary: 1 rank, its phases" phases_per_rank "$W/np1.h5.summary.json" 1
check "stderr: a line per rank" bash -c "grep -q '^dtx: rank 0 (s): read .*, wait .*, total .*, cpu' '$W/np2.log' &&
    grep -q '^dtx: rank 1 (s): read' '$W/np2.log' && ! grep -q '^dtx: rank 2 (s)' '$W/np2.log'"
# More ranks than RANK_LINES_MAX (8): a line per phase with its least and
# most over the ranks instead of a line per rank (plain pass only: nine
# sanitized processes on two cores take long).  9 frames on 9 ranks, block
# size 1, so that every rank transfers.
if [[ ${DTX_SANITIZED:-0} != 1 ]]; then
    job np9
    sed -i 's/"block_frames": 8/"block_frames": 1/' "$W/np9.json"
    OMP_NUM_THREADS=1 mpirun --oversubscribe -np 9 "$DTX" run "$W/np9.json" 2> "$W/np9.log"
    check "9 ranks == 1 rank (1e-12)" "$DTX" diff "$W/np1.h5" "$W/np9.h5" $R --tol 1e-12
    check "summary: each of 9 ranks' phases" phases_per_rank "$W/np9.h5.summary.json" 9
    check "stderr at 9 ranks: a line per phase, none per rank" bash -c \
        "[ \$(grep -c '^dtx: [a-z]* over 9 ranks (s): least [0-9.]* (rank [0-8]), most [0-9.]* (rank [0-8])\$' '$W/np9.log') -eq 11 ] &&
         grep -q '^dtx: transfer over 9 ranks' '$W/np9.log' && ! grep -q '^dtx: rank [0-9] (s)' '$W/np9.log'"
fi
check "no temporary file left" test -z "$(ls "$W" | grep '\.tmp' || true)"

# A second run reuses the correspondence cached in the output.
OMP_NUM_THREADS=1 mpirun -np 1 "$DTX" run "$W/np1.json" 2> "$W/rerun.log"
check "cached correspondence reused" grep -q "reused" "$W/rerun.log"
check "rerun gives the same result" "$DTX" diff "$W/np1.h5" "$W/np2.h5" $R --tol 1e-12

"$DTX" export "$W/np1.h5" $R --obj-dir "$W/exported"
check "export writes 9 frames" test "$(ls "$W/exported" | wc -l)" -eq 9
check "diff notices a different result" bash -c "! '$DTX' diff '$W/np1.h5' '$W/np1.h5' /results/nope 2>/dev/null"

finish
