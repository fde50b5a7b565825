#!/usr/bin/env bash
# Method multicomponent end to end: cat -> three multi-component lions made
# by scripts/make-multicomponent-targets.sh (pebbles, garment, eyes), one job,
# run under mpirun at 1 and 2 ranks and 1 and 2 threads: the same result to
# 1e-12 relative; the file validates; the provenance names the method; a
# contact sheet renders; sp04 refuses the same targets and points at
# multicomponent.
set -euo pipefail
D="$DTX_BUILD/data/sumner-cat-lion"
W="$DTX_TESTDATA"
. "$DTX_SRC/tests/lib.sh"

DTX="$DTX" DTX_DATA_DIR="$DTX_BUILD/data" "$DTX_SRC/scripts/make-multicomponent-targets.sh" "$W/targets" 2> "$W/make.log"
"$DTX" import mesh "$D/source/cat-reference.obj" -o "$W/in.h5" --name cat
mkdir -p "$W/poses"
for k in 1 2 3 4 5 6 7 8 9; do ln -s "$D/source/cat-0$k.obj" "$W/poses/cat-$k.obj"; done
"$DTX" import sequence "$W/poses" -o "$W/in.h5" --name cat-poses --mesh /meshes/cat --dtype float64
for t in pebble-lion lion-garment lion-eyes; do
    "$DTX" import mesh "$W/targets/$t.obj" -o "$W/in.h5" --name "$t"
done

job() { # job NAME METHOD
    cat > "$W/$1.json" <<JOB
{
  "dtx_job": 1,
  "method": "$2",
  "source": {"file": "in.h5", "mesh": "/meshes/cat", "sequences": ["/sequences/cat-poses"]},
  "targets": [
    {"file": "in.h5", "mesh": "/meshes/pebble-lion",
     "markers": {"csv": "targets/pebble-lion-markers.csv", "index_base": 0}},
    {"file": "in.h5", "mesh": "/meshes/lion-garment",
     "markers": {"csv": "targets/lion-garment-markers.csv", "index_base": 0}},
    {"file": "in.h5", "mesh": "/meshes/lion-eyes",
     "markers": {"csv": "targets/lion-eyes-markers.csv", "index_base": 0}}
  ],
  "output": {"file": "$1.h5", "dtype": "float64", "block_frames": 8},
  "multicomponent": {"eps_factor": 0.5}
}
JOB
}
job np1 multicomponent
job np2 multicomponent
job np1t2 multicomponent
job sp04 sp04
OMP_NUM_THREADS=1 mpirun -np 1 "$DTX" run --quiet "$W/np1.json"
OMP_NUM_THREADS=1 mpirun -np 2 "$DTX" run "$W/np2.json" 2> "$W/np2.log"
OMP_NUM_THREADS=2 mpirun -np 1 "$DTX" run --quiet "$W/np1t2.json"

for t in pebble-lion lion-garment lion-eyes; do
    R=/results/$t/cat-poses
    check "$t: 1 rank == 2 ranks (1e-12)" "$DTX" diff "$W/np1.h5" "$W/np2.h5" $R --tol 1e-12
    check "$t: 1 thread == 2 threads (1e-12)" "$DTX" diff "$W/np1.h5" "$W/np1t2.h5" $R --tol 1e-12
done
check "result file validates" "$DTX" validate "$W/np2.h5"
check "summary counts 27 frames" grep -q '"frames": 27' "$W/np2.h5.summary.json"
check "provenance names the method" bash -c "h5dump -a /results/pebble-lion/cat-poses/method '$W/np2.h5' 2>/dev/null | grep -q multicomponent || strings '$W/np2.h5' | grep -q '\"method\":\"multicomponent\"'"
# The Gauss-Newton figures: per frame in frame_stats (iterations within
# max_iter 30, converged 0/1 and only short of 30 when 1, inverted not
# counted: -1), the same at 1 and 2 ranks, summed up in the log, the
# summary and the report.
stats() { # stats FILE TARGET: the rows of frame_stats, "iterations converged inverted"
    h5dump -d "/results/$2/cat-poses/frame_stats" "$1" | grep -E '^ *\([0-9]+,0\):' |
        tr -d '(),:' | awk '{print $2, $3, $4}'
}
stats_ok() {
    stats "$1" "$2" | awk '$1 < 1 || $1 > 30 || ($2 != 0 && $2 != 1) || ($2 == 0 && $1 != 30) || $3 != -1 {bad = 1}
                           END {exit bad}'
}
for t in pebble-lion lion-garment lion-eyes; do
    check "$t: frame_stats has 9 rows" test "$(stats "$W/np2.h5" $t | wc -l)" -eq 9
    check "$t: frame_stats rows are solver figures" stats_ok "$W/np2.h5" $t
    check "$t: frame_stats the same at 1 and 2 ranks" cmp <(stats "$W/np1.h5" $t) <(stats "$W/np2.h5" $t)
    # Gauss-Newton reports no final gradient norm: no frame_grad_norm.
    check "$t: no frame_grad_norm" bash -c "! h5ls '$W/np2.h5/results/$t/cat-poses' | grep -q frame_grad_norm && h5ls '$W/np2.h5/results/$t/cat-poses' | grep -q frame_stats"
done
check "summary: no gradient norm for multicomponent" bash -c "! grep -q grad_norm '$W/np2.h5.summary.json'"
check "log: the proximity graph of each target" grep -q 'target pebble-lion: 2[0-9][0-9] components, [0-9]* proximity edges with [0-9]* vertex pairs' "$W/np2.log"
check "log: Gauss-Newton iterations per result" grep -q 'result lion-eyes/cat-poses: Gauss-Newton [0-9.]* iterations per frame' "$W/np2.log"
check "summary: Gauss-Newton figures per result" test "$(grep -c '"multicomponent": {"gauss_newton_iterations_mean"' "$W/np2.h5.summary.json")" -eq 3
check "report written" "$DTX" report "$W/np2.h5" --no-pictures
check "report: the Gauss-Newton solves of each result" test "$(grep -c '^Gauss-Newton solves (frame_stats): ' "$W/np2.report.md")" -eq 3
# The Newton solver ("solver": "newton") converges on every frame of the
# shirt within max_iter 30 (frame_stats: converged 1), 1 and 2 threads the
# same.  The runs add a result (the poses under a second name) to the files
# of 1 thread and 2 threads.  The plain pass only: the sanitizers make it
# several times slower (core.multicomponent runs the solver under them).
if [[ ${DTX_SANITIZED:-0} != 1 ]]; then
    "$DTX" import sequence "$W/poses" -o "$W/in.h5" --name cat-poses-newton --mesh /meshes/cat --dtype float64
    for out in np1 np1t2; do
        cat > "$W/newton-$out.json" <<JOB
{
  "dtx_job": 1,
  "method": "multicomponent",
  "source": {"file": "in.h5", "mesh": "/meshes/cat", "sequences": ["/sequences/cat-poses-newton"]},
  "targets": [
    {"file": "in.h5", "mesh": "/meshes/lion-garment",
     "markers": {"csv": "targets/lion-garment-markers.csv", "index_base": 0}}
  ],
  "output": {"file": "$out.h5", "dtype": "float64", "block_frames": 8},
  "multicomponent": {"eps_factor": 0.5, "solver": "newton"}
}
JOB
    done
    OMP_NUM_THREADS=1 "$DTX" run --quiet "$W/newton-np1.json"
    OMP_NUM_THREADS=2 "$DTX" run --quiet "$W/newton-np1t2.json"
    N=/results/lion-garment/cat-poses-newton
    nstats() { h5dump -d "$N/frame_stats" "$1" | grep -E '^ *\([0-9]+,0\):' | tr -d '(),:' | awk '{print $2, $3, $4}'; }
    check "newton: every shirt frame converged" test "$(nstats "$W/np1.h5" | awk '$2 == 1 && $1 <= 30' | wc -l)" -eq 9
    check "newton: the summary names the solver" grep -q '"multicomponent": {"newton_iterations_mean"' "$W/np1.h5.summary.json"
    check "newton: report written" "$DTX" report "$W/np1.h5" --no-pictures
    check "newton: the report names the solver" test "$(grep -c '^Newton solves (frame_stats): ' "$W/np1.report.md")" -eq 1
    check "newton: 1 thread == 2 threads (1e-12)" "$DTX" diff "$W/np1.h5" "$W/np1t2.h5" $N --tol 1e-12
fi
check "contact sheet renders" "$DTX" render "$W/np2.h5" /results/pebble-lion/cat-poses -o "$W/pebble-lion.png" --count 4
check "contact sheet written" test -s "$W/pebble-lion.png"

if "$DTX" run --quiet "$W/sp04.json" 2> "$W/sp04.log"; then
    echo "FAILED: sp04 accepted a multi-component target"; fails=$((fails + 1))
else
    check "sp04 points at multicomponent" grep -q 'connected components.*multicomponent' "$W/sp04.log"
fi

finish
