#!/usr/bin/env bash
# Method biharmonic end to end, cat -> lion, under mpirun:
#  - keypoints "markers" (11 of the 55 markers are the key points) at 1 rank x 2
#    threads and 2 ranks x 1 thread (not in the sanitizer pass);
#  - keypoints "auto" (small settings: 20 candidates, at most 6 key points,
#    3 training frames) at 2 ranks x 1 thread (the selection split over
#    them) and 1 rank x 2 threads (over a copy of the first output, whose
#    cached sp04 correspondence it reuses; not in the sanitizer pass);
#  - the weights cache: the 2-rank job again over its own output reads the
#    key points and both meshes' weights from it (same bits), and a job with
#    other training frames selects again (not in the sanitizer pass);
# every result validates, equals the others to 1e-12 relative (`dtx diff`),
# names its method, and the output holds the key points as the marker set
# /markers/lion-keypoints (the same set at every rank and thread count),
# which a later job uses as its markers with the same result; bad
# biharmonic job values are refused with messages naming the field.
set -euo pipefail
D="$DTX_BUILD/data/sumner-cat-lion"
W="$DTX_TESTDATA"
cd "$W"
. "$DTX_SRC/tests/lib.sh"
MPIRUN=(mpirun --oversubscribe --bind-to none)

"$DTX" import mesh "$D/source/cat-reference.obj" -o in.h5 --name cat 2> /dev/null
"$DTX" import mesh "$D/target/lion-reference.obj" -o in.h5 --name lion 2> /dev/null
mkdir -p poses
for k in 1 2 3 4 5 6 7 8 9; do ln -s "$D/source/cat-0$k.obj" "poses/cat-$k.obj"; done
"$DTX" import sequence poses -o in.h5 --name cat-poses --mesh /meshes/cat --dtype float64 2> /dev/null
"$DTX" import markers "$D/markers.csv" --index-base 0 -o in.h5 --name cat-lion \
    --source /meshes/cat --target /meshes/lion 2> /dev/null
# Every fifth marker (11): the "markers" runs compute bounded weights for
# each key point on both meshes, which with all 55 takes a minute a run.
sed -n '1p;2~5p' "$D/markers.csv" > markers11.csv
"$DTX" import markers markers11.csv --index-base 0 -o in.h5 --name cat-lion-11 \
    --source /meshes/cat --target /meshes/lion 2> /dev/null

job() { # job NAME BIHARMONIC-OBJECT [EXTRA-TARGET-KEYS]
    cat > "$1.json" <<JOB
{
  "dtx_job": 1,
  "method": "biharmonic",
  "source": {"file": "in.h5", "mesh": "/meshes/cat", "sequences": ["/sequences/cat-poses"]},
  "targets": [{"file": "in.h5", "mesh": "/meshes/lion",
               "markers": {"file": "in.h5", "path": "${MK:-/markers/cat-lion}"}${3:-}}],
  "output": {"file": "$1.h5", "dtype": "float64", "block_frames": 8},
  "biharmonic": $2
}
JOB
}
# The marker set a run stored, as text.
kpset() { h5dump -d "/markers/lion-keypoints/$2" "$1" | sed -n '/DATA {/,/}/p'; }
R=/results/lion/cat-poses

# ---------------------------------------------------------- markers
MK=/markers/cat-lion-11 job mk1 '{"keypoints": "markers"}'
MK=/markers/cat-lion-11 job mk2 '{}'
t0=$(date +%s)
OMP_NUM_THREADS=2 "${MPIRUN[@]}" -np 1 "$DTX" run mk1.json 2> mk1.log
t1=$(date +%s)
echo "markers: 1 rank x 2 threads $((t1 - t0)) s"
# Both ranks compute the weights of both meshes; the sanitizer pass leaves
# this run to the auto runs below, which cover the same code at 2 ranks.
if [ "${DTX_SANITIZED:-0}" != 1 ]; then
    OMP_NUM_THREADS=1 "${MPIRUN[@]}" -np 2 "$DTX" run --quiet mk2.json
    echo "markers: 2 ranks x 1 thread $(( $(date +%s) - t1 )) s"
    check "markers: 1 rank == 2 ranks (1e-12)" "$DTX" diff mk1.h5 mk2.h5 $R --tol 1e-12
fi
check "markers: result validates" "$DTX" validate mk1.h5
check "markers: provenance names the method" \
    bash -c "h5dump -a $R/method mk1.h5 | grep -q '\"biharmonic\"'"
check "markers: the 11 markers stored as the key points" \
    bash -c "h5dump -H -d /markers/lion-keypoints/source_vertex mk1.h5 | grep -q '( 11 )'"
check "markers: no correspondence computed" \
    grep -q '"lion": "not needed"' mk1.h5.summary.json
check "markers: the run says where the key points come from" \
    grep -q 'its 11 markers are the key points' mk1.log

# ------------------------------------------------------------- auto
small='{"keypoints": "auto", "candidates": 20, "max_keypoints": 6, "training_frames": 3}'
job au1 "$small"
job au2 "$small"
t0=$(date +%s)
OMP_NUM_THREADS=1 "${MPIRUN[@]}" -np 2 "$DTX" run au2.json 2> au2.log
t1=$(date +%s)
# The same job at 1 rank x 2 threads, over a copy of the first output (not
# --resume) without its cached weights: the correspondence comes from the
# old output's cache, the key points are selected again, and the result
# equals the 2-rank one.  The sanitizer pass runs the 2-rank job only (the
# selection split over the ranks, the weights shared out); there au1.h5 is
# that result.
cp au2.h5 au1.h5
cp au2.h5 au2-first.h5
"$DTX" rm au1.h5 /weights/lion-source /weights/lion-target > /dev/null
if [ "${DTX_SANITIZED:-0}" != 1 ]; then
    OMP_NUM_THREADS=2 "${MPIRUN[@]}" -np 1 "$DTX" run au1.json 2> au1.log
fi
t2=$(date +%s)
echo "auto: 2 ranks x 1 thread $((t1 - t0)) s, 1 rank x 2 threads (correspondence cached) $((t2 - t1)) s"
if [ "${DTX_SANITIZED:-0}" != 1 ]; then
    check "auto: 2 ranks x 1 thread == 1 rank x 2 threads (1e-12)" "$DTX" diff au2.h5 au1.h5 $R --tol 1e-12
    check "auto: second run reuses the correspondence" grep -q '"lion": "reused"' au1.h5.summary.json
    check "auto: second run selects the key points again" grep -q 'key points selected' au1.log
fi
check "auto: result validates" "$DTX" validate au2.h5
check "auto: provenance names the method" \
    bash -c "h5dump -a $R/method au2.h5 | grep -q '\"biharmonic\"'"
for d in source_vertex target_vertex label; do
    if [ "${DTX_SANITIZED:-0}" != 1 ]; then
        check "auto: the key-point set's $d is the same at 2 ranks x 1 thread and 1 rank x 2 threads" \
            cmp <(kpset au2.h5 $d) <(kpset au1.h5 $d)
    fi
done
check "auto: at most 6 key points" \
    grep -Eq '\( [1-6] \)' <(h5dump -H -d /markers/lion-keypoints/source_vertex au1.h5)
check "auto: the table is printed" grep -q 'key   *vertex  *position.*nearest marker.*target vertex' au2.log
check "auto: labels name nearby markers" grep -q 'key [0-9]* near ' <(kpset au1.h5 label)
check "auto: the correspondence is stored" \
    bash -c "h5dump -H -g /correspondences/lion au1.h5 > /dev/null"
check "auto: training frames and selection reported" grep -q 'from 3 training frames (20 candidates, 2 rank' au2.log
check "auto: the first run computes the target weights" \
    grep -q 'source from the key-point selection, target computed' au2.log
check "auto: the output caches both meshes' weights" \
    bash -c "h5dump -H -d /weights/lion-source/weights -d /weights/lion-target/weights au2.h5 | grep -c DATASPACE | grep -qx 2"

# The weights cache: the same job again over its own output selects no key
# points and solves no weights (both come from the output, keyed by the
# source, training frames and parameters, and by each mesh and its key
# points), with the same result bit for bit.
OMP_NUM_THREADS=1 "${MPIRUN[@]}" -np 2 "$DTX" run au2.json 2> au2-again.log
check "cache: the re-run takes the key points from the output" \
    grep -q 'key points on .*in.h5:/meshes/cat and their weights reused from the output' au2-again.log
check "cache: the re-run selects no key points" bash -c "! grep -q 'key points selected' au2-again.log"
check "cache: the re-run solves no weights" grep -q \
    "source reused from the output's cache with the key points, target reused from the output's cache" \
    au2-again.log
check "cache: the re-run's result is the same bits" "$DTX" diff au2-first.h5 au2.h5 $R --tol 0
# A changed input is a different key: with one training frame fewer the
# key points are selected again (and their weights solved) over the same
# old output.
if [ "${DTX_SANITIZED:-0}" != 1 ]; then
    job au3 '{"keypoints": "auto", "candidates": 20, "max_keypoints": 6, "training_frames": 2}'
    cp au2.h5 au3.h5
    OMP_NUM_THREADS=2 "$DTX" run au3.json 2> au3.log
    check "cache: other training frames select again" grep -q 'key points selected' au3.log
    check "cache: other training frames solve the weights again" \
        grep -q 'source from the key-point selection' au3.log
fi

# The stored key points, used by a later job as its markers (with the same
# training frames): the same plan, the same result.
cat > reuse.json <<JOB
{
  "dtx_job": 1,
  "method": "biharmonic",
  "source": {"file": "in.h5", "mesh": "/meshes/cat", "sequences": ["/sequences/cat-poses"]},
  "targets": [{"file": "in.h5", "mesh": "/meshes/lion",
               "markers": {"file": "au2.h5", "path": "/markers/lion-keypoints"}}],
  "output": {"file": "reuse.h5", "dtype": "float64", "block_frames": 8},
  "biharmonic": {"keypoints": "markers", "training_frames": 3}
}
JOB
OMP_NUM_THREADS=2 "$DTX" run --quiet reuse.json
check "the stored key points as markers give the same result" \
    "$DTX" diff au1.h5 reuse.h5 $R --tol 1e-12

# ------------------------------------------------------ bad values
bad() { # bad NAME BIHARMONIC-OBJECT EXPECTED-REGEX [EXTRA-TARGET-KEYS]
    job "$1" "$2" "${4:-}"
    if "$DTX" run --quiet "$1.json" 2> "$1.log"; then
        echo "FAILED: $1 accepted"; fails=$((fails + 1))
    else
        check "$1 refused naming the field" grep -Eq "$3" "$1.log"
        check "$1 leaves no output" test ! -e "$1.h5" -a ! -e "$1.h5.partial"
    fi
}
bad b_kind '{"keypoints": "some"}' 'at /biharmonic/keypoints: .*markers, auto'
bad b_cand '{"candidates": 0}' 'at /biharmonic/candidates: expected an integer in \[1, 100000\], got 0'
bad b_eps '{"eps": -0.1}' 'at /biharmonic/eps: .*>= 0'
bad b_max '{"max_keypoints": 2.5}' 'at /biharmonic/max_keypoints: expected an integer'
bad b_train '{"training_frames": 0}' 'at /biharmonic/training_frames: expected an integer in \[1, 100000\], got 0'
bad b_lambda '{"lambda": 0}' 'at /biharmonic/lambda: .*> 0'
bad b_gamma '{"gamma_s": "high"}' 'at /biharmonic/gamma_s: expected a number'
bad b_key '{"epsilon": 0.1}' 'at /biharmonic: unknown key "epsilon"'
bad b_pins '{}' 'at /targets/0/pins: method biharmonic does not support pins' \
    ', "pins": [{"vertex": 3, "position": [0, 0, 0]}]'
bad b_trpins '{}' 'at /targets/0/translation: method biharmonic does not support pins' \
    ', "translation": "pins"'

finish
