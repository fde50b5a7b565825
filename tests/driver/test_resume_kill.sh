#!/usr/bin/env bash
# Crash and resume: `dtx run` under `mpirun -np 2` is killed with SIGKILL
# (mpirun and every rank at once) at several points of a run of a few
# seconds, then `dtx run --resume` finishes it at another rank count. The
# contract:
#   - a killed run leaves no OUTPUT (an old OUTPUT stays as it was), at most
#     OUTPUT.partial and its OUTPUT.lock (stale: its pid is gone, so
#     --resume replaces it);
#   - `dtx run --resume JOB` continues OUTPUT.partial and gives results
#     bitwise equal to an uninterrupted run (positions, residual, frame_done
#     and the correspondence), a valid file, no .partial left behind, and in
#     the summary "frames_skipped" = the frames marked done in the partial
#     (read with h5py after the kill; > 0 for a crash in the frame loop) and
#     "frames" (computed in this run) + "frames_skipped" = all frames;
#   - a plain `dtx run` (no --resume) after a kill discards the stale partial
#     (frames_skipped 0) and gives the same results;
#   - `--resume` of a partial written by a job with other correspondence
#     parameters must not mix the two: it either refuses with a message, or
#     recomputes everything (frames_skipped 0): no frame and no
#     correspondence of the old job may be left in the result.
# Kill points: fixed fractions of the reference run's wall time plus one
# random fraction (the seed is printed; DTX_TEST_SEED=N repeats it); under
# the sanitizers (DTX_SANITIZED=1) only 0.5 and the random one.  And one
# crash at a known point, in the frame loop with frames written, whatever
# the machine's speed: rank 0 dies of SIGKILL there (DTX_FAULT=...:kill).
set -euo pipefail
D="$DTX_BUILD/data/sumner-cat-lion"
W="$DTX_TESTDATA"
PY=/usr/bin/python3
NFRAMES=${DTX_TEST_RESUME_FRAMES:-2000}
. "$DTX_SRC/tests/lib.sh"
quiet() { "$@" > /dev/null; } # quiet COMMAND...: its stdout discarded
now_ms() { echo $(( $(date +%s%N) / 1000000 )); }
sleep_until() { # sleep_until T0_MS DELAY_MS: sleeps until T0 + DELAY (milliseconds)
    local left=$(( $1 + $2 - $(now_ms) ))
    [ "$left" -le 0 ] || sleep "$(printf '%d.%03d' $((left / 1000)) $((left % 1000)))"
}
t_start=$SECONDS

# ---- inputs: the cat, the lion, the markers, NFRAMES blended cat frames ------
"$DTX" import mesh "$D/source/cat-reference.obj" -o "$W/in.h5" --name cat 2> /dev/null
"$DTX" import mesh "$D/target/lion-reference.obj" -o "$W/in.h5" --name lion 2> /dev/null
"$DTX" import sequence "$D"/source/cat-0[1-9].obj -o "$W/in.h5" --name poses --mesh /meshes/cat \
    --dtype float64 2> /dev/null
"$DTX" import markers "$D/markers.csv" --index-base 0 -o "$W/in.h5" --name cat-lion \
    --source /meshes/cat --target /meshes/lion 2> /dev/null
# The blended sequence is written with h5py in layout v1 (schemas/hdf5-layout-v1.md):
# frame t blends pose a = (t / 37) mod 9 into pose a + 1, every frame distinct.
$PY - "$W/in.h5" "$NFRAMES" <<'PY'
import sys, h5py, numpy as np
path, n = sys.argv[1], int(sys.argv[2])
with h5py.File(path, "a") as f:
    P = f["/sequences/poses/positions"][...].astype(np.float64)
    nv = P.shape[1]
    g = f.create_group("/sequences/blend")
    d = g.create_dataset("positions", (n, nv, 3), dtype="<f4", chunks=(16, nv, 3))
    for t0 in range(0, n, 256):
        t = np.arange(t0, min(n, t0 + 256))
        a = (t // 37) % 9
        s = (t % 37) / 37.0
        w = (s * s * (3 - 2 * s))[:, None, None]
        d[t0:t0 + len(t)] = ((1 - w) * P[a] + w * P[(a + 1) % 9]).astype("<f4")
    g["rest"] = h5py.SoftLink("/meshes/cat")
    g.attrs["rest_mesh"] = "/meshes/cat"
    g.attrs["nframes"] = np.int32(n)
PY
check "input file (with the h5py-written sequence) validates" quiet "$DTX" validate "$W/in.h5"

job() { # job NAME OUTPUT [W_IDENTITY]
    cat > "$W/$1.json" <<JOB
{
  "dtx_job": 1,
  "method": "sp04",
  "source": {"file": "in.h5", "mesh": "/meshes/cat", "sequences": ["/sequences/blend"]},
  "targets": [{"name": "lion", "file": "in.h5", "mesh": "/meshes/lion",
               "markers": {"file": "in.h5", "path": "/markers/cat-lion"}}],
  "output": {"file": "$2", "dtype": "float64", "block_frames": 64},
  "sp04": {"w_identity": ${3:-0.001}}
}
JOB
}

cat > "$W/check.py" <<'PY'
import json, sys
import h5py, numpy as np
R = "/results/lion/blend"

def same(a, b):
    """The result and the correspondence bitwise equal, the result complete."""
    bad = []
    with h5py.File(a, "r") as fa, h5py.File(b, "r") as fb:
        names = [R + "/positions", R + "/residual", R + "/frame_done",
                 "/correspondences/lion/pairs", "/correspondences/lion/deformed_source"]
        for n in names:
            x, y = fa[n], fb[n]
            if x.dtype != y.dtype or x.shape != y.shape:
                bad.append("%s: %s %s vs %s %s" % (n, x.dtype, x.shape, y.dtype, y.shape))
                continue
            step = 256 if x.ndim == 3 else x.shape[0]
            for i in range(0, x.shape[0], step):
                xv, yv = x[i:i + step], y[i:i + step]
                if xv.tobytes() != yv.tobytes():
                    if x.ndim == 3:
                        fr = [i + k for k in range(len(xv)) if xv[k].tobytes() != yv[k].tobytes()]
                        bad.append("%s: frames %d..%d differ (%d of them in this block)"
                                   % (n, fr[0], fr[-1], len(fr)))
                    else:
                        bad.append("%s differs" % n)
                    break
        if int(fb[R].attrs["complete"]) != 1:
            bad.append("%s: complete = %r" % (R, fb[R].attrs["complete"]))
    if bad:
        print("  " + "\n  ".join(bad))
    return 1 if bad else 0

def done_in_partial(path):
    """Frames marked done in an interrupted output: -1 if unreadable."""
    try:
        total = [0]
        with h5py.File(path, "r") as f:
            def visit(name, obj):
                if isinstance(obj, h5py.Dataset) and name.endswith("frame_done"):
                    total[0] += int(np.count_nonzero(obj[...] == 1))
            f.visititems(visit)
        return total[0]
    except Exception:
        return -1

def nothing_shared(a, b):
    """No frame of result b and no correspondence dataset equal to a's."""
    bad = []
    with h5py.File(a, "r") as fa, h5py.File(b, "r") as fb:
        x, y = fa[R + "/positions"], fb[R + "/positions"]
        if x.shape != y.shape:
            bad.append("positions: shapes %s vs %s" % (x.shape, y.shape))
        else:
            equal = []
            for i in range(0, x.shape[0], 256):
                xv, yv = x[i:i + 256], y[i:i + 256]
                equal += [i + k for k in range(len(xv)) if xv[k].tobytes() == yv[k].tobytes()]
            if equal:
                bad.append("%d frames equal to the old job's, first %d, last %d"
                           % (len(equal), equal[0], equal[-1]))
        for n in ("pairs", "deformed_source"):
            p = "/correspondences/lion/" + n
            if fa[p][...].tobytes() == fb[p][...].tobytes():
                bad.append(p + " is the old job's")
        if int(fb[R].attrs["complete"]) != 1:
            bad.append("%s: complete = %r" % (R, fb[R].attrs["complete"]))
    if bad:
        print("  " + "\n  ".join(bad))
    return 1 if bad else 0

def counts(path):
    """'frames frames_skipped' of a run summary."""
    s = json.load(open(path))
    f, k = s.get("frames"), s.get("frames_skipped")
    if not isinstance(f, int) or not isinstance(k, int):
        return "summary %s: frames %r, frames_skipped %r" % (path, f, k)
    return "%d %d" % (f, k)

cmd = sys.argv[1]
if cmd == "nothing_shared":
    sys.exit(nothing_shared(sys.argv[2], sys.argv[3]))
if cmd == "same":
    sys.exit(same(sys.argv[2], sys.argv[3]))
if cmd == "frames_done":
    print(done_in_partial(sys.argv[2]))
    sys.exit(0)
if cmd == "counts":
    print(counts(sys.argv[2]))
    sys.exit(0)
sys.exit("check.py: unknown command " + cmd)
PY

# ---- process control ------------------------------------------------------
# The run goes into a session of its own (setsid); OpenMPI puts every rank in
# a process group of its own, but they stay in mpirun's session, so the kill
# takes every process of that session, by pid, at once.
session_pids() { ps -eo pid=,sid=,stat= | awk -v s="$1" '$2 == s && $3 !~ /^Z/ { print $1 }'; }
start_bg() { # start_bg NRANKS LOG ARGS...: sets BG to the session id
    local np=$1 log=$2; shift 2
    OMP_NUM_THREADS=1 setsid mpirun --oversubscribe --bind-to none -np "$np" \
        "$DTX" run --quiet "$@" > "$log" 2>&1 &
    BG=$!
}
kill_bg() { # kill_bg: SIGKILL to the whole session of BG; 0 if it was still running
    local pids running=1 i
    pids=$(session_pids "$BG")
    [ -n "$pids" ] || running=0
    # shellcheck disable=SC2086
    [ -z "$pids" ] || kill -9 $pids 2> /dev/null || true
    wait "$BG" 2> /dev/null || true
    for i in $(seq 100); do
        [ -z "$(session_pids "$BG")" ] && break
        sleep 0.1
    done
    if [ -n "$(session_pids "$BG")" ]; then
        echo "  processes of the killed run still alive: $(session_pids "$BG")"
        return 2
    fi
    return $((1 - running))
}
skipped_ok() { # skipped_ok "FRAMES SKIPPED" DONE_IN_PARTIAL (-1: partial unreadable)
    local skipped=${1#* }
    [[ $skipped =~ ^[0-9]+$ ]] || return 1
    [ "$2" -lt 0 ] || [ "$skipped" -eq "$2" ]
}
all_frames() { # all_frames "FRAMES SKIPPED": every frame computed once or skipped
    [[ $1 =~ ^[0-9]+\ [0-9]+$ ]] && [ $(( ${1% *} + ${1#* } )) -eq "$NFRAMES" ]
}
refused_cleanly() { # refused_cleanly LOG OUTPUT: an error message, no OUTPUT
    grep -q "dtx: error" "$1" && [ ! -e "$2" ]
}
leftovers() { # leftovers OUTPUT: temporary or partial files of OUTPUT
    local f
    for f in "$1".*; do
        [ -e "$f" ] && [[ $f != *.summary.json ]] && echo "${f##*/}"
    done
    return 0
}

# ---- the reference --------------------------------------------------------
job ref ref.h5
job k k.h5
t0=$(now_ms)
OMP_NUM_THREADS=1 mpirun --bind-to none -np 2 "$DTX" run --quiet "$W/ref.json"
ref_ms=$(( $(now_ms) - t0 ))
echo "reference run: $NFRAMES frames, 2 ranks, ${ref_ms} ms"
check "reference validates" quiet "$DTX" validate "$W/ref.h5"

seed=${DTX_TEST_SEED:-$(( $(date +%s) % 100000 ))}
RANDOM=$seed
random_frac=$(awk -v r=$((RANDOM % 1000)) 'BEGIN { printf "%.3f", 0.10 + 0.85 * r / 1000 }')
echo "random kill point: seed $seed (DTX_TEST_SEED=$seed repeats it): fraction $random_frac"

# ---- kill, then resume ----------------------------------------------------
# The early points fall before the output exists (start-up, correspondence),
# the later ones in the frame loop.
i=0
kill_point() { # kill_point FRACTION: kill a run at FRACTION of ref_ms, then resume
    local frac=$1 delay_ms t0 rc
    i=$((i + 1))
    rm -f "$W/k.h5" "$W/k.h5.partial" "$W/k.h5.summary.json"
    delay_ms=$(awk -v f="$frac" -v t="$ref_ms" 'BEGIN { printf "%d", f * t }')
    t0=$(now_ms)
    start_bg 2 "$W/kill$i.log" "$W/k.json"
    sleep_until "$t0" "$delay_ms"
    rc=0
    kill_bg || rc=$?
    check "kill $i: no process of the killed run survives" test $rc -ne 2
    if [ $rc -ne 0 ]; then
        # Too late on a busy machine: the run had finished. Not a kill point.
        echo "kill $i at ${delay_ms} ms (fraction $frac): the run had already ended"
        return 0
    fi
    if [ -e "$W/k.h5" ]; then
        # Killed after the final rename (mpirun still winding down): the
        # output then has to be the complete result.
        echo "kill $i at ${delay_ms} ms (fraction $frac): after the output was renamed into place"
        check "kill $i: the OUTPUT there is complete: bitwise equal to the reference" \
            $PY "$W/check.py" same "$W/ref.h5" "$W/k.h5"
        check "kill $i: the OUTPUT there validates" quiet "$DTX" validate "$W/k.h5"
        return 0
    fi
    echo "kill $i at ${delay_ms} ms (fraction $frac of the reference): killed"
    resume_check
}
resume_check() { # resume_check: the leftovers of killed run i, then --resume; sets done_frames, counts
    local np t0 rc
    np=$(( i % 2 ? 1 : 3 ))
    # (The killed run's OUTPUT.lock stays; --resume replaces it as stale.)
    check "kill $i: nothing but OUTPUT.partial and OUTPUT.lock left" \
        test -z "$(leftovers "$W/k.h5" | grep -vxE 'k\.h5\.(partial|lock)' || true)"
    done_frames=0
    [ -e "$W/k.h5.partial" ] && done_frames=$($PY "$W/check.py" frames_done "$W/k.h5.partial")
    echo "  left: $(leftovers "$W/k.h5" | tr '\n' ' ')(frames marked done in it: $done_frames)"

    t0=$(now_ms)
    rc=0
    OMP_NUM_THREADS=1 mpirun --oversubscribe --bind-to none -np $np "$DTX" run --resume --quiet \
        --summary "$W/resume$i.json" "$W/k.json" || rc=$?
    echo "  resume at $np rank(s): $(( $(now_ms) - t0 )) ms"
    check "kill $i: dtx run --resume at $np rank(s) succeeds" test $rc -eq 0
    check "kill $i: resumed result bitwise equal to the reference" \
        $PY "$W/check.py" same "$W/ref.h5" "$W/k.h5"
    check "kill $i: resumed output validates" quiet "$DTX" validate "$W/k.h5"
    check "kill $i: no partial or temporary file left" test -z "$(leftovers "$W/k.h5")"
    counts=$($PY "$W/check.py" counts "$W/resume$i.json" 2>&1 || true)
    echo "  summary: frames computed, frames_skipped: $counts"
    check "kill $i: frames_skipped = the frames marked done in the partial" \
        skipped_ok "$counts" "$done_frames"
    check "kill $i: frames computed + frames_skipped = $NFRAMES" all_frames "$counts"
    rm -f "$W/k.h5.partial" "$W"/k.h5.tmp*
}
# The plain pass kills at every point; the sanitizer pass (each run several
# times slower) checks the same resume path for memory errors at two.
fractions="0.2 0.5 0.7 0.85 $random_frac"
[ "${DTX_SANITIZED:-0}" = 1 ] && fractions="0.5 $random_frac"
for frac in $fractions; do
    kill_point "$frac"
done
# Where the kills above fall depends on the machine's speed: on a busy one
# none may reach the frame loop.  One crash at a known point does: rank 0
# dies of SIGKILL in the frame loop with half of its blocks written
# (DTX_FAULT=transfer@0:kill), mpirun takes the other rank down, and the
# resume must skip the frames marked done.
i=$((i + 1))
rm -f "$W/k.h5" "$W/k.h5.partial" "$W/k.h5.summary.json"
DTX_FAULT=transfer@0:kill OMP_NUM_THREADS=1 setsid mpirun --oversubscribe --bind-to none \
    -np 2 -x DTX_FAULT "$DTX" run --quiet "$W/k.json" > "$W/kill$i.log" 2>&1 &
BG=$!
rc=0
wait "$BG" || rc=$?
check "kill $i: a rank killed in the frame loop ends the run with a failure" test $rc -ne 0
kill_bg || true
check "kill $i: no process of the crashed run survives" test -z "$(session_pids "$BG")"
check "kill $i: no OUTPUT" test ! -e "$W/k.h5"
echo "kill $i: rank 0 killed itself in the frame loop (mpirun exit $rc)"
resume_check
check "kill $i: frames marked done in the partial (rank 0 wrote half its blocks)" \
    test "$done_frames" -gt 0
check "kill $i: the resume skipped them (frames_skipped > 0)" test "${counts#* }" -gt 0

# ---- kill over an old output, then a plain run ------------------------------
cp "$W/ref.h5" "$W/k.h5"
delay_ms=$(( ref_ms / 2 ))
t0=$(now_ms)
start_bg 2 "$W/kill-plain.log" "$W/k.json"
sleep_until "$t0" "$delay_ms"
rc=0
kill_bg || rc=$?
echo "kill over an old output at ${delay_ms} ms: $([ $rc -eq 0 ] && echo killed || echo "ended (rc $rc)")"
if [ $rc -eq 0 ] && [ -e "$W/k.h5.partial" ]; then
    check "old OUTPUT unchanged by the killed run" cmp -s "$W/ref.h5" "$W/k.h5"
else
    # The run had finished (renamed its output into place) before the kill:
    # it replaced OUTPUT with a whole one.
    check "old OUTPUT replaced by the finished run: bitwise equal data" \
        $PY "$W/check.py" same "$W/ref.h5" "$W/k.h5"
fi
done_frames=0
[ -e "$W/k.h5.partial" ] && done_frames=$($PY "$W/check.py" frames_done "$W/k.h5.partial")
echo "  left: $(leftovers "$W/k.h5" | tr '\n' ' ')(frames marked done in the partial: $done_frames)"
# The partial is created as k.h5.partial.new with its mark and renamed, so
# however early the kill came, a partial there is one dtx recognises (and
# a plain run discards it).
if [ -e "$W/k.h5.partial" ]; then
    check "a partial left by the kill carries dtx's mark" \
        bash -c "h5dump -a /dtx_partial_of '$W/k.h5.partial' > /dev/null 2>&1"
fi
plain_run() {
    OMP_NUM_THREADS=1 mpirun --oversubscribe --bind-to none -np 3 "$DTX" run --quiet \
        --summary "$W/plain.json" "$W/k.json" 2> "$W/plain.log"
}
rc=0
plain_run || rc=$?
[ $rc -eq 0 ] || sed 's/^/  | /' "$W/plain.log"
check "plain run after the kill succeeds" test $rc -eq 0
check "plain run: result bitwise equal to the reference" $PY "$W/check.py" same "$W/ref.h5" "$W/k.h5"
check "plain run: output validates" quiet "$DTX" validate "$W/k.h5"
check "plain run: stale partial discarded (frames_skipped 0)" \
    test "$($PY "$W/check.py" counts "$W/plain.json" 2>&1)" = "$NFRAMES 0"
check "plain run: no partial or temporary file left" test -z "$(leftovers "$W/k.h5")"

# ---- --resume of a partial from other parameters ------------------------------
# Job k is killed with w_identity 0.001, then resumed with w_identity 0.3:
# another correspondence, so no frame of the result may equal the frame of
# the 0.001 reference (which is what a resume that kept the old frames gives).
rm -f "$W/k.h5" "$W/k.h5.partial" "$W"/k.h5.tmp*
delay_ms=$(( ref_ms * 7 / 10 ))
t0=$(now_ms)
start_bg 2 "$W/kill-other.log" "$W/k.json"
sleep_until "$t0" "$delay_ms"
kill_bg || true
echo "other parameters: killed job k (w_identity 0.001) at ${delay_ms} ms; left:" \
    "$(leftovers "$W/k.h5" | tr '\n' ' ')"
job k k.h5 0.3
rc=0
OMP_NUM_THREADS=1 mpirun -np 1 "$DTX" run --resume --quiet --summary "$W/other.json" \
    "$W/k.json" 2> "$W/other.log" || rc=$?
if [ $rc -ne 0 ]; then
    grep 'dtx: error' "$W/other.log" | sed 's/^/  | /' || true
    check "--resume with other parameters: refused with a message, no OUTPUT" \
        refused_cleanly "$W/other.log" "$W/k.h5"
    # (A partial killed before HDF5 wrote its superblock is not recognised
    # as dtx's and is left for the user, as the message says.)  Its remedy
    # works: remove it, run again.
    rm -f "$W/k.h5.partial"
    check "--resume with other parameters: after removing the partial, a plain run succeeds" \
        quiet env OMP_NUM_THREADS=1 mpirun -np 1 "$DTX" run --quiet "$W/k.json"
else
    check "--resume with other parameters: no frame and no correspondence kept from the old job" \
        $PY "$W/check.py" nothing_shared "$W/ref.h5" "$W/k.h5"
    check "--resume with other parameters: output validates" quiet "$DTX" validate "$W/k.h5"
    check "--resume with other parameters: nothing reused (frames_skipped 0)" \
        test "$($PY "$W/check.py" counts "$W/other.json" 2>&1)" = "$NFRAMES 0"
fi

check "the bitwise comparison tells the two jobs' results apart" \
    bash -c "[ -e '$W/k.h5' ] && ! $PY '$W/check.py' same '$W/ref.h5' '$W/k.h5' > /dev/null"

echo "runtime $((SECONDS - t_start)) s"
finish
