#!/usr/bin/env bash
# The correspondence store (job key correspondence_store, dtx run --store,
# --correspond-only; src/io/corr_store.c, src/driver/run_store.c):
#   two jobs with one store: the first computes the lion's correspondence,
#     the second takes it from the store; both results bitwise equal a
#     store-less run's; the store file validates, no temporary is left;
#   two jobs at once on an empty store: both succeed, one file, no temporary;
#   changed markers: a new key, computed again (a second store file);
#   multicomponent: stored without a deformed source and taken back, the
#     result bitwise equal a store-less run's; an sp04 job does not take it;
#   a truncated, a garbage and a damaged (arrays changed, so content_hash
#     fails) store file: a warning naming the file, computed again, the
#     result unchanged and the file replaced by a good one;
#   --correspond-only without a store is refused;
#   a make rehearsal (scripts/dataset.mk): N one-frame clips onto 2
#     characters compute exactly 2 correspondences, and a rerun does nothing
#     (N = 4; scripts/bench-corr-store.sh runs 200).
# The sanitizer pass leaves out the concurrent jobs, the changed markers, the
# sp04-after-multicomponent store, the store-less multicomponent reference,
# the garbage and damaged files and the make rehearsal (cli.make_dataset
# runs the store through make there); the store's reading and writing paths
# are all still taken.
set -euo pipefail
D="$DTX_BUILD/data/sumner-cat-lion"
W="$DTX_TESTDATA"
PY=/usr/bin/python3
. "$DTX_SRC/tests/lib.sh"
plain_pass() { [ "${DTX_SANITIZED:-0}" != 1 ]; }
export OMP_NUM_THREADS=1

# ---- inputs ---------------------------------------------------------------
"$DTX" import mesh "$D/source/cat-reference.obj" -o "$W/in.h5" --name cat 2> /dev/null
"$DTX" import mesh "$D/target/lion-reference.obj" -o "$W/in.h5" --name lion 2> /dev/null
"$DTX" import sequence "$D"/source/cat-0[12].obj -o "$W/in.h5" --name poses --mesh /meshes/cat \
    --dtype float64 2> /dev/null
cp "$D/markers.csv" "$W/markers.csv"
head -n -1 "$D/markers.csv" > "$W/dropped.csv"
"$DTX" generate eyes "$D/target/lion-reference.obj" "$W/eyes.obj" --anchors 100,2000 \
    --radius 0.004 --gap 0.002 --markers "$D/markers.csv" --index-base 0 \
    --markers-out "$W/eyes.csv" 2> /dev/null
"$DTX" import mesh "$W/eyes.obj" -o "$W/in.h5" --name eyes 2> /dev/null

# job NAME [METHOD [TARGET-MESH [MARKERS-CSV [STORE]]]]
job() {
    local method=${2:-sp04} mesh=${3:-lion} csv=${4:-markers.csv} store=${5-store}
    cat > "$W/$1.json" <<JOB
{
  "dtx_job": 1,
  "method": "$method",
  "source": {"file": "in.h5", "mesh": "/meshes/cat", "sequences": ["/sequences/poses"]},
  "targets": [{"name": "t", "file": "in.h5", "mesh": "/meshes/$mesh",
               "markers": {"csv": "$csv", "index_base": 0}}],$([ -n "$store" ] && echo "
  \"correspondence_store\": \"$store\",")
  "output": {"file": "$1.h5", "dtype": "float64"}
}
JOB
}
run() { # run NAME [FLAGS...]: its log in NAME.log
    local name=$1
    shift
    "$DTX" run "$@" "$W/$name.json" 2> "$W/$name.log" || { cat "$W/$name.log"; return 1; }
}
corr_of() { # the summary's correspondence record of target t
    $PY -c 'import json, sys; print(json.load(open(sys.argv[1]))["correspondences"]["t"])' \
        "$W/$1.h5.summary.json"
}
says() { local got; got=$(corr_of "$1"); [ "$got" = "$2" ] || { echo "  $1: $got, expected $2"; return 1; }; }
equal() { "$DTX" diff "$W/$1.h5" "$W/$2.h5" /results/t/poses --tol 0 > /dev/null; }
nfiles() { ls -A "$W/store" | wc -l; }
validates() { for f in "$W"/store/*.h5; do "$DTX" validate "$f" > /dev/null || return 1; done; }

# ---- two jobs, one store ----------------------------------------------------
job ref sp04 lion markers.csv ""
job a
job b
run ref
run a
run b
check "store-less run computes" says ref computed
check "first job with the store computes" says a computed
check "first job says it stored the correspondence" grep -q "correspondence stored as" "$W/a.log"
check "second job takes it from the store" says b store
check "second job's log says so" grep -q "target t: correspondence taken from the store" "$W/b.log"
check "second job computes nothing" bash -c "! grep -q 'correspondence computed' '$W/b.log'"
check "first result bitwise equals the store-less one" equal ref a
check "second result bitwise equals the store-less one" equal ref b
check "the store holds one file" test "$(nfiles)" -eq 1
check "the store file validates" validates
check "no temporary file left" test -z "$(find "$W/store" -name '.*')"
good=$(ls "$W"/store/*.h5)
cp "$good" "$W/good-store-file.h5"

# ---- two jobs at once on an empty store: both compute, either rename wins --------
if plain_pass; then
    job p1 sp04 lion markers.csv store-p
    job p2 sp04 lion markers.csv store-p
    rc1=0 rc2=0
    run p1 & pid1=$!
    run p2 & pid2=$!
    wait $pid1 || rc1=$?
    wait $pid2 || rc2=$?
    check "concurrent jobs: both succeed" test $rc1 -eq 0 -a $rc2 -eq 0
    check "concurrent jobs: both results bitwise equal the store-less one" \
        bash -c "$(declare -f equal); DTX='$DTX' W='$W'; equal ref p1 && equal ref p2"
    check "concurrent jobs: one store file, no temporary left" \
        test "$(ls -A "$W/store-p")" = "$(ls "$W/store")"
fi

# ---- changed markers -----------------------------------------------------------
if plain_pass; then
    job c sp04 lion dropped.csv
    run c
    check "changed markers: computed" says c computed
    check "changed markers: a second store file" test "$(nfiles)" -eq 2
    job c2 sp04 lion dropped.csv
    run c2
    check "changed markers: the next job takes the new one" says c2 store
fi

# ---- multicomponent --------------------------------------------------------------
job mref multicomponent eyes eyes.csv ""
job m1 multicomponent eyes eyes.csv
job m2 multicomponent eyes eyes.csv
plain_pass && run mref
run m1 --correspond-only
run m2
check "multicomponent: --correspond-only writes no output" test ! -e "$W/m1.h5"
check "multicomponent: --correspond-only stores it" \
    grep -q "target t: correspondence stored as" "$W/m1.log"
check "multicomponent: the next job takes it from the store" says m2 store
plain_pass && check "multicomponent: result bitwise equals the store-less one" equal mref m2
check "multicomponent: the store files validate" validates
# The same lion and markers in a fresh store, multicomponent first: the sp04
# job after it computes its own (the key covers the method).
if plain_pass; then
    job x1 multicomponent lion markers.csv store2
    job x2 sp04 lion markers.csv store2
    run x1 --correspond-only
    check "multicomponent onto the lion: stored" test "$(ls -A "$W/store2" | wc -l)" -eq 1
    run x2 --correspond-only
    check "sp04 does not take the multicomponent entry of the same inputs" \
        grep -q "target t: correspondence computed" "$W/x2.log"
    check "... and stores its own beside it" test "$(ls -A "$W/store2" | wc -l)" -eq 2
fi

# ---- damaged store files ---------------------------------------------------------
damaged() { # damaged WHAT: the lion's store file damaged by WHAT, then a run
    local name=d-$1
    job "$name"
    run "$name"
    check "$1 store file: a warning naming it" \
        grep -q "warning: target t: correspondence store: $good: .*computing the correspondence again" \
        "$W/$name.log"
    check "$1 store file: computed again" says "$name" computed
    check "$1 store file: the result is unchanged" equal ref "$name"
    check "$1 store file: replaced by a good one" validates
    job "$name-next"
    check "$1 store file: the next job runs" run "$name-next"
    check "$1 store file: ... and takes it from the store" says "$name-next" store
}
head -c 3000 "$W/good-store-file.h5" > "$good"
damaged truncated
if plain_pass; then
    echo "not an HDF5 file" > "$good"
    damaged garbage
fi
if plain_pass && $PY -c 'import h5py' 2> /dev/null; then
    $PY - "$good" <<'PY'
import sys, h5py
with h5py.File(sys.argv[1], "r+") as f:
    g = next(iter(f["/correspondences"].values()))
    p = g["pairs"][...]
    i = next(i for i in range(len(p) - 1) if p[i, 1] != p[i + 1, 1])
    p[i, 1] = p[i + 1, 1]  # still in range: only content_hash tells
    g["pairs"][...] = p
PY
    damaged "changed-arrays"
fi

# ---- --correspond-only needs a store ---------------------------------------------
job nostore sp04 lion markers.csv ""
rc=0
"$DTX" run --correspond-only "$W/nostore.json" 2> "$W/nostore.log" || rc=$?
check "--correspond-only without a store fails" test $rc -ne 0
check "... saying it needs a store" grep -q "needs a correspondence store" "$W/nostore.log"
check "... and writes nothing" test ! -e "$W/nostore.h5"

# ---- a make rehearsal: many clips onto 2 characters --------------------------------
N=4
if ! plain_pass; then
    finish
    exit
fi
T="$W/tree"
mkdir -p "$T/source" "$T/targets/lion" "$T/targets/cat"
ln -s "$D/source/cat-reference.obj" "$T/source/rest.obj"
for k in $(seq 1 $N); do
    mkdir -p "$T/sequences/clip$k"
    ln -s "$D/source/cat-0$(( (k - 1) % 9 + 1 )).obj" "$T/sequences/clip$k/f.obj"
done
ln -s "$D/target/lion-reference.obj" "$T/targets/lion/mesh.obj"
ln -s "$D/markers.csv" "$T/targets/lion/markers.csv"
ln -s "$D/source/cat-reference.obj" "$T/targets/cat/mesh.obj"
awk -F, 'NR > 1 { print $1 "," $1 }' "$D/markers.csv" > "$T/targets/cat/markers.csv"
mk() { make -f "$DTX_SRC/scripts/dataset.mk" DATA="$T" OUT="$W/out" DTX="$DTX" THREADS=1 "$@"; }
rc=0
mk -j2 > "$W/make1.log" 2>&1 || { rc=$?; cat "$W/make1.log"; }
check "make: $N clips onto 2 characters" test $rc -eq 0
check "make: exactly 2 correspondences computed" \
    test "$(grep -c "correspondence computed" "$W/make1.log")" -eq 2
check "make: the $((2 * N)) clips take theirs from the store" \
    test "$(grep -c "correspondence taken from the store" "$W/make1.log")" -eq $((2 * N))
check "make: $((2 * N)) results" test "$(ls "$W"/out/results/*/*.h5 | wc -l)" -eq $((2 * N))
check "make -q: up to date" mk -q
mk -j2 > "$W/make2.log" 2>&1
check "a rerun of make does nothing" test ! -s "$W/make2.log" -o -z "$(grep dtx "$W/make2.log")"
echo "make rehearsal: $(grep -c "correspondence computed" "$W/make1.log") computed, \
$(grep -c "taken from the store" "$W/make1.log") taken from the store over $N clips x 2 characters"
finish
