#!/usr/bin/env bash
# bench-springs.sh: speed of the springs method (Yang, Ma & Ouhyoung,
# stretchiness-ratio transfer): time per frame single level vs multigrid
# start, Newton iterations per frame, inverted triangles, and the proxy route
# against the paper's sp04 results. Figures are printed, never asserted.
#
# Usage: scripts/bench-springs.sh
#   1. lion-sized (5,000 vertices): the lion rest -> sp04 lion poses onto a
#      thicker lion: the sp04 start with the barrier, and both older starts
#      (linear, the paper's rest) single level and multigrid, 1 thread
#      (tests/bench/bench_springs.c --run same);
#   2. cat -> lion through the sp04 proxy, nine poses, against the paper's
#      results: the sp04 start with the barrier and the linear start without
#      it, in one run (--run proxy);
#   3. camel-sized (21,887 vertices, shared data): as 1 with the linear start
#      on 2 frames (single level takes about a minute a frame);
#   4. `dtx run` of a springs job (cat -> cat made thicker with longer legs,
#      nine poses) on 1 and 2 MPI ranks: wall time.
# Environment: DTX_SKIP_SETUP=1 skips scripts/setup.sh; DTX_BUILD_DIR (default
# build/); DTX_SHARED_DATA (default ../shared/data next to the repository).
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$repo"
shared=${DTX_SHARED_DATA:-$repo/../shared/data}
if [[ ${DTX_SKIP_SETUP:-0} != 1 ]]; then scripts/setup.sh; fi
DTX_SKIP_SETUP=1 scripts/build.sh > /dev/null
build=${DTX_BUILD_DIR:-$repo/build}
export OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1
scripts/unpack-data.sh "$build/data" > /dev/null
bench=$build/dtx_bench_springs
cl=$build/data/sumner-cat-lion

echo "== 1. lion-sized, same connectivity"
"$bench" "$cl" --run same --frames 4
echo "== 2. cat -> lion through the proxy"
"$bench" "$cl" --run proxy
if [[ -d $shared/sumner-horse-camel ]]; then
    echo "== 3. camel-sized, same connectivity, linear start"
    "$bench" "$shared/sumner-horse-camel" --run same --frames 2 --start linear
else
    echo "== 3. camel-sized: skipped (no $shared/sumner-horse-camel)"
fi

echo "== 4. dtx run, cat -> fat cat, nine poses"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
dtx=$build/dtx
"$dtx" generate reshape "$cl/source/cat-reference.obj" "$tmp/fatcat.obj" --axis y 2> /dev/null
"$dtx" import mesh "$cl/source/cat-reference.obj" -o "$tmp/in.h5" --name cat 2> /dev/null
"$dtx" import mesh "$tmp/fatcat.obj" -o "$tmp/in.h5" --name fatcat 2> /dev/null
"$dtx" import sequence "$cl"/source/cat-0?.obj -o "$tmp/in.h5" --name cat-poses \
    --mesh /meshes/cat 2> /dev/null
mpi=(mpirun --oversubscribe --bind-to none)
if [[ $(id -u) -eq 0 ]]; then
    export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
fi
for np in 1 2; do
    cat > "$tmp/j$np.json" <<JOB
{"dtx_job": 1, "method": "springs",
 "source": {"file": "in.h5", "mesh": "/meshes/cat", "sequences": ["/sequences/cat-poses"]},
 "targets": [{"file": "in.h5", "mesh": "/meshes/fatcat"}],
 "output": {"file": "out$np.h5"}}
JOB
    echo "-- $np rank(s) x 1 thread"
    "${mpi[@]}" -np "$np" "$dtx" run "$tmp/j$np.json" 2>&1 | grep -v progress
done
