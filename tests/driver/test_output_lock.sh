#!/usr/bin/env bash
# Two `dtx run` on the same output (README, "Resume and the output"): the
# lock OUTPUT.lock lets one run write it; the other, fresh or --resume, is
# refused before it touches anything, with a message naming the first
# (host, pid, start time).  Started together and in both orders, with
# kill -9 of either at some point, the final name never holds an
# incomplete result: whenever OUTPUT exists, every result is complete,
# every frame_done is 1 and `dtx validate` passes.  A lock left by a
# killed run is replaced when its pid is gone on this host; a lock from
# another host is refused until --break-lock.  A leftover OUTPUT.partial.new
# (a kill before the new partial was renamed into place) is removed.
# No check depends on timing: the second run is started once the first
# holds the lock (polled) and while the first is stopped (SIGSTOP), and
# kills happen at states seen on disk.
set -euo pipefail
D="$DTX_BUILD/data/sumner-cat-lion"
W="$DTX_TESTDATA"
PY=/usr/bin/python3
NFRAMES=${DTX_TEST_LOCK_FRAMES:-600}
. "$DTX_SRC/tests/lib.sh"
cd "$W"
export OMP_NUM_THREADS=1

"$DTX" import mesh "$D/source/cat-reference.obj" -o in.h5 --name cat 2> /dev/null
"$DTX" import mesh "$D/target/lion-reference.obj" -o in.h5 --name lion 2> /dev/null
"$DTX" import sequence "$D"/source/cat-0[1-9].obj -o in.h5 --name poses --mesh /meshes/cat \
    2> /dev/null
"$DTX" import markers "$D/markers.csv" --index-base 0 -o in.h5 --name cat-lion \
    --source /meshes/cat --target /meshes/lion 2> /dev/null
# NFRAMES frames blended between the nine poses (h5py, layout v1): a run of
# a few seconds.
$PY - in.h5 "$NFRAMES" <<'PY'
import sys, h5py, numpy as np
path, n = sys.argv[1], int(sys.argv[2])
with h5py.File(path, "a") as f:
    P = f["/sequences/poses/positions"][...].astype(np.float64)
    nv = P.shape[1]
    g = f.create_group("/sequences/blend")
    t = np.arange(n)
    a, s = (t // 37) % 9, (t % 37) / 37.0
    d = ((1 - s)[:, None, None] * P[a] + s[:, None, None] * P[(a + 1) % 9]).astype("<f4")
    g.create_dataset("positions", data=d, chunks=(16, nv, 3))
    g["rest"] = h5py.SoftLink("/meshes/cat")
    g.attrs["rest_mesh"] = "/meshes/cat"
    g.attrs["nframes"] = np.int32(n)
PY
cat > job.json <<'JOB'
{"dtx_job": 1, "method": "sp04",
 "source": {"file": "in.h5", "mesh": "/meshes/cat", "sequences": ["/sequences/blend", "/sequences/poses"]},
 "targets": [{"name": "lion", "file": "in.h5", "mesh": "/meshes/lion",
              "markers": {"file": "in.h5", "path": "/markers/cat-lion"}}],
 "output": {"file": "out.h5", "block_frames": 32}}
JOB

# complete FILE: every result complete, every frame_done 1, positions finite;
# and the file validates.
cat > complete.py <<'PY'
import sys, h5py, numpy as np
bad = []
with h5py.File(sys.argv[1], "r") as f:
    n = 0
    for t in f["/results"]:
        for s in f["/results"][t]:
            r = f["/results"][t][s]
            n += 1
            if int(r.attrs.get("complete", 0)) != 1:
                bad.append("%s: complete = %r" % (r.name, r.attrs.get("complete")))
            done = r["frame_done"][...]
            if not (done == 1).all():
                bad.append("%s: %d of %d frames not done" % (r.name, int((done != 1).sum()), done.size))
            if not np.isfinite(r["positions"][...]).all():
                bad.append("%s: non-finite positions" % r.name)
    if n != 2:
        bad.append("%d results, expected 2" % n)
if bad:
    print("\n".join(bad))
sys.exit(1 if bad else 0)
PY
complete() {
    "$PY" complete.py "$1" && "$DTX" validate "$1" > /dev/null
}
# final_ok WHAT: out.h5 absent, or complete and valid.
final_ok() {
    if [ -e out.h5 ]; then check "$1: out.h5 exists, so it is complete and valid" complete out.h5
    else echo "ok: $1: no out.h5"; fi
}
# wait_for PATH PID: until PATH exists (or process PID has ended).
wait_for() {
    while [ ! -e "$1" ] && kill -0 "$2" 2> /dev/null; do sleep 0.02; done
}
lock_pid() { sed -n 's/^pid: //p' out.h5.lock 2> /dev/null; }
# wait_lock_of PID: until out.h5.lock names PID (or PID has ended).
wait_lock_of() {
    while [ "$(lock_pid)" != "$1" ] && kill -0 "$1" 2> /dev/null; do sleep 0.02; done
}
refused_naming() { # refused_naming ERRFILE PID
    grep -q "out.h5 is being written by another dtx run: host $(hostname), pid $2, started " "$1" &&
        grep -q -- "--break-lock" "$1"
}
reset() { rm -f out.h5 out.h5.partial out.h5.partial.new out.h5.lock out.h5.summary.json; }

# ---- 1. A runs; B (fresh), then C (--resume) start while A holds the lock,
# in that order and the reverse order of flags.
for second in "" "--resume"; do
    reset
    "$DTX" run --quiet job.json 2> a.err & a=$!
    wait_for out.h5.lock "$a"
    check "run A${second:+ (then $second)} holds the lock with its pid" test "$(lock_pid)" = "$a"
    kill -STOP "$a" 2> /dev/null || true
    set +e; "$DTX" run --quiet $second job.json 2> b.err; rc=$?; set -e
    kill -CONT "$a" 2> /dev/null || true
    check "second run ${second:-fresh} while A runs: refused (exit $rc)" test "$rc" -eq 1
    check "second run ${second:-fresh}: the message names A (host, pid, start time)" \
        refused_naming b.err "$a"
    set +e; wait "$a"; rc=$?; set -e
    check "run A exits 0 ($rc) after the refused run" test "$rc" -eq 0
    check "run A's out.h5 is complete and valid" complete out.h5
    check "run A released the lock" test ! -e out.h5.lock
done
head -n 1 b.err

# ---- 2. Started together, in both orders: one writes, the other is refused
# naming it.
for order in ab ba; do
    reset
    if [ $order = ab ]; then
        "$DTX" run --quiet job.json 2> x.err & x=$!; "$DTX" run --quiet job.json 2> y.err & y=$!
    else
        "$DTX" run --quiet job.json 2> y.err & y=$!; "$DTX" run --quiet job.json 2> x.err & x=$!
    fi
    set +e; wait "$x"; rx=$?; wait "$y"; ry=$?; set -e
    check "together ($order): exactly one run succeeds ($rx, $ry)" \
        test $((rx == 0 ? 1 : 0)) -ne $((ry == 0 ? 1 : 0))
    if [ "$rx" -eq 0 ]; then win=$x lose=y.err; else win=$y lose=x.err; fi
    check "together ($order): the refused run names the other" refused_naming $lose "$win"
    final_ok "together ($order)"
done

# ---- 3. kill -9 of the writer while a second run is refused: no out.h5;
# the lock it leaves is stale (its pid is gone on this host), so --resume
# replaces it, says so, and completes the partial.
for victim in fresh resume; do
    reset
    if [ $victim = resume ]; then
        # The writer is itself a --resume of a killed run's partial.
        "$DTX" run --quiet job.json 2> /dev/null & k=$!
        wait_for out.h5.partial "$k"; kill -9 "$k"; wait "$k" 2> /dev/null || true
        "$DTX" run --quiet --resume job.json 2> /dev/null & a=$!
    else
        "$DTX" run --quiet job.json 2> /dev/null & a=$!
    fi
    wait_lock_of "$a"
    wait_for out.h5.partial "$a"
    kill -STOP "$a" 2> /dev/null || true
    set +e; "$DTX" run --quiet job.json 2> b.err; rc=$?; set -e
    check "kill ($victim writer): the second run was refused (exit $rc)" test "$rc" -eq 1
    kill -9 "$a" 2> /dev/null || true
    wait "$a" 2> /dev/null || true
    final_ok "kill -9 of the $victim writer"
    check "kill ($victim writer): the partial is left, not renamed" test -e out.h5.partial
    set +e; "$DTX" run --resume job.json > /dev/null 2> c.err; rc=$?; set -e
    check "kill ($victim writer): --resume exits 0 ($rc)" test "$rc" -eq 0
    check "kill ($victim writer): --resume said it replaced the stale lock of pid $a" \
        grep -q "replaced the stale lock .*out.h5.lock of pid $a" c.err
    check "kill ($victim writer): out.h5 complete and valid after --resume" complete out.h5
    check "kill ($victim writer): no lock left" test ! -e out.h5.lock
done

# ---- 4. kill -9 of the refused run (as in the report that found the bug:
# B started after A, B killed) changes nothing of A's output.
reset
"$DTX" run --quiet job.json 2> /dev/null & a=$!
wait_for out.h5.partial "$a"
kill -STOP "$a" 2> /dev/null || true
"$DTX" run --quiet job.json 2> /dev/null & b=$!
kill -9 "$b" 2> /dev/null || true
wait "$b" 2> /dev/null || true
kill -CONT "$a" 2> /dev/null || true
set +e; wait "$a"; rc=$?; set -e
check "kill -9 of the second run: the first exits 0 ($rc)" test "$rc" -eq 0
check "kill -9 of the second run: out.h5 complete and valid" complete out.h5

# ---- 5. A lock from another host cannot be judged: refused, naming that
# host, until --break-lock.
reset
printf 'dtx output lock\nhost: node-17.example\npid: 4242\nstarted: 2026-01-02 03:04:05 UTC\n' \
    > out.h5.lock
set +e; "$DTX" run --quiet job.json 2> b.err; rc=$?; set -e
check "lock of another host: refused (exit $rc)" test "$rc" -eq 1
check "lock of another host: the message names host, pid and start time" \
    grep -q "host node-17.example, pid 4242, started 2026-01-02 03:04:05 UTC" b.err
check "lock of another host: nothing written" test ! -e out.h5.partial -a ! -e out.h5
check "lock of another host: the lock is kept" grep -q node-17 out.h5.lock
set +e; "$DTX" run --break-lock job.json > /dev/null 2> c.err; rc=$?; set -e
check "--break-lock: exits 0 ($rc) and says whose lock it removed" \
    grep -q "removed the lock .*host node-17.example, pid 4242" c.err
check "--break-lock: out.h5 complete and valid" complete out.h5
check "--break-lock: no lock left" test ! -e out.h5.lock

# ---- 6. A run killed between creating its partial and renaming it into
# place leaves OUTPUT.partial.new (never an unmarked OUTPUT.partial); the
# next run holding the lock removes it and finishes.
reset
echo "not HDF5: what a kill -9 inside H5Fcreate leaves" > out.h5.partial.new
set +e; "$DTX" run --quiet job.json 2> d.err; rc=$?; set -e
check "leftover OUTPUT.partial.new: the run exits 0 ($rc)" test "$rc" -eq 0
check "leftover OUTPUT.partial.new: removed" test ! -e out.h5.partial.new
check "leftover OUTPUT.partial.new: out.h5 complete and valid" complete out.h5

finish
