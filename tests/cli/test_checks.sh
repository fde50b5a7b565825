#!/usr/bin/env bash
# Honest checks: `dtx validate`, `dtx diff`, `dtx render` and `dtx report`
# on results that are not what they should be (NaN coordinates, frames not
# done, a moved source file), and an int64 face index that does not fit in
# 32 bits.  A check that says "valid" or "same" must have tested it; each
# check is tagged [row-id], and the README's "Bad input" table cites them.
# The inputs are made here: a UV sphere (tests/cli/bad_input_meshes.py), a
# 5-frame sp04 result, and copies of it altered with h5py.
set -uo pipefail
W="$DTX_TESTDATA"
PY=/usr/bin/python3
cd "$W" || exit 1
. "$DTX_SRC/tests/lib.sh"

# expect ROW RC PATTERN COMMAND...: exit status RC and output (stdout and
# stderr) matching PATTERN (extended regex).
expect() {
    local row=$1 want=$2 pattern=$3 msg rc; shift 3
    msg=$(bounded "$@" 2>&1); rc=$?
    if [ "$rc" -ne "$want" ]; then
        case $rc in 0) census "$row" false-success ;; 124) census "$row" hang ;;
                    1|2) census "$row" accept-failed ;; *) census "$row" crash ;; esac
        echo "FAILED: [$row] exit $rc (want $want): $*: $msg"; fails=$((fails + 1)); return
    fi
    if ! grep -qE -- "$pattern" <<<"$msg"; then
        census "$row" unclear-message
        echo "FAILED: [$row] output lacks /$pattern/: $msg"; fails=$((fails + 1)); return
    fi
    if [ "$want" -eq 0 ]; then census "$row" accepted; else census "$row" clear-error; fi
    echo "ok: [$row] $(grep -E -- "$pattern" <<<"$msg" | head -1)"
}

# ---------------------------------------------------------------- inputs
"$PY" "$DTX_SRC/tests/cli/bad_input_meshes.py" table > /dev/null || { echo "FAILED: meshes"; exit 1; }
printf 'source_vertex,target_vertex,label\n0,0,top\n85,85,bottom\n1,1,a\n4,4,b\n40,40,c\n' > markers.csv
"$DTX" import mesh src.obj -o in.h5 --name src 2>/dev/null &&
"$DTX" import mesh tgt.obj -o in.h5 --name tgt 2>/dev/null &&
"$DTX" import sequence src-1.obj src-2.obj src-3.obj src-1.obj src-2.obj -o in.h5 --name walk \
    --mesh /meshes/src --dtype float64 2>/dev/null || { echo "FAILED: import"; exit 1; }
cat > job.json <<'JOB'
{"dtx_job": 1, "method": "sp04",
 "source": {"file": "in.h5", "mesh": "/meshes/src", "sequences": ["/sequences/walk"]},
 "targets": [{"name": "tgt", "file": "in.h5", "mesh": "/meshes/tgt",
              "markers": {"csv": "markers.csv", "index_base": 0}}],
 "output": {"file": "out.h5", "dtype": "float64"}}
JOB
"$DTX" run --quiet job.json || { echo "FAILED: the job did not run"; exit 1; }
R=/results/tgt/walk
# Copies of out.h5: nan.h5 and nan2.h5 have a NaN at frame 2, vertex 5;
# inf.h5 an Inf there; part.h5 has frames 3 and 4 not done (complete = 0)
# and a NaN in frame 4; partnan.h5 is part.h5 with the NaN of nan.h5 too.
"$PY" - <<'PY' || { echo "FAILED: h5py copies"; exit 1; }
import h5py, numpy as np, shutil
R = "/results/tgt/walk"
def variant(name, fn, base="out.h5"):
    shutil.copy(base, name)
    with h5py.File(name, "r+") as f:
        fn(f)
def put(value, frame=2, vertex=5):
    def fn(f):
        p = f[R + "/positions"]; x = p[frame]; x[vertex, 1] = value; p[frame] = x
    return fn
def partial(f):
    d = f[R + "/frame_done"]; d[3] = 0; d[4] = 0
    f[R].attrs["complete"] = np.int32(0)
    put(np.nan, frame=4, vertex=0)(f)
variant("nan.h5", put(np.nan))
variant("nan2.h5", put(np.nan))
variant("inf.h5", put(np.inf))
variant("part.h5", partial)
variant("partnan.h5", put(np.nan), base="part.h5")
PY

# -------------------------------------------------------------- validate
expect validate-counts 0 "out\.h5: valid dtx layout v1 .*1 result, 5 of 5 frames checked \(finite\)" \
    "$DTX" validate out.h5
expect validate-counts 0 "1 sequence, 5 of 5 frames checked \(finite\)" "$DTX" validate in.h5
expect validate-nan 1 "$R/positions: 1 of 5 frames marked done holds non-finite coordinates; first frame 2 \(0-based\), vertex 5 \(nan\)" \
    "$DTX" validate nan.h5
expect validate-nan 1 "$R/positions: 1 of 5 frames marked done holds non-finite coordinates; first frame 2 \(0-based\), vertex 5 \(inf\)" \
    "$DTX" validate inf.h5
# A NaN in a frame not done is allowed (such frames hold undefined
# values); the summary says how many frames were read.
expect validate-not-done 0 "part\.h5: valid dtx layout v1 .*1 result, 3 of 5 frames checked \(finite; 2 not done\)" \
    "$DTX" validate part.h5
expect validate-nan 1 "first frame 2 \(0-based\)" "$DTX" validate partnan.h5
"$PY" -c '
import h5py
with h5py.File("in.h5", "r") as s, h5py.File("seqnan.h5", "w") as d:
    for k, v in s.attrs.items(): d.attrs[k] = v
    for g in ("meshes", "sequences"): s.copy(g, d)
    p = d["/sequences/walk/positions"]; x = p[4]; x[7, 0] = float("nan"); p[4] = x'
expect validate-seq-nan 1 "/sequences/walk/positions: 1 of 5 frames holds non-finite coordinates; first frame 4 \(0-based\), vertex 7" \
    "$DTX" validate seqnan.h5
"$PY" -c '
import h5py, shutil
shutil.copy("out.h5", "flag.h5")
with h5py.File("flag.h5", "r+") as f: f["/results/tgt/walk/frame_done"][1] = 2'
expect validate-flags 1 "$R/frame_done: 1 value out of range \[0, 2\) \(at most 1\); first 2 at \[1, 0\]" \
    "$DTX" validate flag.h5

# ------------------------------------------------------------------ diff
expect diff-same 0 "^same: within --tol 1e-12 over the 5 frames done in both" "$DTX" diff out.h5 out.h5 $R
expect diff-nan 1 "non-finite coordinates: 1 value in 1 frame; first frame 2 \(0-based\), vertex 5: [-0-9.e]+ in out\.h5, nan in nan\.h5" \
    "$DTX" diff out.h5 nan.h5 $R
expect diff-nan 1 "^differ" "$DTX" diff out.h5 nan.h5 $R --tol 1
# NaN in both at the same place is not "same" either.
expect diff-nan 1 "vertex 5: nan in nan\.h5, nan in nan2\.h5" "$DTX" diff nan.h5 nan2.h5 $R
expect diff-nan 1 "vertex 5: nan in nan\.h5, inf in inf\.h5" "$DTX" diff nan.h5 inf.h5 $R
# Frames done in one file only: not compared, named, and a difference.
expect diff-not-done 1 "not compared: 2 of 5 frames not done in both \(2 done only in out\.h5, 0 done only in part\.h5, 0 in neither\): 3, 4" \
    "$DTX" diff out.h5 part.h5 $R
# Frames not done in either: not compared (their NaN included), named.
expect diff-not-done 0 "not compared: 2 of 5 frames not done in both .*2 in neither\): 3, 4" \
    "$DTX" diff part.h5 part.h5 $R
expect diff-not-done 0 "over 3 of 5 frames \(done in both\)" "$DTX" diff part.h5 part.h5 $R
for t in abc 1e-9x ''; do
    expect diff-tol 2 "dtx: diff: --tol \"$t\" is not a number" "$DTX" diff out.h5 out.h5 $R --tol "$t"
done
for t in -1 nan inf -0.5; do
    expect diff-tol 2 "dtx: diff: --tol $t: want a finite relative tolerance >= 0" \
        "$DTX" diff out.h5 out.h5 $R --tol $t
done
expect diff-tol 2 "dtx: diff: --tol needs a value" "$DTX" diff out.h5 out.h5 $R --tol
expect diff-tol 0 "^same: within --tol 0 " "$DTX" diff out.h5 out.h5 $R --tol 0

# ---------------------------------------------------------------- render
expect render-nan 0 "dtx: warning: nan\.h5: $R: 1 of 5 frames have non-finite positions \(first: frame 2, vertex 5\); drawn frames among them: 2, labelled NAN" \
    "$DTX" render nan.h5 $R -o nan.png --no-source
check "[render-nan] the picture is written" test -s nan.png
expect render-nan 0 "drawn frames among them: none" "$DTX" render nan.h5 $R -o nan1.png --frames 0,1 --no-source
expect render-not-done 0 "dtx: warning: part\.h5: $R: 2 of 5 frames are not done \(first: frame 3\), their positions undefined; drawn frames among them: 3, 4, left empty and labelled NOT DONE" \
    "$DTX" render part.h5 $R -o part.png
# The NaN of part.h5 is in a frame not done: no NaN warning for it.
check "[render-not-done] no NaN warning for a frame not done" \
    bash -c "! '$DTX' render part.h5 $R -o part2.png 2>&1 | grep -q non-finite"
check "[render-nan] no warning for a clean result" \
    bash -c "! '$DTX' render out.h5 $R -o ok.png 2>&1 | grep -q warning"

# ---------------------------------------------------------------- report
# The result's source_sequence names in.h5; the files are moved.  The
# source is looked for as stored, then resolved against the result file's
# folder, then by its base name in that folder.  Run from another folder.
mkdir -p mv-rel/data mv-base mv-gone elsewhere
"$PY" - <<'PY' || echo "FAILED: [report-moved-source] h5py copies"
import h5py, shutil
for d, ref in (("mv-rel", "data/in.h5:/sequences/walk"),
               ("mv-base", "/nowhere/data/in.h5:/sequences/walk"),
               ("mv-gone", "/nowhere/data/in.h5:/sequences/walk")):
    shutil.copy("out.h5", d + "/out.h5")
    with h5py.File(d + "/out.h5", "r+") as f:
        f["/results/tgt/walk"].attrs["source_sequence"] = ref
shutil.copy("in.h5", "mv-rel/data/in.h5")
shutil.copy("in.h5", "mv-base/in.h5")
PY
cd elsewhere
for d in mv-rel mv-base; do
    expect report-moved-source 0 "dtx: report: \.\./$d/out\.report\.md" "$DTX" report ../$d/out.h5
    check "[report-moved-source] $d: the contact sheet is linked" \
        grep -q '^!\[/results/tgt/walk: source above, result below\](out.report-pictures/tgt-walk.png)$' ../$d/out.report.md
    check "[report-moved-source] $d: no warning" bash -c "! '$DTX' report ../$d/out.h5 -o r-$d.md 2>&1 | grep -q warning"
done
expect report-missing-source 0 "dtx: warning: \.\./mv-gone/out\.h5: $R: the file of the source sequence \"/nowhere/data/in\.h5:/sequences/walk\" is missing or unreadable: /nowhere/data/in\.h5 \(also looked for \.\./mv-gone/in\.h5\); the contact sheet of $R is left out of the report" \
    "$DTX" report ../mv-gone/out.h5
check "[report-missing-source] no 'dtx: error' with exit 0" \
    bash -c "! '$DTX' report ../mv-gone/out.h5 -o gone2.md 2>&1 | grep -q 'dtx: error'"
check "[report-missing-source] the page says the sheet is left out" \
    grep -q '^(No contact sheet: .*is missing or unreadable: /nowhere/data/in\.h5 ' ../mv-gone/out.report.md
check "[report-missing-source] the page links no picture" bash -c '! grep -q "^!\[" ../mv-gone/out.report.md'
check "[report-missing-source] the rest of the page is there" grep -q '^- frames: 5, 5 done, complete$' ../mv-gone/out.report.md
# dtx render itself keeps it an error (exit 1), with the hint.
expect report-missing-source 1 "dtx: error: .*missing or unreadable.*; use --no-source to draw the result alone" \
    "$DTX" render ../mv-gone/out.h5 $R -o gone.png
cd ..

# ------------------------------------------- 64-bit indices from h5py
# Faces stored as int64 by another program: a value past 32 bits is
# reported as it is (it used to be clamped to 2147483647 on reading).
"$PY" - <<'PY' || echo "FAILED: [h5-index-64bit] h5py copies"
import h5py, numpy as np, shutil
def variant(name, value, dtype):
    shutil.copy("in.h5", name)
    with h5py.File(name, "r+") as f:
        g = f["/meshes/src"]
        F = g["faces"][...].astype(dtype)
        if value is not None:
            F[1, 2] = value
        del g["faces"]; g["faces"] = F
        del g.attrs["content_hash"]
variant("f64.h5", 2**32 + 3, "i8")
variant("fneg.h5", -2**40, "i8")
variant("fu64.h5", 2**64 - 1, "u8")
variant("fok.h5", None, "i8")
PY
for v in "f64.h5 4294967299" "fneg.h5 -1099511627776" "fu64.h5 18446744073709551615"; do
    set -- $v
    expect h5-index-64bit 1 "$1: /sequences/walk/rest/faces: face 1 \(0-based\) holds $2, which does not fit in the 32-bit indices dtx reads" \
        "$DTX" export $1 /sequences/walk --obj-dir obj-$1
done
# In range int64 faces are read (the layout asks for int32; validate says so).
expect h5-index-64bit 0 "" "$DTX" export fok.h5 /sequences/walk --obj-dir obj-ok
expect h5-index-64bit 1 "/meshes/src/faces: expected 32-bit signed integer values, found 64-bit" \
    "$DTX" validate f64.h5

# Special files where the checking commands read: a FIFO as the file to
# validate, and a FIFO as the run summary beside a result (inspect, report):
# refused or left out at once, never a hang (timeout 20 turns a hang into a
# failure).
mkfifo fifo.h5 && cp out.h5 sumfifo.h5 && mkfifo sumfifo.h5.summary.json
expect special-validate 1 "fifo\.h5: not a regular file \(a FIFO\)" timeout 20 "$DTX" validate fifo.h5
expect special-summary 0 "sumfifo\.h5" timeout 20 "$DTX" inspect sumfifo.h5
expect special-summary 1 "the run summary: .*sumfifo\.h5\.summary\.json: not a regular file \(a FIFO\)" \
    timeout 20 "$DTX" report sumfifo.h5 --no-pictures

# dtx keypoints checks its --name against the layout's name rule before
# computing anything (usage error, exit 2).
for nm in .. . .dtx-tmp-k; do
    expect import-name 2 "--name \"$nm\" must be .*not \. or \.\. and not starting with \.dtx-" \
        "$DTX" keypoints in.h5 --mesh /meshes/src --sequence /sequences/walk --name "$nm"
done

# export, render and report never write over their input: an output naming
# the input file (also through a symbolic link) is refused before anything is
# read, and the input is unchanged.
cp out.h5 keep.h5 && ln -sf out.h5 out-link.h5
for o in --pc2 --mdd --glb --obj-rest; do
    expect out-is-input 1 "out-link\.h5 \($o\) is also an input \(the input file out\.h5\): dtx does not write over" \
        "$DTX" export out.h5 $R $o out-link.h5
done
expect out-is-input 1 "out\.h5 \(the picture, -o\) is also an input \(the input file out\.h5\)" "$DTX" render out.h5 $R -o out.h5
expect out-is-input 1 "out\.h5 \(the report page\) is also an input \(the result file out\.h5\)" "$DTX" report out.h5 -o out.h5 --no-pictures
expect out-is-input 1 "out\.h5\.summary\.json \(the report page\) is also an input \(the run summary out\.h5\.summary\.json\)" \
    "$DTX" report out.h5 -o out.h5.summary.json --no-pictures
check "[out-is-input] the input is unchanged" cmp -s out.h5 keep.h5

finish
