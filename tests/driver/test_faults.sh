#!/usr/bin/env bash
# Faults during a run: an error on one rank of three ends the whole job
# promptly with that rank's message and a non-zero exit, at every phase; an
# output that cannot be written (file-size limit) fails cleanly; in both
# cases an earlier complete output stays exactly as it was and no OUTPUT
# appears that is not complete.
set -euo pipefail
D="$DTX_BUILD/data/sumner-cat-lion"
W="$DTX_TESTDATA"
. "$DTX_SRC/tests/lib.sh"
rm -rf "${W:?}"/*
"$DTX" import mesh "$D/source/cat-reference.obj" -o "$W/in.h5" --name cat
"$DTX" import mesh "$D/target/lion-reference.obj" -o "$W/in.h5" --name lion
"$DTX" import sequence "$D"/source/cat-0[1-9].obj "$D"/source/cat-0[1-9].obj \
    "$D"/source/cat-0[1-9].obj -o "$W/in.h5" --name poses --mesh /meshes/cat
"$DTX" import markers "$D/markers.csv" --index-base 0 -o "$W/in.h5" --name m \
    --source /meshes/cat --target /meshes/lion
cat > "$W/job.json" <<JOB
{
  "dtx_job": 1,
  "method": "sp04",
  "source": {"file": "in.h5", "mesh": "/meshes/cat", "sequences": ["/sequences/poses"]},
  "targets": [{"name": "lion", "file": "in.h5", "mesh": "/meshes/lion",
               "markers": {"file": "in.h5", "path": "/markers/m"}}],
  "output": {"file": "out.h5", "block_frames": 8}
}
JOB
mpi=(mpirun --oversubscribe --bind-to none)
OMP_NUM_THREADS=1 "${mpi[@]}" -np 1 "$DTX" run --quiet "$W/job.json"
before=$(cksum < "$W/out.h5")

# An error on rank 1 of 3, at each phase.
for phase in read correspondence output transfer finish; do
    start=$(date +%s)
    set +e
    DTX_FAULT="$phase@1" OMP_NUM_THREADS=1 timeout 60 "${mpi[@]}" -np 3 -x DTX_FAULT \
        "$DTX" run "$W/job.json" > "$W/$phase.out" 2> "$W/$phase.err"
    rc=$?
    set -e
    took=$(($(date +%s) - start))
    check "$phase fault on rank 1: non-zero exit ($rc), not a timeout" \
        test "$rc" -ne 0 -a "$rc" -ne 124
    check "$phase fault: ended in ${took} s (< 30 s)" test "$took" -lt 30
    check "$phase fault: rank 1's message" grep -q "rank 1.*injected fault at phase $phase" \
        "$W/$phase.err"
    check "$phase fault: earlier output unchanged" test "$(cksum < "$W/out.h5")" = "$before"
done
grep -h "error" "$W/transfer.err" | head -n 2
# What is left is told truthfully: the partial of the transfer fault reads
# back with its frames done, and --resume is offered for it.
check "transfer fault: the partial is said to be kept, with its frames done, for --resume" \
    grep -q "out.h5.partial is kept: [0-9]* of 27 frames done; once the cause above is fixed, \`dtx run --resume .*job.json\` continues" \
    "$W/transfer.err"

# The same fault where a rank's threads share its blocks (the I/O thread
# joins the transfers): a clean failure, and --resume under other rank and
# thread counts gives the 1-thread result bit for bit.
sed -e 's/out.h5/thr.h5/' -e 's/"block_frames": 8/"block_frames": 16/' "$W/job.json" \
    > "$W/thr.json"
set +e
DTX_FAULT="transfer@1" OMP_NUM_THREADS=2 timeout 60 "${mpi[@]}" -np 2 -x DTX_FAULT \
    "$DTX" run "$W/thr.json" > "$W/thr.out" 2> "$W/thr.err"
rc=$?
set -e
check "transfer fault on rank 1 of 2, 2 threads each: non-zero exit ($rc), not a timeout" \
    test "$rc" -ne 0 -a "$rc" -ne 124
check "transfer fault at 2 threads: rank 1's message" \
    grep -q "rank 1.*injected fault at phase transfer" "$W/thr.err"
check "transfer fault at 2 threads: no OUTPUT, the partial kept" \
    test ! -e "$W/thr.h5" -a -e "$W/thr.h5.partial"
OMP_NUM_THREADS=3 "${mpi[@]}" -np 1 "$DTX" run --quiet --resume "$W/thr.json"
check "resumed at 1 rank x 3 threads: bitwise the 1-thread result" \
    "$DTX" diff "$W/out.h5" "$W/thr.h5" /results/lion/poses --tol 0

# Disk full, simulated by a file-size limit below the result's size: the run
# fails with a message naming the file, the old output survives.
set +e
# (A plain singleton run: PMIx and OpenMPI's shared memory would trip over
# the limit themselves, so they are told to keep their data in memory.)
(ulimit -f 2000; PMIX_MCA_gds=hash OMPI_MCA_btl=self OMP_NUM_THREADS=1 \
    "$DTX" run --quiet "$W/job.json") 2> "$W/fsize.err"
rc=$?
set -e
check "file-size limit: non-zero exit ($rc), not a crash" test "$rc" -ne 0 -a "$rc" -lt 128
check "file-size limit: message names the output and the reason" \
    grep -q "dtx: error: .*out.h5.partial: .*File too large" "$W/fsize.err"
check "file-size limit: earlier output unchanged" test "$(cksum < "$W/out.h5")" = "$before"
# Never "the frames are kept" for a partial that does not read back.
fate() {
    if [ -e "$W/out.h5.partial" ]; then grep -q "out.h5.partial is kept: [0-9]* of 27 frames done" "$W/fsize.err"
    else grep -q "removed .*out.h5.partial, which this run created: it does not read back" "$W/fsize.err"; fi
}
check "file-size limit: what is left of the partial is said truthfully" fate
head -c 400 "$W/fsize.err"; echo
# The same run without the limit completes (resuming what was written).
OMP_NUM_THREADS=1 "$DTX" run --quiet --resume "$W/job.json"
check "after the failure, --resume completes a valid output" "$DTX" validate "$W/out.h5"

# A singleton killed with SIGKILL leaves its session directory
# ($TMPDIR/dtx-mpi-HOST-PID-*); the next singleton start on the host removes
# those whose PID is gone, and only those.
T="$W/tmp"
rm -rf "$T"
mkdir -p "$T"
host=$(uname -n | tr -cd 'A-Za-z0-9.-' | cut -c1-63)
sleep 0 &
dead=$!
wait "$dead"
mkdir -p "$T/dtx-mpi-$host-$dead-aaaaaa/ompi.vm.0/jf.0" "$T/dtx-mpi-$host-$$-bbbbbb" \
    "$T/dtx-mpi-otherhost-$dead-cccccc" "$T/dtx-mpi-dddddd"
echo x > "$T/dtx-mpi-$host-$dead-aaaaaa/ompi.vm.0/jf.0/segment"
rm -f "$W/out.h5"
TMPDIR="$T" OMP_NUM_THREADS=1 "$DTX" run --quiet "$W/job.json"
check "stale session directory (dead PID, this host) removed" test ! -e "$T/dtx-mpi-$host-$dead-aaaaaa"
check "session directory of a live PID kept" test -d "$T/dtx-mpi-$host-$$-bbbbbb"
check "session directory of another host kept" test -d "$T/dtx-mpi-otherhost-$dead-cccccc"
check "directory of another naming kept" test -d "$T/dtx-mpi-dddddd"
check "the run's own session directory removed at exit (3 left, the 3 kept)" \
    test "$(find "$T" -mindepth 1 -maxdepth 1 | wc -l)" -eq 3

finish
