#!/usr/bin/env bash
# One job with two targets x two sequences, run at 1 rank, 3 ranks and
# 2 ranks x 2 threads: every result and every correspondence must be bitwise
# identical between the runs (results must not depend on how frames are dealt
# to ranks and threads), complete and valid.
#
# Targets: the lion with the bundled markers, and the cat itself ("catself")
# with identity markers on the same source vertices. The cat onto itself is a
# case with a known answer: the correspondence is the identity on triangles
# and the transfer reproduces every source frame up to a translation.
# Sequences: the 9 cat poses (float64) and 150 frames that are the pose OBJs
# in a scrambled order (float32), so frame t of the long result must equal
# the result of its pose in the short one.
#
# Also: jobs whose results would collide are refused before anything is
# written (two targets with one name; two sequences with one base name, which
# would both go to /results/<target>/<base name>).
set -euo pipefail
D="$DTX_BUILD/data/sumner-cat-lion"
W="$DTX_TESTDATA"
PY=/usr/bin/python3
. "$DTX_SRC/tests/lib.sh"
quiet() { "$@" > /dev/null; } # quiet COMMAND...: its stdout discarded
stray() { # stray DIR GLOB...: the names of the files in DIR matching the globs
    local d=$1 g f
    shift
    for g in "$@"; do
        for f in "$d"/$g; do [ -e "$f" ] && echo "${f##*/}"; done
    done
    return 0
}
t_start=$SECONDS

# ---- inputs ---------------------------------------------------------------
"$DTX" import mesh "$D/source/cat-reference.obj" -o "$W/in.h5" --name cat 2> /dev/null
"$DTX" import mesh "$D/target/lion-reference.obj" -o "$W/in.h5" --name lion 2> /dev/null
"$DTX" import sequence "$D"/source/cat-0[1-9].obj -o "$W/in.h5" --name poses --mesh /meshes/cat \
    --dtype float64 2> /dev/null
# 150 frames (not a multiple of the 8-frame solve group) in a fixed scrambled
# order; order.txt holds the 0-based pose index of every frame.
files=()
: > "$W/order.txt"
for t in $(seq 0 149); do
    p=$(( (t * t * 7 + t * 3 + t / 4) % 9 ))
    files+=("$D/source/cat-0$((p + 1)).obj")
    echo $p >> "$W/order.txt"
done
"$DTX" import sequence "${files[@]}" -o "$W/in.h5" --name long --mesh /meshes/cat 2> /dev/null
"$DTX" import markers "$D/markers.csv" --index-base 0 -o "$W/in.h5" --name cat-lion \
    --source /meshes/cat --target /meshes/lion 2> /dev/null
awk -F, 'NR == 1 { print; next } { print $1 "," $1 ",self " $1 }' "$D/markers.csv" > "$W/self.csv"
"$DTX" import markers "$W/self.csv" --index-base 0 -o "$W/in.h5" --name cat-self \
    --source /meshes/cat --target /meshes/cat 2> /dev/null

job() { # job NAME [SEQUENCES-JSON [TARGETS-JSON]]
    local seqs=${2:-'"/sequences/poses", "/sequences/long"'}
    local tgts=${3:-'{"name": "lion", "file": "in.h5", "mesh": "/meshes/lion",
                "markers": {"file": "in.h5", "path": "/markers/cat-lion"}},
               {"name": "catself", "file": "in.h5", "mesh": "/meshes/cat",
                "markers": {"file": "in.h5", "path": "/markers/cat-self"}}'}
    cat > "$W/$1.json" <<JOB
{
  "dtx_job": 1,
  "method": "sp04",
  "source": {"file": "in.h5", "mesh": "/meshes/cat", "sequences": [$seqs]},
  "targets": [$tgts],
  "output": {"file": "$1.h5", "dtype": "float64", "block_frames": 8}
}
JOB
}

cat > "$W/check.py" <<'PY'
import json, sys
import h5py, numpy as np

def datasets(f):
    out = {}
    def visit(name, obj):
        if isinstance(obj, h5py.Dataset) and name.split("/")[0] in (
                "results", "correspondences", "meshes"):
            out[name] = obj
    f.visititems(visit)
    return out

def same(a, b):
    """Every result, correspondence and mesh dataset bitwise equal."""
    with h5py.File(a, "r") as fa, h5py.File(b, "r") as fb:
        da, db = datasets(fa), datasets(fb)
        if sorted(da) != sorted(db):
            print("  datasets differ: %s vs %s" % (sorted(da), sorted(db)))
            return 1
        bad = 0
        for name in sorted(da):
            x, y = da[name], db[name]
            if x.dtype != y.dtype or x.shape != y.shape:
                print("  %s: %s %s vs %s %s" % (name, x.dtype, x.shape, y.dtype, y.shape))
                bad += 1
                continue
            xv, yv = x[...], y[...]
            if xv.tobytes() != yv.tobytes():
                diff = np.flatnonzero(xv.reshape(-1).view(np.uint8) != yv.reshape(-1).view(np.uint8))
                print("  %s: not bitwise equal (%d differing bytes, first at byte %d)"
                      % (name, diff.size, diff[0]))
                bad += 1
        print("  %d datasets compared, %d differ" % (len(da), bad))
        return 1 if bad else 0

def content(out, inp, order_file):
    """The known answers: shapes, completeness, the identity correspondence
    and transfer of the cat onto itself, long frames equal to their poses."""
    order = np.loadtxt(order_file, dtype=int)
    bad = []
    with h5py.File(out, "r") as f, h5py.File(inp, "r") as g:
        nv = {"lion": g["/meshes/lion/vertices"].shape[0], "catself": g["/meshes/cat/vertices"].shape[0]}
        T = {"poses": 9, "long": len(order)}
        for t in ("lion", "catself"):
            for s in ("poses", "long"):
                r = f["/results/%s/%s" % (t, s)]
                if r["positions"].shape != (T[s], nv[t], 3):
                    bad.append("%s/%s positions shape %s" % (t, s, r["positions"].shape))
                    continue
                if int(r.attrs["complete"]) != 1 or not np.all(r["frame_done"][...] == 1):
                    bad.append("%s/%s not complete" % (t, s))
                if not np.all(np.isfinite(r["residual"][...])):
                    bad.append("%s/%s residual not finite" % (t, s))
        for t in ("lion", "catself"):
            if "/correspondences/%s/pairs" % t not in f:
                bad.append("no correspondence for %s" % t)
        if bad:
            print("  " + "\n  ".join(bad))
            return 1
        nf = g["/meshes/cat/faces"].shape[0]
        pairs = f["/correspondences/catself/pairs"][...]
        ident = pairs.shape == (nf, 2) and np.array_equal(pairs[:, 0], np.arange(nf)) \
            and np.array_equal(pairs[:, 1], np.arange(nf))
        print("  catself correspondence: %d pairs for %d triangles, identity: %s"
              % (pairs.shape[0], nf, ident))
        if not ident:
            bad.append("the cat's correspondence onto itself is not the identity")
        rest = g["/meshes/cat/vertices"][...]
        diag = np.linalg.norm(rest.max(0) - rest.min(0))
        for s in ("poses", "long"):
            src = g["/sequences/%s/positions" % s][...].astype(np.float64)
            res = f["/results/catself/%s/positions" % s][...]
            d = (res - res.mean(1, keepdims=True)) - (src - src.mean(1, keepdims=True))
            e = np.abs(d).max() / diag
            print("  catself/%s reproduces the source up to translation: max error %.2e of the diagonal"
                  % (s, e))
            if not e < 1e-9:
                bad.append("catself/%s does not reproduce the source (%.2e)" % (s, e))
        for t in ("lion", "catself"):
            short = f["/results/%s/poses/positions" % t][...]
            long_ = f["/results/%s/long/positions" % t][...]
            scale = np.abs(short).max()
            e = np.abs(long_ - short[order]).max() / scale
            # float32 input frames vs float64 ones: agree to float32 rounding.
            print("  %s/long frame t == %s/poses frame order[t]: max relative difference %.2e"
                  % (t, t, e))
            if not e < 1e-5:
                bad.append("%s/long frames are not the results of their poses (%.2e)" % (t, e))
            if not np.abs(short[1:] - short[:1]).max() > 1e-3 * scale:
                bad.append("%s/poses frames are all the same" % t)
    if bad:
        print("  " + "\n  ".join(bad))
        return 1
    return 0

def summary(path, frames):
    """The run summary: the contract's keys, the frame count, fresh correspondences."""
    s = json.load(open(path))
    bad = []
    for k in ("frames", "frames_per_second", "seconds", "residual", "peak_rss_mb",
              "correspondences", "frames_skipped"):
        if k not in s:
            bad.append("no key %r" % k)
    for k in ("read", "correspondence", "factor", "transfer", "write", "total"):
        if not isinstance(s.get("seconds", {}).get(k), (int, float)):
            bad.append("no seconds.%s" % k)
    for k in ("mean", "max"):
        if not isinstance(s.get("residual", {}).get(k), (int, float)):
            bad.append("no residual.%s" % k)
    if s.get("frames") != frames:
        bad.append("frames %r, expected %d" % (s.get("frames"), frames))
    if s.get("frames_skipped", 0) != 0:
        bad.append("frames_skipped %r in a fresh run" % s.get("frames_skipped"))
    if s.get("correspondences") != {"lion": "computed", "catself": "computed"}:
        bad.append("correspondences %r, expected both computed" % s.get("correspondences"))
    if not isinstance(s.get("peak_rss_mb"), (int, float)) or not s["peak_rss_mb"] > 0:
        bad.append("peak_rss_mb %r" % s.get("peak_rss_mb"))
    if bad:
        print("  %s: %s" % (path, "; ".join(bad)))
    return 1 if bad else 0

cmd = sys.argv[1]
if cmd == "same":
    sys.exit(same(sys.argv[2], sys.argv[3]))
if cmd == "content":
    sys.exit(content(sys.argv[2], sys.argv[3], sys.argv[4]))
if cmd == "summary":
    sys.exit(summary(sys.argv[2], int(sys.argv[3])))
sys.exit("check.py: unknown command " + cmd)
PY

# ---- the runs -------------------------------------------------------------
job np1
job np3
job np2t2
run() { # run NAME THREADS MPIRUN-ARGS...
    local name=$1 threads=$2; shift 2
    local t0=$SECONDS
    OMP_NUM_THREADS=$threads mpirun "$@" "$DTX" run --quiet "$W/$name.json"
    echo "run $name: $((SECONDS - t0)) s"
}
run np1 1 -np 1
run np3 1 --oversubscribe --bind-to none -np 3
run np2t2 2 --oversubscribe --bind-to none -np 2

for r in np1 np3 np2t2; do
    check "$r: output validates" quiet "$DTX" validate "$W/$r.h5"
    check "$r: summary has the contract's keys, 318 frames, both correspondences computed" \
        $PY "$W/check.py" summary "$W/$r.h5.summary.json" 318
done
check "np1: known answers (identity cat, long frames = their poses)" \
    $PY "$W/check.py" content "$W/np1.h5" "$W/in.h5" "$W/order.txt"
check "1 rank == 3 ranks, bitwise, every result and correspondence" \
    $PY "$W/check.py" same "$W/np1.h5" "$W/np3.h5"
check "1 rank == 2 ranks x 2 threads, bitwise, every result and correspondence" \
    $PY "$W/check.py" same "$W/np1.h5" "$W/np2t2.h5"
for r in lion/poses lion/long catself/poses catself/long; do
    check "dtx diff --tol 0: $r equal at 1 and 3 ranks" \
        quiet "$DTX" diff "$W/np1.h5" "$W/np3.h5" /results/$r --tol 0
done
# The comparison itself must see a one-ulp change in one coordinate.
cp "$W/np1.h5" "$W/ulp.h5"
$PY -c 'import sys, h5py, numpy as np
with h5py.File(sys.argv[1], "r+") as f:
    d = f["/results/catself/long/positions"]
    d[77, 123, 1] = np.nextafter(d[77, 123, 1], np.inf)' "$W/ulp.h5"
check "the bitwise comparison sees a one-ulp change" \
    bash -c "! $PY '$W/check.py' same '$W/np1.h5' '$W/ulp.h5'"
rm -f "$W/ulp.h5"
check "no temporary or partial file left" \
    test -z "$(stray "$W" '*.tmp*' '*.partial')"

# ---- jobs whose results would collide are refused -------------------------
refused() { # refused NAME GREP-PATTERN: the run fails, says why, writes nothing
    local name=$1 pattern=$2 rc=0
    OMP_NUM_THREADS=1 mpirun -np 1 "$DTX" run "$W/$name.json" 2> "$W/$name.log" || rc=$?
    grep '^dtx: error' "$W/$name.log" | sed 's/^/  | /' || true
    [ "$rc" -ne 0 ] && grep -q -- "$pattern" "$W/$name.log" && [ -z "$(stray "$W" "$name.h5*")" ]
}
job dupname '"/sequences/poses"' \
    '{"name": "lion", "file": "in.h5", "mesh": "/meshes/lion",
      "markers": {"file": "in.h5", "path": "/markers/cat-lion"}},
     {"name": "lion", "file": "in.h5", "mesh": "/meshes/cat",
      "markers": {"file": "in.h5", "path": "/markers/cat-self"}}'
check "two targets named lion: refused, naming /targets/1" refused dupname '/targets/1'

# A name is one path part (dtx import refuses "more/poses"): the nested
# sequence another program could write is made by moving an imported one.
"$DTX" import sequence "$D/source/cat-03.obj" "$D/source/cat-04.obj" -o "$W/in.h5" \
    --name more-poses --mesh /meshes/cat 2> /dev/null
"$PY" -c 'import sys, h5py
with h5py.File(sys.argv[1], "r+") as f:
    f.create_group("/sequences/more")
    f.move("/sequences/more-poses", "/sequences/more/poses")' "$W/in.h5"
job dupbase '"/sequences/poses", "/sequences/more/poses"' \
    '{"name": "lion", "file": "in.h5", "mesh": "/meshes/lion",
      "markers": {"file": "in.h5", "path": "/markers/cat-lion"}}'
check "sequences /sequences/poses and /sequences/more/poses (both /results/lion/poses): refused" \
    refused dupbase 'more/poses'

echo "runtime $((SECONDS - t_start)) s"
finish
