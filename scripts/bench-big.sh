#!/usr/bin/env bash
# bench-big.sh: sp04 on big meshes: the cat and the lion midpoint-subdivided
# 0..3 times (`dtx generate subdivide`; the lion has 5,000 / 19,994 / ~80k /
# ~320k vertices), source poses subdivided the same way, markers unchanged
# (the original vertices keep their indices).  For each size, at
# DTX_BENCH_THREADS (default 2) OpenMP threads, in memory
# (tests/bench/bench_sp04.c): correspondence seconds, factorisation seconds,
# transfer time per frame and the bare back-substitution per frame on the
# same factor; then the growth exponents (figure ~ n^k) between consecutive
# sizes and over the whole series.  Figures are printed, never asserted.
#
# Usage: scripts/bench-big.sh
# Environment: DTX_SKIP_SETUP=1 skips scripts/setup.sh; DTX_BUILD_DIR (default
# build/); DTX_BENCH_LEVELS (default "0 1 2 3"); DTX_BENCH_THREADS (default 2);
# DTX_BENCH_COMPARE=/path/to/dtx_bench of another build (say main's): each
# size is run with it too, right before this build's, and its table printed
# first, so both come from one run on the same meshes.
# The subdivided meshes are kept in $DTX_BUILD_DIR/bench-big and made again
# only when missing.
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$repo"
if [[ ${DTX_SKIP_SETUP:-0} != 1 ]]; then scripts/setup.sh; fi
DTX_SKIP_SETUP=1 scripts/build.sh > /dev/null
build=${DTX_BUILD_DIR:-$repo/build}
levels=${DTX_BENCH_LEVELS:-0 1 2 3}
threads=${DTX_BENCH_THREADS:-2}
export OPENBLAS_NUM_THREADS=1
scripts/unpack-data.sh "$build/data" > /dev/null
data=$build/data/sumner-cat-lion
work=$build/bench-big
mkdir -p "$work"

# Frames timed per size: fewer on the bigger meshes (per frame grows ~ n).
frames_for() { case $1 in 0) echo 256 ;; 1) echo 128 ;; 2) echo 32 ;; *) echo 8 ;; esac; }

benches=()
if [[ -n ${DTX_BENCH_COMPARE:-} ]]; then benches+=("$DTX_BENCH_COMPARE"); fi
benches+=("$build/dtx_bench")
for b in "${!benches[@]}"; do : > "$work/summary-$b.txt"; done
for L in $levels; do
    dir=$work/L$L
    if [[ ! -s $dir/.done ]]; then
        rm -rf "$dir"
        mkdir -p "$dir/source" "$dir/target"
        for f in "$data"/source/*.obj "$data"/target/*.obj; do
            sub=$(basename "$(dirname "$f")")
            "$build/dtx" generate subdivide "$f" "$dir/$sub/$(basename "$f")" --levels "$L" \
                2> /dev/null
        done
        cp "$data/markers.csv" "$dir/markers.csv"
        echo ok > "$dir/.done"
    fi
    for b in "${!benches[@]}"; do
    echo "== level $L: ${benches[$b]}" >&2
    OMP_NUM_THREADS=$threads "${benches[$b]}" sp04 "$dir" "$(frames_for "$L")" |
        tee "$work/L$L-$b.txt" >&2
    awk -v L="$L" '
        /target .* vertices/ { for (i = 1; i <= NF; i++) if ($i == "target") nv = $(i + 1) }
        /^  correspondence/ { corr = $2 }
        /factor alone/ { f = $0; sub(/.*factor alone /, "", f); sub(/ s.*/, "", f) }
        /^  transfer per frame/ { frame = $4 }
        /bare back-substitution .* 3 columns/ { bare = $3 }
        END { print L, nv, corr, f, frame, bare }' "$work/L$L-$b.txt" >> "$work/summary-$b.txt"
    done
done

for b in "${!benches[@]}"; do
echo
echo "sp04 on subdivided cat -> lion, $threads thread(s): ${benches[$b]}"
awk '
    { L[NR] = $1; n[NR] = $2; c[NR] = $3; f[NR] = $4; p[NR] = $5; b[NR] = $6 }
    function k(a, b, i, j) { return log(b / a) / log(n[j] / n[i]) }
    END {
        printf "%-6s %9s %12s %10s %14s %14s\n", "level", "target nv", "corresp. s", "factor s",
            "per frame ms", "bare solve ms"
        for (i = 1; i <= NR; i++)
            printf "%-6s %9d %12.2f %10.3f %14.3f %14.3f\n", L[i], n[i], c[i], f[i], p[i], b[i]
        if (NR < 2) exit
        print "growth exponents (figure ~ n^k):"
        printf "%-12s %12s %10s %14s %14s\n", "sizes", "corresp.", "factor", "per frame",
            "bare solve"
        for (i = 2; i <= NR; i++)
            printf "%-12s %12.2f %10.2f %14.2f %14.2f\n", L[i - 1] "->" L[i], k(c[i - 1], c[i], i - 1, i),
                k(f[i - 1], f[i], i - 1, i), k(p[i - 1], p[i], i - 1, i), k(b[i - 1], b[i], i - 1, i)
        printf "%-12s %12.2f %10.2f %14.2f %14.2f\n", L[1] "->" L[NR], k(c[1], c[NR], 1, NR),
            k(f[1], f[NR], 1, NR), k(p[1], p[NR], 1, NR), k(b[1], b[NR], 1, NR)
    }' "$work/summary-$b.txt"
done
