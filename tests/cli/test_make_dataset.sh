#!/usr/bin/env bash
# scripts/dataset.mk on a small tree built from the bundled cat -> lion data:
# two sequences (walk, jump) and two targets (lion with 0-based markers, and the
# cat itself with 1-based markers and an index-base file).  Checks that the
# first make builds and validates every result, that the result equals a hand-
# made job's, that a second make does nothing, and that a touched frame, changed
# markers, a touched target mesh, a bad frame, a removed frame and a changed
# variable each redo exactly the steps that depend on them.
set -uo pipefail
D="$DTX_BUILD/data/sumner-cat-lion"
W="$DTX_TESTDATA"
DATA="$W/data"
O="$W/out"
pass=0 fails=0
check() { # check DESCRIPTION COMMAND...
    local what=$1
    shift
    if "$@"; then
        echo "ok: $what"
        pass=$((pass + 1))
    else
        echo "FAILED: $what"
        fails=$((fails + 1))
    fi
}
not() { ! "$@"; }
# mk ARGS...: the Makefile on the sample tree, one thread per run (make -j2).
mk() { make -f "$DTX_SRC/scripts/dataset.mk" DATA="$DATA" OUT="$O" DTX="$DTX" THREADS=1 "$@"; }
# The output files written since the stamp (variable stamps, the correspondence
# store and its stamps left out: they are checked on their own), sorted.
changed() {
    find "$O" -type f -newer "$W/stamp" ! -path '*/.vars/*' ! -path '*/.corr/*' \
        ! -path '*/correspondences/*' | sed "s|^$O/||" | LC_ALL=C sort | tr '\n' ' '
}
# build LOG ARGS...: mk with its output in LOG, shown when it fails.
build() {
    local log=$1 rc
    shift
    mk "$@" > "$log" 2>&1
    rc=$?
    [[ $rc -eq 0 ]] || cat "$log"
    return $rc
}
new_stamp() {
    sleep 0.05
    touch "$W/stamp"
    sleep 0.05
}
same() { # same WHAT EXPECTED ACTUAL
    if [[ $2 == "$3" ]]; then return 0; fi
    echo "  $1: expected [$2]" >&2
    echo "  $1: got      [$3]" >&2
    return 1
}
res() { printf 'results/%s.h5 results/%s.h5.summary.json ' "$1" "$1"; }

# --------------------------------------------------------------------------
# The sample tree: frames and the lion are copies (they get touched), the rest
# symlinks.
# --------------------------------------------------------------------------
mkdir -p "$DATA/source" "$DATA/sequences/walk" "$DATA/sequences/jump" \
    "$DATA/targets/lion" "$DATA/targets/cat"
ln -s "$D/source/cat-reference.obj" "$DATA/source/rest.obj"
for k in 1 2 3; do cp "$D/source/cat-0$k.obj" "$DATA/sequences/walk/cat-$k.obj"; done
for k in 4 5 6; do cp "$D/source/cat-0$k.obj" "$DATA/sequences/jump/cat-$k.obj"; done
cp "$D/target/lion-reference.obj" "$DATA/targets/lion/mesh.obj"
cp "$D/markers.csv" "$DATA/targets/lion/markers.csv"
ln -s "$D/source/cat-reference.obj" "$DATA/targets/cat/mesh.obj"
# The cat onto itself: the lion markers' source vertices, 1-based, on both sides.
awk -F, 'NR > 1 { print $1 + 1 "," $1 + 1 }' "$D/markers.csv" > "$DATA/targets/cat/markers.csv"
echo 1 > "$DATA/targets/cat/index-base"

# --------------------------------------------------------------------------
# First build, then nothing to do.
# --------------------------------------------------------------------------
t0=$SECONDS
check "make -j2 builds the tree" build "$W/make1.log" -j2
for p in lion/walk lion/jump cat/walk cat/jump; do
    check "$p: result validates" "$DTX" validate "$O/results/$p.h5" > /dev/null
    check "$p: 3 frames transferred" grep -q '"frames": 3' "$O/results/$p.h5.summary.json"
done
touch -d @0 "$W/stamp"
check "the output tree holds exactly the expected files" \
    same "files" "jobs/cat/jump.json jobs/cat/walk.json jobs/lion/jump.json jobs/lion/walk.json \
$(res cat/jump)$(res cat/walk)$(res lion/jump)$(res lion/walk)\
sequences/jump.h5 sequences/walk.h5 targets/cat.h5 targets/lion.h5 " "$(changed)"

# Each target's correspondence computed once, into the store, and taken from
# there by each of its pairs.
check "first build: 2 correspondences computed (one per target)" \
    test "$(grep -c "correspondence computed" "$W/make1.log")" -eq 2
check "first build: the 4 pairs take them from the store" \
    test "$(grep -c "correspondence taken from the store" "$W/make1.log")" -eq 4
check "the store holds exactly 2 files" test "$(ls -A "$O/correspondences" | wc -l)" -eq 2
for f in "$O"/correspondences/*.h5; do
    check "store file ${f##*/} validates" "$DTX" validate "$f" > /dev/null
done

# The same transfer by hand: the Makefile wired the right frames and markers.
H="$W/byhand"
mkdir -p "$H"
"$DTX" import mesh "$D/source/cat-reference.obj" -o "$H/in.h5" --name cat 2> /dev/null
"$DTX" import mesh "$D/target/lion-reference.obj" -o "$H/in.h5" --name lion 2> /dev/null
"$DTX" import sequence "$DATA/sequences/walk" -o "$H/in.h5" --name walk --mesh /meshes/cat 2> /dev/null
"$DTX" import markers "$D/markers.csv" --index-base 0 -o "$H/in.h5" --name cl 2> /dev/null
cat > "$H/job.json" << 'JOB'
{"dtx_job": 1, "method": "sp04",
 "source": {"file": "in.h5", "mesh": "/meshes/cat", "sequences": ["/sequences/walk"]},
 "targets": [{"name": "lion", "file": "in.h5", "mesh": "/meshes/lion",
              "markers": {"file": "in.h5", "path": "/markers/cl"}}],
 "output": {"file": "out.h5"}}
JOB
OMP_NUM_THREADS=1 "$DTX" run --quiet "$H/job.json"
check "lion/walk equals the hand-made job's result" \
    "$DTX" diff "$H/out.h5" "$O/results/lion/walk.h5" /results/lion/walk --tol 1e-12 > /dev/null

check "make -q: up to date after the build" mk -q
build "$W/make2.log" -j2
check "a second make runs nothing" not grep -q 'dtx' "$W/make2.log"

# --------------------------------------------------------------------------
# A touched frame redoes its sequence's import and results only; the
# correspondences come from the old results' cache.
# --------------------------------------------------------------------------
new_stamp
touch "$DATA/sequences/walk/cat-2.obj"
check "make -q notices the touched frame" not mk -q
check "touched frame: make succeeds" build "$W/make3.log" -j2
check "touched frame: only walk's import and results redone" \
    same "rebuilt" "$(res cat/walk)$(res lion/walk)sequences/walk.h5 " "$(changed)"
check "touched frame: correspondences reused" \
    test "$(grep -c "reused from the output's cache" "$W/make3.log")" -eq 2
check "make -q: up to date again" mk -q

# --------------------------------------------------------------------------
# Changed markers redo that target's import and results, and change them.
# --------------------------------------------------------------------------
cp "$O/results/lion/jump.h5" "$W/lion-jump-before.h5"
new_stamp
sed -i '$d' "$DATA/targets/lion/markers.csv" # drop the last marker
check "changed markers: make succeeds" build "$W/make4.log" -j2
check "changed markers: only lion's import and results redone" \
    same "rebuilt" "$(res lion/jump)$(res lion/walk)targets/lion.h5 " "$(changed)"
check "changed markers: correspondence recomputed" grep -q "target lion: correspondence computed" "$W/make4.log"
check "changed markers: lion/jump result changed" \
    bash -c "! '$DTX' diff '$W/lion-jump-before.h5' '$O/results/lion/jump.h5' /results/lion/jump > /dev/null"
check "make -q: up to date again" mk -q

# --------------------------------------------------------------------------
# A touched target mesh with the same content: the import is redone, and dtx
# finds the results already complete for the job (nothing transferred), yet
# make must consider them up to date afterwards.
# --------------------------------------------------------------------------
new_stamp
touch "$DATA/targets/lion/mesh.obj"
check "touched target mesh: make succeeds" build "$W/make4b.log" -j2
check "touched target mesh: lion's import redone, results only confirmed" \
    test "$(grep -c "already complete for this job: nothing to do" "$W/make4b.log")" -eq 2
check "touched target mesh: no correspondence computed" not grep -q "correspondence computed" "$W/make4b.log"
check "touched target mesh: make -q up to date afterwards" mk -q

# --------------------------------------------------------------------------
# A bad frame fails the import and leaves nothing that looks done; removing it
# (a change no remaining file shows) redoes the sequence.
# --------------------------------------------------------------------------
new_stamp
echo "not a mesh" > "$DATA/sequences/jump/cat-7.obj"
mk -j2 > "$W/make5.log" 2>&1
rc=$?
check "bad frame: make fails" test $rc -ne 0
check "bad frame: the message names the file" grep -q "jump/cat-7.obj" "$W/make5.log"
check "bad frame: nothing written" same "written" "" "$(changed)"
check "bad frame: no temporary file left" test -z "$(find "$O" -name '*.tmp*')"
check "bad frame: make -q still says out of date" not mk -q
rm "$DATA/sequences/jump/cat-7.obj"
new_stamp
rm "$DATA/sequences/jump/cat-6.obj"
check "removed frame: make succeeds" build "$W/make6.log" -j2
check "removed frame: only jump's import and results redone" \
    same "rebuilt" "$(res cat/jump)$(res lion/jump)sequences/jump.h5 " "$(changed)"
check "removed frame: jump now has 2 frames" grep -q '"frames": 2' "$O/results/cat/jump.h5.summary.json"

# --------------------------------------------------------------------------
# A changed variable redoes the steps it affects (here jobs and results).
# --------------------------------------------------------------------------
new_stamp
check "OUT_DTYPE=float64: make succeeds" build "$W/make7.log" -j2 OUT_DTYPE=float64
check "OUT_DTYPE=float64: jobs and results redone, imports kept" \
    same "rebuilt" "jobs/cat/jump.json jobs/cat/walk.json jobs/lion/jump.json jobs/lion/walk.json $(res cat/jump)$(res cat/walk)$(res lion/jump)$(res lion/walk)" "$(changed)"
check "OUT_DTYPE=float64: written in the job" grep -q '"dtype": "float64"' "$O/jobs/cat/walk.json"
check "make -q OUT_DTYPE=float64: up to date" mk -q OUT_DTYPE=float64
echo "timing: the make steps took $((SECONDS - t0)) s"

# --------------------------------------------------------------------------
# Broken trees are refused before any work, naming what is missing.
# --------------------------------------------------------------------------
B="$W/bad"
mkdir -p "$B/source" "$B/sequences/s" "$B/targets/t"
ln -s "$D/source/cat-reference.obj" "$B/source/rest.obj"
ln -s "$D/source/cat-01.obj" "$B/sequences/s/f1.obj"
ln -s "$D/target/lion-reference.obj" "$B/targets/t/mesh.obj"
bad() { # bad DESCRIPTION PATTERN [MAKE-ARGS...]
    local what=$1 pattern=$2 msg
    shift 2
    if msg=$(make -f "$DTX_SRC/scripts/dataset.mk" DTX="$DTX" OUT="$W/badout" "$@" 2>&1); then
        echo "FAILED: $what: make succeeded"
        fails=$((fails + 1))
    elif ! grep -q -- "$pattern" <<< "$msg"; then
        echo "FAILED: $what: message lacks '$pattern': $msg"
        fails=$((fails + 1))
    else
        echo "ok: $what: $msg"
        pass=$((pass + 1))
    fi
}
bad "DATA not set" "DATA is not set" DATA=
bad "missing markers" "targets/t/markers.csv: missing" DATA="$B"
cp "$D/markers.csv" "$B/targets/t/markers.csv"
bad "MARKER_BASE=2" "MARKER_BASE=2: must be 0 or 1" DATA="$B" MARKER_BASE=2
bad "OUT inside the input tree" "is inside" DATA="$B" OUT="$B/sequences/out"
mkdir "$B/sequences/empty"
bad "sequence folder without frames" "sequences/empty/: no .obj" DATA="$B"
rmdir "$B/sequences/empty"
mkdir "$B/sequences/bad+name"
ln -s "$D/source/cat-01.obj" "$B/sequences/bad+name/f1.obj"
bad "bad sequence name" "names may only use" DATA="$B"
rm -r "$B/sequences/bad+name"
mkdir -p "$B/targets/u"
cp "$D/markers.csv" "$B/targets/u/markers.csv"
bad "target without a mesh" "targets/u/mesh.obj (or .ply, .off): missing" DATA="$B"
rm -r "$B/targets/u"
echo 2 > "$B/targets/t/index-base"
bad "index-base holding 2" "targets/t/index-base: must hold 0 or 1, not '2'" DATA="$B"
check "refused trees wrote no results" test ! -e "$W/badout/results"
check "refused trees left no temporary file" test -z "$(find "$W/badout" -name '*.tmp*')"

echo "make_dataset: $pass passed, $fails failed"
[ "$fails" -eq 0 ]
