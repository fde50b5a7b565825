#!/usr/bin/env bash
# bench-keypoints.sh: speed of automatic key-point selection (Yang, Gao, Lai,
# Rosin & Xia 2018, Algorithm 1; the paper needed 3-40 minutes on ~2,000-vertex
# sources on a 6-core i7). Figures are printed, never asserted.
#
# Usage: scripts/bench-keypoints.sh
#   1. the shared cactus (5,261 vertices, 18 deformed frames), 100 candidates,
#      eps 0.03: 1 and 2 OpenMP threads (tests/bench/bench_keypoints.c);
#   2. the nine bundled cat poses (7,207 vertices), the same settings;
#   3. fast vs exact evaluation (keypoints.h) on the cat poses with 20
#      candidates: the chosen points and errors of both;
#   4. when `dtx keypoints` exists: 1 and 2 MPI ranks on the cactus.
#   The cactus steps are skipped when the shared data is missing.
# Environment: DTX_SKIP_SETUP=1 skips scripts/setup.sh; DTX_BUILD_DIR (default
# build/); DTX_SHARED_DATA (default ../shared/data next to the repository);
# DTX_BENCH_KP_EXACT=0 skips step 3 (the exact mode takes minutes).
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$repo"
shared=${DTX_SHARED_DATA:-$repo/../shared/data}
if [[ ${DTX_SKIP_SETUP:-0} != 1 ]]; then scripts/setup.sh; fi
DTX_SKIP_SETUP=1 scripts/build.sh > /dev/null
build=${DTX_BUILD_DIR:-$repo/build}
export OPENBLAS_NUM_THREADS=1
scripts/unpack-data.sh "$build/data" > /dev/null
bench=$build/dtx_bench_keypoints

cactus=$shared/cactus
cframes=()
if [[ -f $cactus/cactus0.ply ]]; then
    for i in $(seq 1 18); do cframes+=("$cactus/cactus$i.ply"); done
    for t in 1 2; do
        echo "== cactus, $t thread(s)"
        OMP_NUM_THREADS=$t "$bench" --threads "$t" "$cactus/cactus0.ply" "${cframes[@]}"
    done
else
    echo "== cactus: skipped (no $cactus/cactus0.ply)"
fi

cat=$build/data/sumner-cat-lion/source
poses=()
for i in 01 02 03 04 05 06 07 08 09; do poses+=("$cat/cat-$i.obj"); done
for t in 1 2; do
    echo "== cat, nine poses, $t thread(s)"
    OMP_NUM_THREADS=$t "$bench" --threads "$t" "$cat/cat-reference.obj" "${poses[@]}"
done

if [[ ${DTX_BENCH_KP_EXACT:-1} != 0 ]]; then
    echo "== cat, nine poses, 20 candidates, eps 0: fast, then exact (the paper's evaluation)"
    OMP_NUM_THREADS=2 "$bench" --threads 2 --candidates 20 --eps 0 --max 8 \
        "$cat/cat-reference.obj" "${poses[@]}"
    OMP_NUM_THREADS=2 "$bench" --threads 2 --candidates 20 --eps 0 --max 8 --exact \
        "$cat/cat-reference.obj" "${poses[@]}"
fi

if [[ ${#cframes[@]} -gt 0 ]] && "$build/dtx" help 2>&1 | grep -q "dtx keypoints"; then
    tmp=$(mktemp -d)
    trap 'rm -rf "$tmp"' EXIT
    "$build/dtx" import mesh "$cactus/cactus0.ply" -o "$tmp/c.h5" --name cactus 2> /dev/null
    "$build/dtx" import sequence "${cframes[@]}" -o "$tmp/c.h5" --name bend \
        --mesh /meshes/cactus 2> /dev/null
    mpi=(mpirun --oversubscribe --bind-to none)
    if [[ $(id -u) -eq 0 ]]; then
        export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
    fi
    for np in 1 2; do
        echo "== cactus, dtx keypoints on $np rank(s) x 1 thread"
        s=$(date +%s.%N)
        OMP_NUM_THREADS=1 "${mpi[@]}" -np "$np" "$build/dtx" keypoints "$tmp/c.h5" \
            --mesh /meshes/cactus --sequence /sequences/bend --name k$np > "$tmp/out$np.txt"
        e=$(date +%s.%N)
        tail -n 3 "$tmp/out$np.txt"
        awk -v s="$s" -v e="$e" 'BEGIN { printf "wall %.2f s\n", e - s }'
    done
fi
