#!/usr/bin/env bash
# scripts/slurm/dtx-job.sbatch under a real Slurm: the test starts a one-node
# cluster of its own (slurmctld and slurmd from Debian's packages, its
# configuration, state and spool in the scratch directory, free ports,
# AuthType=auth/none so no munge is needed), then
#   1. submits the batch script (2 ranks through mpirun) and compares the
#      result with the same job run directly (dtx diff --tol 0);
#   2. submits a job array (--list: one array task per clip group, the
#      groups' jobs one after another, one correspondence store shared) and
#      compares each result;
#   3. requeues a long job mid-run (scontrol requeue, once frames are
#      marked done in its partial: the job is killed and queued again), and
#      checks that the requeued run resumed the partial (frames_skipped > 0,
#      restart count 1 in Slurm's log) and that its result equals an
#      uninterrupted run's.
# slurmd runs the jobs as root, so the test needs root; without Slurm or root
# it is skipped, except in CI (CI=true), where it fails.
set -euo pipefail
D="$DTX_BUILD/data/sumner-cat-lion"
W="$DTX_TESTDATA"
PY=/usr/bin/python3
SB="$DTX_SRC/scripts/slurm/dtx-job.sbatch"
. "$DTX_SRC/tests/lib.sh"
missing() {
    if [ "${CI:-}" = true ]; then
        echo "FAILED: $1 (CI runs this test: install Slurm with scripts/setup.sh, run as root)"
        exit 1
    fi
    echo "skipped: $1"
    exit 77
}
for c in slurmctld slurmd sbatch squeue scontrol; do
    command -v "$c" > /dev/null || missing "$c not found"
done
[ "$(id -u)" -eq 0 ] || missing "slurmd runs jobs as root here: run as root"

# ---- the cluster ------------------------------------------------------------
S=$W/slurm
mkdir -p "$S/state" "$S/spool" "$S/log"
free_port() { $PY -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'; }
ctl_port=$(free_port)
d_port=$(free_port)
while [ "$d_port" = "$ctl_port" ]; do d_port=$(free_port); done
host=$(hostname -s)
cat > "$S/slurm.conf" <<CONF
ClusterName=dtxtest
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$ctl_port
SlurmdPort=$d_port
AuthType=auth/none
CredType=cred/none
SlurmUser=root
SlurmdUser=root
StateSaveLocation=$S/state
SlurmdSpoolDir=$S/spool
SlurmctldPidFile=$S/slurmctld.pid
SlurmdPidFile=$S/slurmd.pid
SlurmctldLogFile=$S/log/slurmctld.log
SlurmdLogFile=$S/log/slurmd.log
# Every process of a job, whatever its process group (OpenMPI gives each
# rank its own), is found through the process tree.
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/builtin
MpiDefault=none
ReturnToService=2
JobRequeue=1
KillWait=5
MinJobAge=600
InactiveLimit=0
NodeName=$host NodeAddr=127.0.0.1 CPUs=$(nproc) State=UNKNOWN
PartitionName=dtx Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF=$S/slurm.conf
stop_slurm() {
    local f id p
    # No process of a job outlives the test, stopped or not.
    for id in $(squeue -h -o %A 2> /dev/null); do
        for p in $(scontrol listpids "$id" 2> /dev/null | awk 'NR > 1 { print $1 }'); do
            kill -CONT "$p" 2> /dev/null || true
            kill -KILL "$p" 2> /dev/null || true
        done
    done
    scancel --quiet --full "$(squeue -h -o %i 2> /dev/null | tr '\n' ' ')" 2> /dev/null || true
    for f in "$S/slurmd.pid" "$S/slurmctld.pid"; do
        [ -s "$f" ] && kill "$(cat "$f")" 2> /dev/null || true
    done
    sleep 0.5
    for f in "$S/slurmd.pid" "$S/slurmctld.pid"; do
        [ -s "$f" ] && kill -9 "$(cat "$f")" 2> /dev/null || true
    done
}
trap stop_slurm EXIT
slurmctld -i
slurmd
node_up() { sinfo -h -o %t 2> /dev/null | grep -qx idle; }
for _ in $(seq 100); do node_up && break; sleep 0.2; done
if ! node_up; then
    echo "FAILED: the one-node cluster did not come up; its logs:"
    tail -n 20 "$S"/log/*.log | sed 's/^/  | /'
    exit 1
fi
echo "cluster up: $(sinfo -h -o '%P %D node(s) %c cpus %t'), ports $ctl_port/$d_port"

# job_state ID: COMPLETED, RUNNING, PENDING, SUSPENDED, FAILED, ... (one line
# per task of an array)
job_state() { scontrol -o show job "$1" 2> /dev/null | sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p'; }
wait_done() { # wait_done ID...: every job (every array task) ended; 0 when all COMPLETED
    local id st all i
    for i in $(seq 1800); do
        all=1
        for id in "$@"; do
            st=$(job_state "$id")
            [ -n "$st" ] || { all=0; continue; }
            while read -r s; do
                case $s in
                    COMPLETED | FAILED | CANCELLED | TIMEOUT | NODE_FAIL | OUT_OF_MEMORY | BOOT_FAIL) ;;
                    *) all=0 ;;
                esac
            done <<< "$st"
        done
        [ $all -eq 1 ] && break
        sleep 0.2
    done
    for id in "$@"; do
        job_state "$id" | grep -qvx COMPLETED &&
            return 1
    done
    return 0
}
submit() { # submit SBATCH_ARGS...: the job id
    sbatch --parsable "$@" | cut -d';' -f1
}
export DTX DTX_LAUNCH=mpirun OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1

# ---- inputs -------------------------------------------------------------------
cd "$W"
"$DTX" import mesh "$D/source/cat-reference.obj" -o in.h5 --name cat 2> /dev/null
"$DTX" import mesh "$D/target/lion-reference.obj" -o in.h5 --name lion 2> /dev/null
"$DTX" import markers "$D/markers.csv" --index-base 0 -o in.h5 --name cat-lion \
    --source /meshes/cat --target /meshes/lion 2> /dev/null
for k in 1 2 3 4 5 6 7 8 9; do
    "$DTX" import sequence "$D/source/cat-0$k.obj" -o in.h5 --name "clip$k" --mesh /meshes/cat 2> /dev/null
done
"$DTX" import sequence "$D"/source/cat-0[1-9].obj -o in.h5 --name poses --mesh /meshes/cat \
    --dtype float64 2> /dev/null
# A long sequence for the requeue: frame t blends pose (t / 37) mod 9 into the next.
NFRAMES=3000
[ "${DTX_SANITIZED:-0}" = 1 ] && NFRAMES=1000 # each frame several times slower there
NFRAMES=${DTX_TEST_SLURM_FRAMES:-$NFRAMES}
$PY - in.h5 "$NFRAMES" <<'PY'
import sys, h5py, numpy as np
path, n = sys.argv[1], int(sys.argv[2])
with h5py.File(path, "a") as f:
    P = f["/sequences/poses/positions"][...].astype(np.float64)
    g = f.create_group("/sequences/blend")
    t = np.arange(n)
    a, s = (t // 37) % 9, (t % 37) / 37.0
    w = (s * s * (3 - 2 * s))[:, None, None]
    g.create_dataset("positions", data=((1 - w) * P[a] + w * P[(a + 1) % 9]).astype("<f4"),
                     chunks=(16, P.shape[1], 3))
    g["rest"] = h5py.SoftLink("/meshes/cat")
    g.attrs["rest_mesh"] = "/meshes/cat"
    g.attrs["nframes"] = np.int32(n)
PY
job() { # job NAME SEQUENCES(JSON list) [MORE KEYS]: NAME.json writing NAME.h5
    cat > "$1.json" <<JOB
{"dtx_job": 1, "method": "sp04", ${3:-}
 "source": {"file": "in.h5", "mesh": "/meshes/cat", "sequences": $2},
 "targets": [{"name": "lion", "file": "in.h5", "mesh": "/meshes/lion",
              "markers": {"file": "in.h5", "path": "/markers/cat-lion"}}],
 "output": {"file": "$1.h5", "dtype": "float32", "block_frames": 32}}
JOB
}
direct() { # direct NAME: the job run directly (no Slurm) into NAME-direct.h5
    sed "s/\"$1.h5\"/\"$1-direct.h5\"/" "$1.json" > "$1-direct.json"
    OMP_NUM_THREADS=1 mpirun --oversubscribe --bind-to none -np 2 "$DTX" run --quiet "$1-direct.json"
}
same() { # same NAME RESULT [DIRECT]: NAME.h5 equals NAME-direct.h5 (or DIRECT) bit for bit
    "$DTX" diff "$1.h5" "${3:-$1-direct.h5}" "$2" --tol 0 > /dev/null
}

# ---- 1. the batch script ----------------------------------------------------
job poses '["/sequences/poses"]'
direct poses
id=$(submit --ntasks-per-node=2 --cpus-per-task=1 --time=10 "$SB" poses.json --quiet)
echo "batch job $id submitted"
check "batch job $id completed" wait_done "$id"
log=dtx-dtx-$id.out
sed 's/^/  | /' "$log" || true
check "batch: Slurm's log says dtx run exited with 0" grep -q "dtx run poses.json exited with 0" "$log"
check "batch: result equals the direct run's (dtx diff --tol 0)" same poses /results/lion/poses
check "batch: the result validates" "$DTX" validate poses.h5 > /dev/null

# ---- 2. a job array, one task per clip group ----------------------------------
# Three groups of clips: task 1 runs clip1..clip3 one after another, task 2
# clip4 and clip5, task 3 clip6.
# The clips share one correspondence store.
for k in 1 2 3 4 5 6; do
    job "clip$k" "[\"/sequences/clip$k\"]" '"correspondence_store": "store",'
done
printf '%s\n' "clip1.json clip2.json clip3.json" "clip4.json clip5.json" "clip6.json" > groups.txt
id=$(submit --array=1-3 --ntasks=1 --cpus-per-task=1 --time=10 "$SB" --list groups.txt --quiet)
echo "array job $id submitted (3 tasks)"
check "array job $id: every task completed" wait_done "$id"
# The direct run: all six clips in one job (each result is the same whatever
# else a job holds).
job clips '["/sequences/clip1", "/sequences/clip2", "/sequences/clip3", "/sequences/clip4", "/sequences/clip5", "/sequences/clip6"]'
direct clips
for k in 1 2 3 4 5 6; do
    check "array: clip$k equals the direct run's" same "clip$k" "/results/lion/clip$k" clips-direct.h5
done
corr_of() { $PY -c 'import json, sys; print(json.load(open(sys.argv[1]))["correspondences"]["lion"])' "$1"; }
for k in 1 2 3 4 5 6; do
    eval "corr$k=\$(corr_of clip$k.h5.summary.json)"
done
echo "array: correspondences: $corr1 $corr2 $corr3 | $corr4 $corr5 | $corr6"
# A group's later jobs find the store filled by its first; task 3 starts when
# a core frees, after task 1 or 2 stored it; tasks 1 and 2 may both compute.
check "array: clip2, clip3, clip5 and clip6 take the correspondence from the store" \
    test "$corr2 $corr3 $corr5 $corr6" = "store store store store"
check "array: one store file for the one character" test "$(ls store | grep -c '\.h5$')" -eq 1
check "array: 3 task logs, each naming its group's jobs" \
    test "$(grep -l 'exited with 0' dtx-dtx-*.out | wc -l)" -ge 4
# A line past the end of the list is an error naming the line.
id=$(submit --array=4 --ntasks=1 --cpus-per-task=1 --time=10 "$SB" --list groups.txt)
wait_done "$id" || true
check "array: a task past the end of the list fails, naming the line" \
    grep -q "line 4 of groups.txt names no job" dtx-dtx-*.out

# ---- 3. requeued mid-run, resumed -------------------------------------------------
job blend '["/sequences/blend"]'
direct blend
frames_done() { # frames marked done in blend.h5.partial (-1: not readable now)
    $PY - << 'PY'
import h5py, numpy as np
try:
    n = [0]
    with h5py.File("blend.h5.partial", "r") as f:
        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and name.endswith("frame_done"):
                n[0] += int(np.count_nonzero(obj[...] == 1))
        f.visititems(visit)
    print(n[0])
except Exception:
    print(-1)
PY
}
id=$(submit --ntasks=1 --cpus-per-task=1 --time=10 "$SB" blend.json --quiet)
echo "long job $id submitted ($NFRAMES frames, 1 rank)"
# Let it run in short steps, its processes stopped in between (SIGSTOP to
# every pid Slurm lists for it; not scontrol suspend, whose SIGTSTP mpirun
# forwards to its ranks asynchronously, sometimes after Slurm's SIGCONT,
# which leaves them stopped), until its partial has frames marked done;
# then let it go on and requeue it while it runs (Slurm kills it and
# queues it again).
job_pids() { scontrol listpids "$1" 2> /dev/null | awk 'NR > 1 { print $1 }'; }
signal_job() { # signal_job SIGNAL ID: the signal to every process of the job
    local p
    for p in $(job_pids "$2"); do kill "-$1" "$p" 2> /dev/null || true; done
}
stopped=0
for _ in $(seq 600); do
    st=$(job_state "$id")
    [ "$st" = COMPLETED ] && break
    if [ "$st" = RUNNING ] && [ -e blend.h5.partial ]; then
        signal_job STOP "$id"
        n=$(frames_done)
        signal_job CONT "$id"
        if [ "$n" -gt 0 ] && [ "$n" -lt "$NFRAMES" ]; then
            stopped=$n
            break
        fi
    fi
    sleep 0.1
done
echo "job $id had $stopped of $NFRAMES frames marked done when requeued"
check "long job requeued mid-run (frames done in its partial)" test "$stopped" -gt 0
# Slurm delays a requeued job's start by two minutes: start it sooner, but
# only once the killed instance is gone and a new second has begun: slurmd
# refuses to launch a job whose credential is not newer, in whole seconds,
# than the one it revoked at the kill ("Job credential revoked"; seen in a
# CI run that restarted it 0.3 s after the requeue, in the same second).
scontrol requeue "$id"
started=0
for _ in $(seq 600); do
    if [ "$(job_state "$id")" = PENDING ] && [ -z "$(job_pids "$id")" ]; then
        sleep 1.1
        scontrol update JobId="$id" StartTime=now 2> /dev/null && started=1
        break
    fi
    sleep 0.1
done
check "requeued job $id pending, its killed instance gone, its start moved to now" \
    test $started -eq 1
f0=$fails
check "requeued job $id completed" wait_done "$id"
[ "$fails" -eq "$f0" ] || grep -h "JobId=$id" "$S"/log/slurmctld.log | tail -8 | sed 's/^/  | /' || true
log=dtx-dtx-$id.out
sed 's/^/  | /' "$log" || true
check "requeue: Slurm's log shows the restart (restart 1)" grep -q "restart 1," "$log"
check "requeue: result equals the uninterrupted run's (dtx diff --tol 0)" same blend /results/lion/blend
check "requeue: the result validates" "$DTX" validate blend.h5 > /dev/null
check "requeue: no partial left" test ! -e blend.h5.partial
skipped=$($PY -c 'import json; print(json.load(open("blend.h5.summary.json"))["frames_skipped"])')
echo "requeued run: frames_skipped $skipped"
check "requeue: the requeued run resumed the partial (frames_skipped >= the $stopped done)" \
    test "$skipped" -ge "$stopped"
finish
