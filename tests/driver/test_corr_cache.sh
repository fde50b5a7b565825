#!/usr/bin/env bash
# The correspondence cache: `dtx run` reuses the correspondence stored in the
# job's old output exactly when everything that determines it is unchanged
# (source and target mesh contents, the marker pairs, the sp04 correspondence
# parameters), target by target, and says which in the run summary
# ("correspondences": {"<target>": "computed" | "reused"}).
#
# One job, two targets (the lion with the bundled markers; the cat onto itself
# with identity markers), the 9 cat poses, the same output file every time;
# each step edits the job or its inputs and reruns it:
#   unchanged (at 2 ranks)                 -> both reused, results bitwise equal
#   defaults spelled out, markers as CSV   -> both reused (the key is content)
#   lion: one marker dropped               -> lion computed, catself reused;
#                                             the lion result changes
#   lion: one marker moved                 -> lion computed, result changes
#   lion: markers back as at first         -> lion computed (the cache held the
#                                             moved set only), result bitwise
#                                             equal to the first run's
#   sp04.w_identity changed                -> both computed, results change
#   sp04.w_closest changed                 -> both computed
#   only output dtype and block_frames     -> both reused
#   a second sequence added                -> both reused
#   lion: another mesh, same target name   -> lion computed
#   old output unreadable (garbage bytes)  -> both computed, run succeeds
# The sanitizer pass runs the first two, the dropped marker and the garbage.
set -euo pipefail
D="$DTX_BUILD/data/sumner-cat-lion"
W="$DTX_TESTDATA"
PY=/usr/bin/python3
. "$DTX_SRC/tests/lib.sh"
quiet() { "$@" > /dev/null; } # quiet COMMAND...: its stdout discarded
# The sanitizer pass checks the cache's reading and writing (steps 1, 3's
# first, 7); the plain pass also every rule of its key.
plain_pass() { [ "${DTX_SANITIZED:-0}" != 1 ]; }
differs() { ! "$DTX" diff "$@" > /dev/null; } # differs A B RESULT [--tol X]
t_start=$SECONDS

# ---- inputs ---------------------------------------------------------------
"$DTX" import mesh "$D/source/cat-reference.obj" -o "$W/in.h5" --name cat 2> /dev/null
"$DTX" import mesh "$D/target/lion-reference.obj" -o "$W/in.h5" --name lion 2> /dev/null
"$DTX" import sequence "$D"/source/cat-0[1-9].obj -o "$W/in.h5" --name poses --mesh /meshes/cat \
    --dtype float64 2> /dev/null
"$DTX" import sequence "$D"/source/cat-0[2-5].obj -o "$W/in.h5" --name more --mesh /meshes/cat \
    2> /dev/null
"$DTX" import markers "$D/markers.csv" --index-base 0 -o "$W/in.h5" --name cat-lion \
    --source /meshes/cat --target /meshes/lion 2> /dev/null
awk -F, 'NR == 1 { print; next } { print $1 "," $1 ",self " $1 }' "$D/markers.csv" > "$W/self.csv"
"$DTX" import markers "$W/self.csv" --index-base 0 -o "$W/in.h5" --name cat-self \
    --source /meshes/cat --target /meshes/cat 2> /dev/null
# One marker dropped (the last); one marker's lion vertex moved to a vertex
# sharing a triangle with it.
head -n -1 "$D/markers.csv" > "$W/dropped.csv"
$PY - "$D" "$W" <<'PY'
import csv, sys
d, w = sys.argv[1], sys.argv[2]
faces = [[int(t.split("/")[0]) - 1 for t in l.split()[1:4]]
         for l in open(d + "/target/lion-reference.obj") if l.startswith("f ")]
rows = list(csv.reader(open(d + "/markers.csv")))
used = {int(r[1]) for r in rows[1:]}
v = int(rows[10][1])
nb = sorted({u for f in faces if v in f for u in f} - used)
rows[10][1] = str(nb[0])
print("moved marker 10: lion vertex %d -> %d" % (v, nb[0]))
csv.writer(open(w + "/moved.csv", "w", newline=""), lineterminator="\n").writerows(rows)
# Another lion: the same triangles, scaled by 1.5.
with open(w + "/lion-big.obj", "w") as o:
    for l in open(d + "/target/lion-reference.obj"):
        if l.startswith("v "):
            x = [1.5 * float(c) for c in l.split()[1:4]]
            l = "v %.17g %.17g %.17g\n" % tuple(x)
        o.write(l)
PY
"$DTX" import markers "$W/dropped.csv" --index-base 0 -o "$W/in.h5" --name dropped \
    --source /meshes/cat --target /meshes/lion 2> /dev/null
"$DTX" import markers "$W/moved.csv" --index-base 0 -o "$W/in.h5" --name moved \
    --source /meshes/cat --target /meshes/lion 2> /dev/null
"$DTX" import mesh "$W/lion-big.obj" -o "$W/in.h5" --name lion-big 2> /dev/null

# job STEP [LION-MARKERS [SP04 [OUTPUT-EXTRA [SEQUENCES [LION-MESH]]]]]
job() {
    local markers=${2:-'"file": "in.h5", "path": "/markers/cat-lion"'}
    local sp04=${3:-'"w_identity": 0.001'} out=${4:-'"dtype": "float64", "block_frames": 8'}
    local seqs=${5:-'"/sequences/poses"'} mesh=${6:-/meshes/lion}
    cat > "$W/$1.json" <<JOB
{
  "dtx_job": 1,
  "method": "sp04",
  "source": {"file": "in.h5", "mesh": "/meshes/cat", "sequences": [$seqs]},
  "targets": [{"name": "lion", "file": "in.h5", "mesh": "$mesh", "markers": {$markers}},
              {"name": "catself", "file": "in.h5", "mesh": "/meshes/cat",
               "markers": {"file": "in.h5", "path": "/markers/cat-self"}}],
  "output": {"file": "out.h5", $out},
  "sp04": {$sp04}
}
JOB
}
step() { # step NAME NRANKS: runs NAME.json, keeps out.h5 as NAME.h5
    local name=$1 np=$2 t0=$SECONDS rc=0
    OMP_NUM_THREADS=1 mpirun --oversubscribe --bind-to none -np "$np" "$DTX" run --quiet \
        --summary "$W/$name.summary.json" "$W/$name.json" || rc=$?
    check "$name: dtx run at $np rank(s) succeeds" test $rc -eq 0
    cp "$W/out.h5" "$W/$name.h5" || true
    echo "step $name: $((SECONDS - t0)) s, correspondences: $(corr_of "$name" 2>&1)"
}
corr_of() { # corr_of STEP: the summary's "correspondences" as lion=...,catself=...
    $PY -c 'import json, sys
c = json.load(open(sys.argv[1])).get("correspondences")
print(",".join("%s=%s" % kv for kv in sorted(c.items())) if isinstance(c, dict) else repr(c))' \
        "$W/$1.summary.json"
}
says() { # says STEP EXPECTED ("catself=...,lion=..."): the summary's record
    local got
    got=$(corr_of "$1")
    [ "$got" = "$2" ] || { echo "  summary of $1: correspondences $got, expected $2"; return 1; }
}
same_corr() { # same_corr A B TARGET: the cached correspondence datasets bitwise equal
    $PY -c 'import sys, h5py
a, b, t = sys.argv[1:4]
with h5py.File(a, "r") as fa, h5py.File(b, "r") as fb:
    for n in ("pairs", "deformed_source"):
        x, y = fa["/correspondences/%s/%s" % (t, n)][...], fb["/correspondences/%s/%s" % (t, n)][...]
        if x.dtype != y.dtype or x.shape != y.shape or x.tobytes() != y.tobytes():
            sys.exit("  /correspondences/%s/%s differs" % (t, n))' "$W/$1.h5" "$W/$2.h5" "$3"
}
L=/results/lion/poses
C=/results/catself/poses

# ---- 1. first run, then unchanged ------------------------------------------
job s1
step s1 1
check "s1 (first run): both computed" says s1 "catself=computed,lion=computed"
check "s1: output validates" quiet "$DTX" validate "$W/s1.h5"
job s2
step s2 2
check "s2 (unchanged, 2 ranks): both reused" says s2 "catself=reused,lion=reused"
check "s2: lion result bitwise equal to s1" quiet "$DTX" diff "$W/s1.h5" "$W/s2.h5" $L --tol 0
check "s2: catself result bitwise equal to s1" quiet "$DTX" diff "$W/s1.h5" "$W/s2.h5" $C --tol 0
check "s2: cached lion correspondence bitwise equal to s1" same_corr s1 s2 lion
check "s2: output validates" quiet "$DTX" validate "$W/s2.h5"

if plain_pass; then
# ---- 2. the same content, spelled differently -------------------------------
job s3 '"csv": "'"$D"'/markers.csv", "index_base": 0' \
    '"w_identity": 0.001, "w_smooth": 1.0, "max_distance": 0.1, "max_angle_deg": 90,
     "w_closest": [1, 100, 5000, 5000, 5000, 5000], "weights": "area"'
step s3 1
check "s3 (markers from the CSV file, default parameters written out): both reused" \
    says s3 "catself=reused,lion=reused"
fi

# ---- 3. the lion's markers change ------------------------------------------
job s4 '"file": "in.h5", "path": "/markers/dropped"'
step s4 1
check "s4 (lion: one marker dropped): lion computed, catself reused" \
    says s4 "catself=reused,lion=computed"
check "s4: the lion result changed" differs "$W/s1.h5" "$W/s4.h5" $L --tol 0
check "s4: the catself result did not" quiet "$DTX" diff "$W/s1.h5" "$W/s4.h5" $C --tol 0
if plain_pass; then
job s5 '"file": "in.h5", "path": "/markers/moved"'
step s5 1
check "s5 (lion: one marker moved to a neighbour vertex): lion computed, catself reused" \
    says s5 "catself=reused,lion=computed"
check "s5: the lion result changed from s1" differs "$W/s1.h5" "$W/s5.h5" $L --tol 0
check "s5: the lion result changed from s4" differs "$W/s4.h5" "$W/s5.h5" $L --tol 0
job s6
step s6 1
check "s6 (lion: the first markers again): lion computed, catself reused" \
    says s6 "catself=reused,lion=computed"
check "s6: recomputed lion result bitwise equal to s1" \
    quiet "$DTX" diff "$W/s1.h5" "$W/s6.h5" $L --tol 0
check "s6: recomputed lion correspondence bitwise equal to s1" same_corr s1 s6 lion
fi

if plain_pass; then
# ---- 4. correspondence parameters change -------------------------------------
job s7 '' '"w_identity": 0.002'
step s7 1
check "s7 (sp04.w_identity 0.001 -> 0.002): both computed" says s7 "catself=computed,lion=computed"
check "s7: the lion result changed" differs "$W/s6.h5" "$W/s7.h5" $L --tol 0
job s8 '' '"w_identity": 0.002, "w_closest": [1, 100, 5000, 5000, 5000]'
step s8 1
check "s8 (sp04.w_closest one phase fewer): both computed" says s8 "catself=computed,lion=computed"

# ---- 5. nothing the correspondence depends on changes ------------------------
job s9 '' '"w_identity": 0.002, "w_closest": [1, 100, 5000, 5000, 5000]' \
    '"dtype": "float32", "block_frames": 24'
step s9 1
check "s9 (only output dtype float32 and block_frames 24): both reused" \
    says s9 "catself=reused,lion=reused"
check "s9: lion result equal to s8 to float32 precision" \
    quiet "$DTX" diff "$W/s8.h5" "$W/s9.h5" $L --tol 1e-6
check "s9: output validates" quiet "$DTX" validate "$W/s9.h5"
job s10 '' '"w_identity": 0.002, "w_closest": [1, 100, 5000, 5000, 5000]' \
    '"dtype": "float32", "block_frames": 24' '"/sequences/poses", "/sequences/more"'
step s10 1
check "s10 (a second sequence): both reused" says s10 "catself=reused,lion=reused"
check "s10: the poses result bitwise equal to s9" quiet "$DTX" diff "$W/s9.h5" "$W/s10.h5" $L --tol 0

# ---- 6. the target mesh behind a name changes ---------------------------------
job s11 '' '"w_identity": 0.002, "w_closest": [1, 100, 5000, 5000, 5000]' \
    '"dtype": "float32", "block_frames": 24' '"/sequences/poses"' /meshes/lion-big
step s11 1
check "s11 (target lion is now a 1.5x lion): lion computed, catself reused" \
    says s11 "catself=reused,lion=computed"
check "s11: output validates" quiet "$DTX" validate "$W/s11.h5"
fi

# ---- 7. an old output that cannot be read -----------------------------------
head -c 100000 /dev/urandom > "$W/out.h5"
job s12
step s12 1
check "s12 (old output is garbage): both computed" says s12 "catself=computed,lion=computed"
check "s12: lion result bitwise equal to s1" quiet "$DTX" diff "$W/s1.h5" "$W/s12.h5" $L --tol 0
check "s12: output validates" quiet "$DTX" validate "$W/s12.h5"

echo "runtime $((SECONDS - t_start)) s"
finish
