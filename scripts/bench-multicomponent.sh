#!/usr/bin/env bash
# bench-multicomponent.sh: speed of the multicomponent method (Zhou, Xu, Tong &
# Desbrun 2010) on a target the size of the paper's pebble camel (750 stones,
# 51,000 vertices, 99,000 triangles; the paper: 54.6 s correspondence, 14.7 s per
# frame). Figures are printed, never asserted.
#
# Usage: scripts/bench-multicomponent.sh [NFRAMES]    (default 48: the whole gallop)
#   The camel of the shared sumner-horse-camel set shattered by dtx_gen_pebbles
#   into 750 closed stones (gap 0.3%, thickness 0.5% of the diagonal, no
#   subdivision: 58,910 vertices, 114,922 triangles), the 124 markers moved to
#   the stones, the 48-pose horse gallop as the source (tests/bench/bench_mc.c):
#   1. proximity threshold 0.5 x a stone's longest edge (as the pebble-lion test:
#      the camel's edges vary sixfold, so the paper's 1.5 ties each stone to
#      ~17 others with 7 million vertex pairs): correspondence time, plan time,
#      per-frame transfer time at 1 and 2 OpenMP threads, Gauss-Newton
#      iterations, and the distance of each stone vertex from sp04's result on
#      the unbroken camel;
#   2. the paper's threshold 1.5, on 8 frames, 2 threads;
#   3. with DTX_BENCH_MC_NEWTON=1: threshold 0.5, 8 frames, 2 threads, the
#      fixed-point and the Newton solver one after the other (frames that
#      converge, CPU seconds a frame, distances from sp04).
#   Skipped (exit 0) when the shared data is missing.
# Environment: DTX_SKIP_SETUP=1 skips scripts/setup.sh; DTX_BUILD_DIR (default
# build/) is built and used, as by scripts/build.sh; DTX_SHARED_DATA (default
# ../shared/data next to the repository); DTX_BENCH_MC_PAPER=0 skips step 2;
# DTX_BENCH_MC_NEWTON=1 adds step 3.
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$repo"
n=${1:-48}
shared=${DTX_SHARED_DATA:-$repo/../shared/data}
data=$shared/sumner-horse-camel
if [[ ! -f $data/target/camel-reference.obj || ! -f $data/markers.csv ]]; then
    echo "bench-multicomponent: skipped: no horse/camel data in $data"
    exit 0
fi
if [[ ${DTX_SKIP_SETUP:-0} != 1 ]]; then scripts/setup.sh; fi
DTX_SKIP_SETUP=1 scripts/build.sh > /dev/null
build=${DTX_BUILD_DIR:-$repo/build}
export OPENBLAS_NUM_THREADS=1

# spin THREADS: seconds of a fixed amount of pure arithmetic on THREADS threads.
spin() { OMP_NUM_THREADS=$1 "$build"/dtx_bench spin | sed -n 's/.*thread(s) \([0-9.]*\) s.*/\1/p'; }
a=$(spin 1)
b=$(spin 2)
echo "== the machine: a pure arithmetic loop runs $(awk -v a="$a" -v b="$b" \
    'BEGIN { printf "%.2f", a / b }')x faster on 2 threads than on 1 (2.00 on two free cores)"

echo "== horse gallop -> pebble camel, proximity threshold 0.5, $n frames"
OMP_NUM_THREADS=2 "$build"/dtx_bench_mc "$data" --eps 0.5 --frames "$n" --threads 1,2

if [[ ${DTX_BENCH_MC_PAPER:-1} != 0 ]]; then
    echo "== the same with the paper's proximity threshold 1.5, 8 frames"
    OMP_NUM_THREADS=2 "$build"/dtx_bench_mc "$data" --eps 1.5 --frames 8 --threads 2
fi

if [[ ${DTX_BENCH_MC_NEWTON:-0} == 1 ]]; then
    for solver in fixed-point newton; do
        echo "== proximity threshold 0.5, 8 frames, solver $solver"
        OMP_NUM_THREADS=2 "$build"/dtx_bench_mc "$data" --eps 0.5 --frames 8 --threads 2 --solver "$solver"
    done
fi
