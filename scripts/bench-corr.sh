#!/usr/bin/env bash
# bench-corr.sh: the sp04 correspondence's choices measured one by one (issue 21, item 6).
# For each variant, on cat -> lion (with the paper's own results: mean and worst RMS per pose
# over the lion's diagonal, core.cat_lion_accuracy's measure) and on horse gallop -> camel
# (no reference: time, pairs, fit), what `dtx_bench corr` prints.  Figures only, nothing
# asserted.  Usage: scripts/bench-corr.sh [BUILD_DIR] (default build; data from
# DTX_SHARED_DATA, default ../shared/data next to the repository).
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-build}
data=${DTX_SHARED_DATA:-$repo/../shared/data}
bench="$build/dtx_bench"
paper="w_identity=0.001"
# The paper raises w_C from 1 to 5000 in four steps; equal ratios (5000^(1/3) = 17.1 each)
# are the principled reading of "four steps" for a weight that acts multiplicatively, and
# [1, 500, 1000, 5000] is the reading of a public implementation (the README's "paper's
# weights").
geo="w_closest=1,17.0998,292.402,5000"
lin="w_closest=1,500,1000,5000"
run() {
    name=$1
    shift
    echo "== $name"
    for pair in sumner-cat-lion sumner-horse-camel; do
        OMP_NUM_THREADS=${OMP_NUM_THREADS:-1} "$bench" corr "$data/$pair" "$@" | sed 1d
    done
}
run "defaults (weights per area)"
run "0. weights per element (the defaults before)" weights=element
run "1. closest points at target vertices only" closest_on=vertices
run "1e. closest points at target vertices only, per element" closest_on=vertices weights=element
run "2. no normal rule for closest points" closest_normals=0
run "2e. no normal rule for closest points, per element" closest_normals=0 weights=element
run "3a. paper's weights, [1, 500, 1000, 5000], per element" $paper $lin weights=element
run "3b. paper's weights, [1, 500, 1000, 5000], per area" $paper $lin
run "3c. paper's weights, four equal ratios, per element" $paper $geo weights=element
run "3d. paper's weights, four equal ratios, per area" $paper $geo
echo "== resolution: the cat refined once by midpoint subdivision (same surface, 4x the triangles)"
for w in element area; do
    OMP_NUM_THREADS=${OMP_NUM_THREADS:-1} "$bench" corr "$data/sumner-cat-lion" subdivide=1 weights=$w | sed 1d
done
