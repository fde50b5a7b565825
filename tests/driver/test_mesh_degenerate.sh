#!/usr/bin/env bash
# Degenerate meshes end to end (rows of the bad-input table that need more
# than a message): `dtx run` must accept each, warn, and give a result that
# is finite, validates, and is what the table promises:
#   [degenerate-needle-target], [degenerate-needle-source]: a triangle whose
#     height is a tiny fraction of its edge (1e-6 .. 1e-12, and 0) must not
#     blow up the deformation-gradient inverse: the results for the
#     different heights agree with each other (the triangle is regularised
#     like a zero-area one) instead of exploding or failing to factor;
#   [topo-unreferenced-source]: a source vertex in no triangle changes
#     nothing: the result equals the one without that vertex;
#   [topo-unreferenced-target]: a target vertex in no triangle keeps its
#     rest offset from the centroid of the vertices in triangles.
set -uo pipefail
W="$DTX_TESTDATA"
PY=/usr/bin/python3
cd "$W" || exit 1
pass=0 fails=0
ok() { echo "ok: [$1] $2"; pass=$((pass + 1)); }
bad() { echo "FAILED: [$1] $2"; fails=$((fails + 1)); }

"$PY" "$DTX_SRC/tests/cli/bad_input_meshes.py" needles || bad setup "generating the meshes"
printf 'source_vertex,target_vertex,label\n0,0,top\n85,85,bottom\n1,1,a\n4,4,b\n40,40,c\n' > markers.csv
heights="h0 h1e-12 h1e-9 h1e-6"
for m in src tgt src_unref tgt_unref; do
    "$DTX" import mesh $m.obj -o in.h5 --name $m 2>/dev/null || bad setup "import $m"
done
for h in $heights; do
    for m in src_$h tgt_$h; do
        "$DTX" import mesh $m.obj -o in.h5 --name $m 2>/dev/null || bad setup "import $m"
    done
done
for s in src src_unref $(for h in $heights; do echo src_$h; done); do
    "$DTX" import sequence $s-1.obj $s-2.obj $s-3.obj -o in.h5 --name $s --mesh /meshes/$s \
        --dtype float64 2>/dev/null || bad setup "import sequence $s"
done

# job NAME SOURCE TARGET...: NAME.json (sequence = the source's), output NAME.h5.
job() {
    local name=$1 src=$2 sep="" t; shift 2
    { printf '{"dtx_job": 1, "method": "sp04",\n "source": {"file": "in.h5", "mesh": "/meshes/%s", "sequences": ["/sequences/%s"]},\n "targets": [' "$src" "$src"
      for t in "$@"; do
          printf '%s\n  {"name": "%s", "file": "in.h5", "mesh": "/meshes/%s", "markers": {"csv": "markers.csv", "index_base": 0}}' "$sep" "$t" "$t"
          sep=,
      done
      printf '],\n "output": {"file": "%s.h5", "dtype": "float64"}}\n' "$name"; } > "$name.json"
}
# run ROW NAME WARNING: dtx run NAME.json must succeed with WARNING on stderr
# and a valid output.
run() {
    local msg
    if ! msg=$("$DTX" run "$2.json" 2>&1); then bad "$1" "dtx run $2.json failed: $msg"; return 1; fi
    if ! grep -qE -- "$3" <<<"$msg"; then bad "$1" "no /$3/ in: $msg"; return 1; fi
    if ! "$DTX" validate "$2.h5" >/dev/null 2>&1; then bad "$1" "$2.h5 does not validate"; return 1; fi
    ok "$1" "$(grep -E -- "$3" <<<"$msg" | head -1)"
}
# check ROW PYTHON-ASSERTIONS: run them with h5py and numpy; r(file, result)
# reads positions, diag(file, result) the target's bounding-box diagonal.
check() {
    local row=$1 msg
    if msg=$("$PY" - <<PY 2>&1
import h5py, numpy as np
def r(f, res): return h5py.File(f + ".h5", "r")[res + "/positions"][...]
def rest(f, res): return h5py.File(f + ".h5", "r")[res + "/target/vertices"][...]
def diag(f, res):
    t = rest(f, res); return np.linalg.norm(t.max(0) - t.min(0))
def dev(a, b, d): return np.abs(a - b).max() / d
$2
PY
    ); then ok "$row" "$msg"; else bad "$row" "$msg"; fi
}

job clean src tgt
"$DTX" run --quiet clean.json 2>/dev/null || bad setup "the clean job failed"

# ---------------------------------------------------------------- needles
# One job, one target per height: all must factor and agree.
job ntgt src $(for h in $heights; do echo tgt_$h; done)
if run degenerate-needle-target ntgt 'warning: target mesh .*:/meshes/tgt_h1e-9: 1 triangle of zero area or thinner than 0\.0001 of the longest edge \(face 20 first'; then
    check degenerate-needle-target "
d = diag('clean', '/results/tgt/src')
R = {h: r('ntgt', '/results/tgt_%s/src' % h) for h in '$heights'.split()}
assert all(np.isfinite(x).all() for x in R.values()), 'non-finite positions'
worst = max(dev(R[a], R[b], d) for a in R for b in R)
assert worst < 1e-2, 'needle heights 0..1e-6 give results %.3g diagonals apart' % worst
print('heights 0..1e-6 agree within %.2g of the diagonal' % worst)"
fi
# One job per source height.
for h in $heights; do
    job nsrc_$h src_$h tgt
    run degenerate-needle-source nsrc_$h "warning: source mesh .*:/meshes/src_$h: 1 triangle of zero area"
done
check degenerate-needle-source "
d = diag('clean', '/results/tgt/src')
R = {h: r('nsrc_' + h, '/results/tgt/src_' + h) for h in '$heights'.split()}
assert all(np.isfinite(x).all() for x in R.values()), 'non-finite positions'
worst = max(dev(R[a], R[b], d) for a in R for b in R)
assert worst < 1e-2, 'needle heights 0..1e-6 give results %.3g diagonals apart' % worst
print('heights 0..1e-6 agree within %.2g of the diagonal' % worst)"

# ------------------------------------------------- vertices in no triangle
job usrc src_unref tgt
if run topo-unreferenced-source usrc 'warning: source mesh .*:/meshes/src_unref: 1 vertex in no triangle \(vertex 86 first\)'; then
    check topo-unreferenced-source "
d = diag('clean', '/results/tgt/src')
e = dev(r('usrc', '/results/tgt/src_unref'), r('clean', '/results/tgt/src'), d)
assert e < 1e-9, 'the unused source vertex changed the result by %.3g diagonals' % e
print('same result as without the vertex (%.2g of the diagonal)' % e)"
fi
job utgt src tgt_unref
if run topo-unreferenced-target utgt 'warning: target mesh .*:/meshes/tgt_unref: 1 vertex in no triangle \(vertex 86 first\)'; then
    check topo-unreferenced-target "
X, T = r('utgt', '/results/tgt_unref/src'), rest('utgt', '/results/tgt_unref/src')
d = diag('utgt', '/results/tgt_unref/src')
want = X[:, :86].mean(1) + (T[86] - T[:86].mean(0))
e = np.abs(X[:, 86] - want).max() / d
assert e < 1e-9, 'vertex 86 is %.3g diagonals from its rest offset to the centroid' % e
print('vertex 86 keeps its rest offset from the centroid (%.2g of the diagonal)' % e)"
fi

echo "$pass passed, $fails failed"
[ "$fails" -eq 0 ]
