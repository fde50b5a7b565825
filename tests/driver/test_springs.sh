#!/usr/bin/env bash
# Method springs end to end under mpirun, one job with three targets:
#  - "fatcat": the cat made 1.25 times thicker with 1.4 times longer legs by
#    `dtx generate reshape` (the source's connectivity: no markers, no
#    correspondence; the paper's setting);
#  - "self": the cat itself, no markers: the result must be the source poses
#    (up to a translation: the centroid stays at the rest centroid; to 2e-3
#    of the diagonal with the cheap settings below);
#  - "lion": another connectivity, through the sp04 proxy (markers).
# Three poses; springs deals single frames, so both ranks of the 2-rank run
# solve (2 + 1 frames, the first rank rotating from result to result).
# Cheap settings (no internal springs, at most 25 Newton iterations: the
# self target converges in about 23); core.springs tests the method's
# properties and scripts/bench-springs.sh its speed and accuracy.
# Run at 2 ranks x 1 thread and 1 rank x 2 threads (the second not in the
# sanitizer pass): the same results to 1e-12 relative; the
# file validates and holds frame_stats (Newton iterations, converged,
# inverted triangles) and frame_grad_norm (the final gradient norm, the
# same bits at both rank and thread counts) for every frame; the summary,
# the log, the report and inspect report the solves; a run failed in its
# frame loop and resumed writes the clean run's bits; the lion result stays near sp04's; a target of another
# connectivity without markers, and pins on a proxy target, are refused
# with messages naming the target.
set -euo pipefail
D="$DTX_BUILD/data/sumner-cat-lion"
W="$DTX_TESTDATA"
cd "$W"
. "$DTX_SRC/tests/lib.sh"
MPIRUN=(mpirun --oversubscribe --bind-to none)
PY=/usr/bin/python3
asan=0 maxit=25
# The sanitizer pass checks memory, not numbers: fewer iterations, no
# numeric checks, the 2-rank run only.
if [[ $(ldd "$DTX") == *libasan* ]]; then asan=1 maxit=6; fi

"$DTX" generate reshape "$D/source/cat-reference.obj" fatcat.obj --axis y --thicken 1.25 \
    --legs 1.4 2> /dev/null
"$DTX" import mesh "$D/source/cat-reference.obj" -o in.h5 --name cat 2> /dev/null
"$DTX" import mesh fatcat.obj -o in.h5 --name fatcat 2> /dev/null
"$DTX" import mesh "$D/target/lion-reference.obj" -o in.h5 --name lion 2> /dev/null
mkdir -p poses
for k in 1 5 9; do ln -s "$D/source/cat-0$k.obj" "poses/cat-$k.obj"; done
"$DTX" import sequence poses -o in.h5 --name cat-poses --mesh /meshes/cat --dtype float64 2> /dev/null
"$DTX" import markers "$D/markers.csv" --index-base 0 -o in.h5 --name cat-lion \
    --source /meshes/cat --target /meshes/lion 2> /dev/null

job() { # job NAME TARGETS [EXTRA]
    cat > "$1.json" <<JOB
{
  "dtx_job": 1,
  "method": "springs",
  "source": {"file": "in.h5", "mesh": "/meshes/cat", "sequences": ["/sequences/cat-poses"]},
  "targets": [$2],
  "output": {"file": "$1.h5", "dtype": "float64", "block_frames": 8},
  "springs": {"internal": false, "max_iter": $maxit${3:-}}
}
JOB
}
T_FAT='{"file": "in.h5", "mesh": "/meshes/fatcat"}'
T_SELF='{"file": "in.h5", "mesh": "/meshes/cat", "name": "self"}'
T_LION='{"file": "in.h5", "mesh": "/meshes/lion", "markers": {"file": "in.h5", "path": "/markers/cat-lion"}}'
for n in np2 np1t2; do job $n "$T_FAT, $T_SELF, $T_LION"; done
job sp04 "$T_LION"
sed -i 's/"method": "springs"/"method": "sp04"/; /"springs":/d; s/"block_frames": 8},/"block_frames": 8}/' sp04.json

OMP_NUM_THREADS=1 "${MPIRUN[@]}" -np 2 "$DTX" run np2.json 2> np2.log
"$DTX" run --quiet sp04.json
R=/results
if [ "$asan" = 0 ]; then
    OMP_NUM_THREADS=2 "${MPIRUN[@]}" -np 1 "$DTX" run --quiet np1t2.json
    for t in fatcat self lion; do
        check "$t: 2 ranks x 1 thread == 1 rank x 2 threads (1e-12)" \
            "$DTX" diff np2.h5 np1t2.h5 $R/$t/cat-poses --tol 1e-12
    done
fi
check "result file validates" "$DTX" validate np2.h5
check "log: no correspondence for the same-connectivity targets" \
    grep -q 'target fatcat: the source.s vertices and faces: no correspondence needed' np2.log
check "log: the lion goes through the proxy" grep -q 'target lion: .* on the proxy' np2.log
check "log: Newton iterations per result" grep -q 'result fatcat/cat-poses: Newton [0-9.]* iterations per frame' np2.log
check "summary: springs figures" grep -q '"springs": {"newton_iterations_mean"' np2.h5.summary.json
check "summary: 9 frames" grep -q '"frames": 9' np2.h5.summary.json
check "summary: no correspondence for fatcat" grep -q '"fatcat": "not needed"' np2.h5.summary.json
check "provenance names the method" bash -c "h5dump -a /results/fatcat/cat-poses/method np2.h5 | grep -q springs"
check "frame_stats: 3 x 3 per result" bash -c "h5dump -H -d /results/lion/cat-poses/frame_stats np2.h5 | grep -q 'DATASPACE  SIMPLE { ( 3, 3 )'"
"$DTX" report np2.h5 -o report.md --no-pictures 2> /dev/null
check "report: the Newton solves of each result" test "$(grep -c '^Newton solves (frame_stats): ' report.md)" -eq 3
check "frame_stats: columns named" bash -c "h5dump -a /results/lion/cat-poses/frame_stats/columns np2.h5 | grep -q 'iterations converged inverted'"
# frame_stats rows: every one written (no -1), iterations 1..maxit,
# converged 0 or 1.  (A frame may stop unconverged before maxit: when no
# shifted Hessian can be factored, springs.c keeps the last iterate.)
stats() { # stats RESULT: the frame_stats numbers, space-separated
    h5dump -y -w 0 -d "$1/frame_stats" np2.h5 | awk '/^   DATA \{/ { on = 1; next }
        on && /^   \}/ { exit } on' | tr ',' '\n' | awk 'NF { print $1 + 0 }' | paste -sd' '
}
for t in fatcat self lion; do
    st=$(stats $R/$t/cat-poses)
    echo "frame_stats $t: $st"
    check "frame_stats of $t: 3 plausible rows" awk -v m=$maxit '{ if (NF != 9) exit 1
        for (i = 1; i <= 9; i += 3) if ($i < 1 || $i > m || ($(i+1) != 0 && $(i+1) != 1) ||
            $(i+2) < 0) exit 1 }' <<< "$st"
done
# frame_grad_norm: the final gradient norm of every frame, written (3
# finite entries >= 0, no NaN fill left), bit for bit the same at 1 rank x
# 2 threads.
gnorm() { # gnorm FILE RESULT: the frame_grad_norm values, one a line, as h5dump prints them
    h5dump -y -w 0 -m '%.17g' -d "$2/frame_grad_norm" "$1" | awk '/^   DATA \{/ { on = 1; next }
        on && /^   \}/ { exit } on' | tr ',' '\n' | awk 'NF { print $1 }'
}
for t in fatcat self lion; do
    g=$(gnorm np2.h5 $R/$t/cat-poses | paste -sd' ')
    echo "frame_grad_norm $t: $g"
    check "frame_grad_norm of $t: float64, 3 entries" bash -c "h5dump -H -d $R/$t/cat-poses/frame_grad_norm np2.h5 | grep -q 'H5T_IEEE_F64LE' && h5dump -H -d $R/$t/cat-poses/frame_grad_norm np2.h5 | grep -q 'DATASPACE  SIMPLE { ( 3 )'"
    check "frame_grad_norm of $t: 3 finite entries >= 0" awk '{ if (NF != 3) exit 1
        for (i = 1; i <= 3; i++) if ($i !~ /^[0-9.]+(e[-+]?[0-9]+)?$/) exit 1 }' <<< "$g"
    # What the converged flags say: a frame that met Newton's stopping
    # test (a step or an energy change, not a gradient test) ends in its
    # quadratic tail, its final gradient norm below 1e-5 (at most 1.3e-7 on
    # the nine reshaped-cat poses at the default settings, 6.6e-7 on this
    # fatcat's with max_iter 100, about 5e-12 for self here; the fatcat's
    # pose 9 ran out at 100 steps with 1.3e-5); a frame that ran out may
    # end anywhere.
    check "frame_grad_norm of $t: below 1e-5 in every converged frame" \
        awk -v s="$(stats $R/$t/cat-poses)" 'BEGIN { split(s, st, " ") }
            { for (i = 1; i <= 3; i++) if (st[3 * i - 1] == 1 && !($i + 0 < 1e-5)) exit 1 }' <<< "$g"
    if [ "$asan" = 0 ]; then
        check "frame_grad_norm of $t: the same bits at 2 ranks x 1 thread and 1 rank x 2 threads" \
            cmp <(gnorm np2.h5 $R/$t/cat-poses) <(gnorm np1t2.h5 $R/$t/cat-poses)
    fi
done
# Resume: a run of the fatcat alone that rank 0 of 2 fails in the frame
# loop (one frame a block: it fails after transferring its second frame,
# before writing it), resumed at 1 rank x 2 threads, writes the bits of the
# clean run: positions, frame_stats and frame_grad_norm.  (Not in the
# sanitizer pass.)
if [ "$asan" = 0 ]; then
    job flt "$T_FAT"
    sed -i 's/"block_frames": 8/"block_frames": 1/' flt.json
    set +e
    DTX_FAULT="transfer@0" OMP_NUM_THREADS=1 timeout 300 "${MPIRUN[@]}" -np 2 -x DTX_FAULT \
        "$DTX" run flt.json > flt.out 2> flt.err
    rc=$?
    set -e
    check "resume: the faulted run failed ($rc) and kept frames for --resume" bash -c \
        "test $rc -ne 0 -a $rc -ne 124 && grep -q 'flt.h5.partial is kept: [1-2] of 3 frames done' flt.err"
    OMP_NUM_THREADS=2 "${MPIRUN[@]}" -np 1 "$DTX" run --quiet --resume flt.json
    check "resume: the positions bit for bit" "$DTX" diff np2.h5 flt.h5 $R/fatcat/cat-poses --tol 0
    check "resume: frame_grad_norm bit for bit" \
        cmp <(gnorm np2.h5 $R/fatcat/cat-poses) <(gnorm flt.h5 $R/fatcat/cat-poses)
    check "resume: frame_stats the same" cmp <(h5dump -d $R/fatcat/cat-poses/frame_stats np2.h5 | grep '^ *(') \
        <(h5dump -d $R/fatcat/cat-poses/frame_stats flt.h5 | grep '^ *(')
    check "resume: the output validates" "$DTX" validate flt.h5
fi
check "summary: the worst final gradient norm" grep -q '"grad_norm_max": [0-9.e+-]*, "grad_norm_max_frame": [0-2]' np2.h5.summary.json
check "report: the final gradient norm per frame" test "$(grep -c '^Final gradient norm per frame:' report.md)" -eq 3
"$DTX" inspect np2.h5 > inspect.txt
check "inspect: the solves of each result" test "$(grep -c 'solves .* of 3 frames done converged; final gradient norm at most' inspect.txt)" -eq 3
"$DTX" inspect --json np2.h5 > inspect.json
check "inspect --json: the solves of self (3 converged, the largest norm and its frame)" "$PY" -c '
import json, sys
items = json.load(open("inspect.json"))["results"]
r = [i for i in items if i.get("path") == "/results/self/cat-poses"][0]["solves"]
sys.exit(0 if r["converged_frames"] == 3 and 0 <= r["grad_norm_max"] < 1e-5 and r["grad_norm_max_frame"] in (0, 1, 2) else 1)'
if [ "$asan" = 0 ]; then
    check "self converged in every frame" awk '{ exit ($2 == 1 && $5 == 1 && $8 == 1) ? 0 : 1 }' <<< "$(stats $R/self/cat-poses)"
    # The barrier keeps the fatcat's triangles right side up and the
    # unfolding penalty turns over those the sp04 start has folded.
    check "fatcat: no inverted triangle in any frame" awk '{ exit ($3 == 0 && $6 == 0 && $9 == 0) ? 0 : 1 }' <<< "$(stats $R/fatcat/cat-poses)"
fi

# The numbers, with h5py: self = the poses up to a translation; the lion
# within 6% of its diagonal (RMS, centroids removed) of sp04's; the fatcat
# keeps the fatcat's rest proportions (taller than the cat in every pose).
if [ "$asan" = 1 ]; then
    echo "skipped: the numeric checks (sanitizer build)"
elif "$PY" -c 'import h5py, numpy' 2> /dev/null; then
    out=$("$PY" - <<'PY'
import h5py, numpy as np
f = h5py.File("np2.h5", "r"); s = h5py.File("sp04.h5", "r"); i = h5py.File("in.h5", "r")
P = i["/sequences/cat-poses/positions"][...]
def diag(X): return np.linalg.norm(X.max(0) - X.min(0))
def rms(A, B):
    A = A - A.mean(0); B = B - B.mean(0)
    return np.sqrt(((A - B) ** 2).sum(1).mean())
S = f["/results/self/cat-poses/positions"][...]
d = diag(i["/meshes/cat/vertices"][...])
print("self %.3g" % max(rms(S[k], P[k]) / d for k in range(len(P))))
L = f["/results/lion/cat-poses/positions"][...]; L0 = s["/results/lion/cat-poses/positions"][...]
dl = diag(i["/meshes/lion/vertices"][...])
print("lion %.4f" % max(rms(L[k], L0[k]) / dl for k in range(len(L))))
F = f["/results/fatcat/cat-poses/positions"][...]
print("taller %d" % all(np.ptp(F[k][:, 1]) > 1.08 * np.ptp(P[k][:, 1]) for k in range(len(P))))
PY
)
    echo "$out"
    # With internal springs core.springs gets the poses to 5e-14; without
    # them (the cheap settings here) a nearly flat fold can settle mirrored:
    # 4.6e-4 of the diagonal when this test was written.
    check "self reproduces the poses (2e-3 of the diagonal)" awk '/^self/ { exit ($2 < 2e-3) ? 0 : 1 }' <<< "$out"
    check "lion within 6% of sp04's" awk '/^lion/ { exit ($2 < 0.06) ? 0 : 1 }' <<< "$out"
    check "fatcat keeps its longer legs" grep -q '^taller 1' <<< "$out"
else
    echo "skipped: the numeric checks (no python3-h5py)"
fi

# Refusals.
job nomark '{"file": "in.h5", "mesh": "/meshes/lion"}'
if "$DTX" run --quiet nomark.json 2> nomark.log; then
    echo "FAILED: a lion without markers was accepted"; fails=$((fails + 1))
else
    check "no markers: message names the target and the need" \
        grep -q 'target "lion" .*needs its markers' nomark.log
    check "no markers: no output left" test ! -e nomark.h5 -a ! -e nomark.h5.partial
fi
job pins '{"file": "in.h5", "mesh": "/meshes/lion", "markers": {"file": "in.h5", "path": "/markers/cat-lion"}, "pins": [{"vertex": 0, "position": [0, 0, 0]}]}'
if "$DTX" run --quiet pins.json 2> pins.log; then
    echo "FAILED: pins on a proxy target were accepted"; fails=$((fails + 1))
else
    check "pins on a proxy: refused naming the target" grep -q 'target "lion".*pins' pins.log
fi
job badlevels "$T_FAT" ', "levels": 12'
if "$DTX" run --quiet badlevels.json 2> badlevels.log; then
    echo "FAILED: levels 12 was accepted"; fails=$((fails + 1))
else
    check "bad levels: message names the field" grep -q 'badlevels.json: at /springs/levels' badlevels.log
fi

finish
