#!/usr/bin/env bash
# bench-corr-store.sh: the make rehearsal of issue 21 item 1 (README,
# "Datasets with make, and runs on a cluster"): N one-frame clips of the
# bundled cat onto 2 characters (the lion, the cat itself) converted by
# scripts/dataset.mk -j2, which computes each character's correspondence
# once into the store OUT/correspondences and then fans out over the clips.
#
# Usage: scripts/bench-corr-store.sh [N [DTX]]     (N default 200)
#   Prints the number of correspondences computed (from the log: must be 2),
#   taken from the store (2 N) and the wall time of the first make and of a
#   rerun (which must run nothing).  With OLD_MK=FILE (a dataset.mk without
#   the store, e.g. `git show d80b427:scripts/dataset.mk > old.mk`) the same
#   tree is converted with it too in the same run, and the ratio printed.
set -euo pipefail

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
N=${1:-200}
DTX=${2:-$repo/build/dtx}
[[ -x $DTX ]] || { echo "bench: no dtx at $DTX (scripts/build.sh first)" >&2; exit 2; }
W=$(mktemp -d "${TMPDIR:-/tmp}/dtx-bench-store.XXXXXX")
trap 'rm -rf "$W"' EXIT
bash "$repo/scripts/unpack-data.sh" "$W/data" > /dev/null
D=$W/data/sumner-cat-lion
T=$W/tree
mkdir -p "$T/source" "$T/targets/lion" "$T/targets/cat"
ln -s "$D/source/cat-reference.obj" "$T/source/rest.obj"
for k in $(seq 1 "$N"); do
    mkdir -p "$T/sequences/clip$k"
    ln -s "$D/source/cat-0$(((k - 1) % 9 + 1)).obj" "$T/sequences/clip$k/f.obj"
done
ln -s "$D/target/lion-reference.obj" "$T/targets/lion/mesh.obj"
ln -s "$D/markers.csv" "$T/targets/lion/markers.csv"
ln -s "$D/source/cat-reference.obj" "$T/targets/cat/mesh.obj"
awk -F, 'NR > 1 { print $1 "," $1 }' "$D/markers.csv" > "$T/targets/cat/markers.csv"

# convert MAKEFILE OUT LOG: prints the wall seconds of make -j2.
convert() {
    local t0 t1
    t0=$(date +%s.%N)
    make -f "$1" DATA="$T" OUT="$2" DTX="$DTX" THREADS=1 -j2 > "$3" 2>&1 ||
        { tail -20 "$3" >&2; exit 1; }
    t1=$(date +%s.%N)
    echo "$t1 - $t0" | bc
}
new=$(convert "$repo/scripts/dataset.mk" "$W/out" "$W/make1.log")
rerun=$(convert "$repo/scripts/dataset.mk" "$W/out" "$W/make2.log")
computed=$(grep -c "correspondence computed" "$W/make1.log" || true)
stored=$(grep -c "correspondence taken from the store" "$W/make1.log" || true)
again=$(grep -c "dtx" "$W/make2.log" || true)
printf 'clips: %d x 2 characters (%d results)\n' "$N" "$((2 * N))"
printf 'store:   first make %.1f s; correspondences computed %d, taken from the store %d\n' \
    "$new" "$computed" "$stored"
printf 'store:   rerun %.2f s, dtx lines in its log: %d\n' "$rerun" "$again"
if [[ -n ${OLD_MK:-} ]]; then
    old=$(convert "$OLD_MK" "$W/out-old" "$W/old.log")
    printf 'without: first make %.1f s; correspondences computed %d\n' "$old" \
        "$(grep -c "correspondence computed" "$W/old.log" || true)"
    printf 'ratio without / with the store: %.2f\n' "$(echo "$old / $new" | bc -l)"
fi
[[ $computed -eq 2 && $stored -eq $((2 * N)) && $again -eq 0 ]] ||
    { echo "bench: expected 2 computed, $((2 * N)) from the store, an idle rerun" >&2; exit 1; }
