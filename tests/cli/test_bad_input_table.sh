#!/usr/bin/env bash
# The bad-input table (README, "Bad input"), one check per row, through the
# dtx command.  A rejected input must give a non-zero exit, a message naming
# the file, the item (line, vertex, face, dataset path, JSON pointer) and the
# problem, and leave no output (neither OUTPUT nor OUTPUT.partial).  An
# accepted input must give exit 0, the warning the table promises, and a
# result that is finite and passes `dtx validate`.  Every check is tagged
# [row-id]; the table cites the tags.  Rows already covered by
# cli.bad_input are not repeated here.
set -uo pipefail
. "$DTX_SRC/tests/lib.sh"
# Runs that must not allocate before checking sizes do so under a 1 GiB
# address-space limit; a sanitizer build reserves terabytes of shadow memory
# at start, so there the limit is left off (the plain build checks it).
if [[ $(ldd "$DTX") == *libasan* ]]; then VLIMIT=""; else VLIMIT="ulimit -v 1048576;"; fi
W="$DTX_TESTDATA"
PY=/usr/bin/python3
cd "$W" || exit 1
pass=0 fails=0
ok() { echo "ok: [$1] $2"; pass=$((pass + 1)); }
bad() { echo "FAILED: [$1] $2"; fails=$((fails + 1)); }

# reject ROW OUTPUT PATTERN COMMAND...: non-zero exit, a message matching
# PATTERN (extended regex), and neither OUTPUT nor OUTPUT.partial nor the
# lock OUTPUT.lock left.
reject() {
    local row=$1 out=$2 pattern=$3 msg rc; shift 3
    msg=$(bounded "$@" 2>&1); rc=$?
    if [ $rc -eq 0 ]; then census "$row" false-success; bad "$row" "exit 0: $msg"; return; fi
    if [ $rc -eq 124 ]; then census "$row" hang; bad "$row" "no answer in 120 s (a hang?): $msg"; return; fi
    if [ $rc -gt 2 ]; then census "$row" crash; bad "$row" "exit $rc (a crash?): $msg"; return; fi
    if ! grep -qE -- "$pattern" <<<"$msg"; then
        census "$row" unclear-message; bad "$row" "message lacks /$pattern/: $msg"; return
    fi
    if [ -n "$out" ] && { [ -e "$out" ] || [ -e "$out.partial" ] || [ -e "$out.lock" ]; }; then
        census "$row" leftovers; bad "$row" "$out, $out.partial or $out.lock was left behind"; return
    fi
    census "$row" clear-error
    ok "$row" "$(head -1 <<<"$msg")"
}

# accept ROW PATTERN COMMAND...: exit 0 and, when PATTERN is not empty, a
# message (warning) matching it.
accept() {
    local row=$1 pattern=$2 msg rc; shift 2
    msg=$(bounded "$@" 2>&1); rc=$?
    if [ $rc -eq 124 ]; then census "$row" hang; bad "$row" "no answer in 120 s (a hang?)"; return 1; fi
    if [ $rc -ne 0 ]; then census "$row" accept-failed; bad "$row" "exit $rc: $msg"; return 1; fi
    if [ -n "$pattern" ] && ! grep -qE -- "$pattern" <<<"$msg"; then
        census "$row" unclear-message; bad "$row" "message lacks /$pattern/: $msg"; return 1
    fi
    census "$row" accepted
    ok "$row" "$(grep -E -- "${pattern:-.}" <<<"$msg" | head -1)"
}

# finite_valid ROW FILE RESULT...: every position of each result is finite,
# no coordinate is further than 10 bounding-box diagonals of its target from
# the target's centroid (nothing blew up), and the file validates.
finite_valid() {
    local row=$1 file=$2 msg; shift 2
    if ! msg=$("$PY" - "$file" "$@" <<'PY' 2>&1
import sys, h5py, numpy as np
f = h5py.File(sys.argv[1], "r")
for r in sys.argv[2:]:
    p = f[r + "/positions"][...]
    t = f[r + "/target/vertices"][...]
    assert np.isfinite(p).all(), r + ": non-finite positions"
    assert np.isfinite(f[r + "/residual"][...]).all(), r + ": non-finite residual"
    diag = np.linalg.norm(t.max(0) - t.min(0))
    far = np.abs(p - t.mean(0)).max() / diag
    assert far < 10, "%s: a vertex %.3g diagonals away: the result blew up" % (r, far)
PY
    ); then bad "$row" "$file: $msg"; return; fi
    if ! msg=$("$DTX" validate "$file" 2>&1); then bad "$row" "$file does not validate: $msg"; return; fi
    ok "$row" "$file: results finite and bounded, file validates"
}

# ---------------------------------------------------------------- inputs
# A small closed source (a UV sphere, 86 vertices), a target of the same
# connectivity and three source poses; then variants, each the clean mesh
# with one defect.
"$PY" "$DTX_SRC/tests/cli/bad_input_meshes.py" table || bad setup "generating the meshes"
cat > markers.csv <<'CSV'
source_vertex,target_vertex,label
0,0,top
85,85,bottom
1,1,a
4,4,b
40,40,c
CSV
imp() { "$DTX" import mesh "$1.obj" -o in.h5 --name "$1" 2>/dev/null || bad setup "import $1"; }
for m in src tgt tgt_two src_two tgt_seam tgt_unref tgt_dup tgt_nonman src_nonman tgt_dupface \
         tgt_zero src_zero; do imp $m; done
for s in src src_two src_nonman src_zero; do
    "$DTX" import sequence $s-1.obj $s-2.obj $s-3.obj -o in.h5 --name $s --mesh /meshes/$s \
        --dtype float64 2>/dev/null || bad setup "import sequence $s"
done
"$DTX" import sequence src-1.obj pose_collapsed.obj pose_point.obj -o in.h5 --name collapsing \
    --mesh /meshes/src --dtype float64 2>/dev/null || bad setup "import sequence collapsing"

# job NAME SOURCE SEQUENCE TARGET...: NAME.json, output NAME.h5, CSV markers.
job() {
    local name=$1 src=$2 seq=$3 sep="" t; shift 3
    { printf '{"dtx_job": 1, "method": "sp04",\n "source": {"file": "in.h5", "mesh": "/meshes/%s", "sequences": ["/sequences/%s"]},\n "targets": [' "$src" "$seq"
      for t in "$@"; do
          printf '%s\n  {"name": "%s", "file": "in.h5", "mesh": "/meshes/%s", "markers": {"csv": "markers.csv", "index_base": 0}}' "$sep" "$t" "$t"
          sep=,
      done
      printf '],\n "output": {"file": "%s.h5", "dtype": "float64"}}\n' "$name"; } > "$name.json"
}

# ------------------------------------------------------------ mesh files
# Each bad file through `dtx import mesh`: no output file may appear.
w() { printf "$2" > "$1"; }
imp_rej() { reject "$1" out.h5 "$3" "$DTX" import mesh "$2" -o out.h5 --name m; }
tri='v 0 0 0\nv 1 0 0\nv 0 1 0\n'
plyh='ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n'
w e.obj ''; w e.off ''; w e.ply ''
imp_rej mesh-empty-obj e.obj 'e\.obj: empty file'
imp_rej mesh-empty-off e.off 'e\.off: empty file'
imp_rej mesh-empty-ply e.ply 'e\.ply: not a PLY file'
w t.obj "${tri}f 1 2"
imp_rej mesh-truncated-obj t.obj 't\.obj:4: face with 2 vertices'
w t.off 'OFF\n3 1 0\n0 0 0\n1 0 0\n'
imp_rej mesh-truncated-off t.off 't\.off: file ends after 2 of 3 vertices'
w t.ply "${plyh}0 0 0\n1 0 0\n"
imp_rej mesh-truncated-ply t.ply 't\.ply: the header declares 3 vertices and 1 faces.*truncated'
"$PY" - <<'PY'
import struct
hdr = (b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
       b"property float y\nproperty float z\nelement face 1\n"
       b"property list uchar int vertex_indices\nend_header\n")
v = struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0)
f = struct.pack("<B3i", 3, 0, 1, 2)
open("tb.ply", "wb").write(hdr + v + f[:7])
open("nanb.ply", "wb").write(hdr + struct.pack("<9f", 0, 0, 0, 1, float("nan"), 0, 0, 1, 0) + f)
open("hugeb.ply", "wb").write(hdr.replace(b"vertex 3", b"vertex 2000000000") + v + f)
PY
imp_rej mesh-truncated-plybin tb.ply 'tb\.ply: .*truncated'
head -c 4096 /dev/urandom > g.bin
for x in obj off ply; do cp g.bin g.$x; done
imp_rej mesh-garbage-obj g.obj 'g\.obj: not a text file'
imp_rej mesh-garbage-off g.off 'g\.off: not a text file'
imp_rej mesh-garbage-ply g.ply 'g\.ply: not a PLY file'
# Garbage without NUL bytes (printable noise).
tr -dc 'a-z0-9 .\n/-' < /dev/urandom | head -c 4096 > n.obj
imp_rej mesh-garbage-text-obj n.obj 'n\.obj(:[0-9]+)?: '
w u.obj "${tri}foo bar\nf 1 2 3\n"
accept mesh-unknown-obj "u\.obj:4: unknown keyword 'foo' ignored" "$DTX" import mesh u.obj -o u.h5 --name m
w u.off 'OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\nfoo\n'
accept mesh-unknown-off 'u\.off:7: data after the last face ignored' "$DTX" import mesh u.off -o u.h5 --name m2
w u.ply "${plyh/format ascii 1.0\\n/format ascii 1.0\\nfoo bar\\n}0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"
imp_rej mesh-unknown-ply u.ply "u\.ply:3: unknown header keyword 'foo'"
w q.obj 'v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 1.5 0\nf 1 2 3 4 5\n'
accept mesh-ngon-obj 'q\.obj.*(polygon|triangulat)' "$DTX" import mesh q.obj -o u.h5 --name q
nq=$("$PY" -c 'import h5py; print(h5py.File("u.h5", "r")["/meshes/q/faces"].shape[0])' 2>&1)
if [ "$nq" = 3 ]; then ok mesh-ngon-obj "a pentagon became 3 triangles"
else bad mesh-ngon-obj "a pentagon did not become 3 triangles: $nq"; fi
w m.off 'OFF\n3 1 0\n0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n'
imp_rej mesh-malformed-off m.off 'm\.off:4: '
w m.ply "${plyh/element vertex 3/element vertex three}"
imp_rej mesh-malformed-ply m.ply 'm\.ply:3: '
w z.obj "${tri}f 0 1 2\n"
imp_rej mesh-index0-obj z.obj 'z\.obj:4: face index 0 \(OBJ indices start at 1\)'
w r.off 'OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n'
imp_rej mesh-range-off r.off 'r\.off:6: face vertex index 3 out of range \[0, 3\)'
w r.ply "${plyh}0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n"
imp_rej mesh-range-ply r.ply 'r\.ply:13: face 0 \(0-based\): vertex index 3 out of range'
w neg.obj "${tri}f -1 -2 -4\n"
imp_rej mesh-negative-obj neg.obj 'neg\.obj:4: relative face index -4 refers before the first vertex'
w neg.off 'OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 -1\n'
imp_rej mesh-negative-off neg.off 'neg\.off:6: face vertex index -1 out of range'
w neg.ply "${plyh}0 0 0\n1 0 0\n0 1 0\n3 0 1 -1\n"
imp_rej mesh-negative-ply neg.ply 'neg\.ply:13: face 0 \(0-based\): vertex index -1 out of range'
w inf.obj 'v 0 0 0\nv 1 0 inf\nv 0 1 0\nf 1 2 3\n'
imp_rej mesh-nonfinite-obj inf.obj 'inf\.obj:2: vertex 2 has a non-finite coordinate'
w inf.off 'OFF\n3 1 0\n0 0 0\n1 -inf 0\n0 1 0\n3 0 1 2\n'
imp_rej mesh-nonfinite-off inf.off 'inf\.off:4: vertex 1 \(0-based\) has a non-finite coordinate'
w nan.ply "${plyh}0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n"
imp_rej mesh-nonfinite-ply nan.ply 'nan\.ply:11: vertex 1 \(0-based\) has a non-finite coordinate'
imp_rej mesh-nonfinite-plybin nanb.ply 'nanb\.ply.*vertex 1 \(0-based\) has a non-finite coordinate'
# Huge counts: refused from the file size before anything is allocated
# (under a 1 GiB address-space limit an allocation would fail differently).
w huge.off 'OFF\n2000000000 2000000000 0\n0 0 0\n'
reject mesh-huge-off out.h5 'huge\.off:2: the counts \(2000000000 vertices, 2000000000 faces\) cannot fit' \
    bash -c "$VLIMIT exec '$DTX' import mesh huge.off -o out.h5 --name m"
w huge.ply "${plyh/element vertex 3/element vertex 4000000000}0 0 0\n"
reject mesh-huge-ply out.h5 'huge\.ply: 4000000000 vertices and 1 faces declared \(at most 2147483647' \
    bash -c "$VLIMIT exec '$DTX' import mesh huge.ply -o out.h5 --name m"
reject mesh-huge-plybin out.h5 'hugeb\.ply: the header declares 2000000000 vertices.*need at least 24000000001 bytes' \
    bash -c "$VLIMIT exec '$DTX' import mesh hugeb.ply -o out.h5 --name m"
# A failed import into an existing file leaves it valid and without the mesh.
cp in.h5 keep.h5
reject mesh-into-existing "" 'inf\.obj:2' "$DTX" import mesh inf.obj -o keep.h5 --name broken
if "$DTX" validate keep.h5 >/dev/null 2>&1 && ! h5ls keep.h5/meshes/broken >/dev/null 2>&1; then
    ok mesh-into-existing "keep.h5 still valid, no /meshes/broken"
else
    bad mesh-into-existing "keep.h5 damaged by the failed import"
fi
# A face that repeats a vertex, in a mesh another program wrote: dtx run
# (and dtx validate) reject the mesh naming the face.  (dtx import mesh:
# cli.import_checks.)
cp in.h5 rep.h5
"$PY" -c '
import h5py
with h5py.File("rep.h5", "r+") as f:
    g = f["/meshes/src"]
    del g.attrs["content_hash"]
    F = g["faces"][...]; F[0] = [0, 0, 1]; g["faces"][...] = F'
job repjob src src tgt
sed -i 's#"source": {"file": "in.h5"#"source": {"file": "rep.h5"#' repjob.json
reject mesh-repeated-vertex repjob.h5 'rep\.h5: /meshes/src: face 0 \(0-based\) repeats a vertex \(0 0 1\)' \
    "$DTX" run repjob.json
reject mesh-repeated-vertex "" '/meshes/src: face 0 \(0-based\) repeats a vertex \(0 0 1\)' "$DTX" validate rep.h5

# ------------------------------------------------------------- sequences
# (A frame with another vertex count: cli.bad_input.)
cp in.h5 seq.h5
"$PY" - <<'PY'
lines = open("src-2.obj").read().splitlines()
f = [i for i, l in enumerate(lines) if l.startswith("f ")]
a, b = lines[f[0]], lines[f[1]]
lines[f[0]], lines[f[1]] = b, a            # same vertices, faces reordered
open("frame-faces.obj", "w").write("\n".join(lines) + "\n")
lines = open("src-2.obj").read().splitlines()
lines[6] = "v 0.5 nan 0.25"
open("frame-nan.obj", "w").write("\n".join(lines) + "\n")
PY
reject seq-frame-faces "" 'frame-faces\.obj: frame 1 has different faces from the rest mesh /meshes/src' \
    "$DTX" import sequence src-1.obj frame-faces.obj -o seq.h5 --name bad --mesh /meshes/src
reject seq-frame-nonfinite "" 'frame-nan\.obj:7: vertex 7 has a non-finite coordinate' \
    "$DTX" import sequence src-1.obj frame-nan.obj -o seq.h5 --name bad --mesh /meshes/src
if "$DTX" validate seq.h5 >/dev/null 2>&1 && ! h5ls seq.h5/sequences/bad >/dev/null 2>&1; then
    ok seq-frame-nonfinite "seq.h5 still valid, no /sequences/bad"
else
    bad seq-frame-nonfinite "seq.h5 damaged by the failed imports"
fi

# A failed import into an existing file leaves it as it was: no temporary
# group anywhere, and not one byte more (HDF5 keeps the space of unlinked
# data, so frames written before the bad one would stay as dead bytes).
# 20 good frames first: more than one 16-frame chunk.
for i in $(seq -w 1 20); do cp src-2.obj ok-$i.obj; done
"$PY" - <<'PY'
lines = open("src-2.obj").read().splitlines()
v = [l for l in lines if l.startswith("v ")]
f = [l for l in lines if l.startswith("f ") and "86" not in l.split()[1:]]
open("frame-nv.obj", "w").write("\n".join(v[:-1] + f) + "\n")
open("frame-empty.obj", "w").write("")
PY
seq_fail() { # seq_fail ROW FRAME PATTERN
    local before msg
    cp in.h5 seqf.h5; before=$(stat -c %s seqf.h5)
    reject "$1" "" "$3" "$DTX" import sequence ok-*.obj "$2" -o seqf.h5 --name bad --mesh /meshes/src
    if ! msg=$("$PY" - seqf.h5 "$before" <<'PY' 2>&1
import os, sys, h5py
left = []
with h5py.File(sys.argv[1], "r") as f:
    f.visit(lambda n: left.append(n) if ".dtx-" in n or n.endswith("/bad") else None)
assert not left, "left behind: %s" % left
size, before = os.path.getsize(sys.argv[1]), int(sys.argv[2])
assert size == before, "the file grew from %d to %d bytes" % (before, size)
PY
    ); then bad "$1" "seqf.h5: $msg"; return; fi
    if ! msg=$("$DTX" validate seqf.h5 2>&1); then bad "$1" "seqf.h5 does not validate: $msg"; return; fi
    ok "$1" "seqf.h5: no temporary group, same size ($before bytes), validates"
}
seq_fail seq-into-existing frame-nv.obj 'frame-nv\.obj: frame 20 has 85 vertices but the rest mesh /meshes/src has 86'
seq_fail seq-into-existing frame-nan.obj 'frame-nan\.obj:7: vertex 7 has a non-finite coordinate'
seq_fail seq-into-existing frame-empty.obj 'frame-empty\.obj: empty file'
seq_fail seq-into-existing frame-faces.obj 'frame-faces\.obj: frame 20 has different faces'
seq_fail seq-into-existing missing.obj 'missing\.obj: no such file or directory'
# Frames beyond the in-memory budget are read a second time for writing
# (DTX_IMPORT_CACHE_FRAMES shrinks the budget to 3 frames): the sequence is
# the same as one written from memory.
cp in.h5 seqc.h5
if "$DTX" import sequence ok-*.obj src-3.obj -o seqc.h5 --name all --mesh /meshes/src 2>/dev/null &&
   DTX_IMPORT_CACHE_FRAMES=3 "$DTX" import sequence ok-*.obj src-3.obj -o seqc.h5 --name some \
       --mesh /meshes/src 2>/dev/null &&
   msg=$("$PY" -c '
import h5py, numpy as np
with h5py.File("seqc.h5", "r") as f:
    a, b = f["/sequences/all/positions"][...], f["/sequences/some/positions"][...]
    assert a.shape == (21, 86, 3) and np.array_equal(a, b), (a.shape, b.shape)
    assert not np.array_equal(a[0], a[20]), "src-3.obj is the last frame"' 2>&1); then
    ok seq-into-existing "21 frames read once or (18 of them) twice give the same sequence"
else
    bad seq-into-existing "the import reading frames twice differs or failed: ${msg:-}"
fi
DTX_IMPORT_CACHE_FRAMES=3 seq_fail seq-into-existing frame-nan.obj 'frame-nan\.obj:7: vertex 7 has a non-finite coordinate'
reject seq-missing-file out.h5 'no-such-dir: no such file or directory' \
    "$DTX" import sequence no-such-dir -o out.h5 --name s --mesh /meshes/src

# ----------------------------------------------------------------- names
# One rule for every object name (dtx_h5_check_name): refused before any
# file is read or written.
name_rej() { # name_rej NAME PATTERN
    reject import-name out.h5 "--name: $2" "$DTX" import mesh src.obj -o out.h5 --name "$1"
    reject import-name "" "--name: $2" "$DTX" import sequence src-1.obj -o seq.h5 --name "$1" \
        --mesh /meshes/src
}
name_rej .. '"\.\." cannot name an HDF5 object: HDF5 reads'
name_rej . '"\." cannot name an HDF5 object: HDF5 reads'
name_rej .dtx-tmp-x '"\.dtx-tmp-x" cannot name an HDF5 object: names starting with "\.dtx-" are reserved'
name_rej a/b "\"a/b\" cannot name an HDF5 object: it contains '/'"
name_rej "$(printf 'a\tb')" '"a\?b" cannot name an HDF5 object: it contains the control character 0x09'
name_rej "$(printf 'n%.0s' $(seq 256))" '"n+\.\.\." cannot name an HDF5 object: it is 256 bytes long, more than 255'
name_rej "" '"" cannot name an HDF5 object: it is empty'
reject import-name mk2.h5 '/markers/\.\.: "\.\." cannot name an HDF5 object' \
    "$DTX" import markers markers.csv --index-base 0 -o mk2.h5 --name ..
if ! msg=$("$PY" - seq.h5 <<'PY' 2>&1
import sys, h5py
left = []
with h5py.File(sys.argv[1], "r") as f:
    f.visit(lambda n: left.append(n) if ".dtx-" in n else None)
assert not left, "left behind: %s" % left
PY
); then bad import-name "seq.h5: $msg"; else ok import-name "seq.h5: no temporary group after the refused names"; fi
job j_tmpname src src tgt
sed -i 's#"name": "tgt"#"name": ".dtx-tmp-x"#' j_tmpname.json
reject job-target-name j_tmpname.h5 'j_tmpname\.json: at /targets/0/name: expected a string matching' "$DTX" run j_tmpname.json
job j_seqname src src tgt
sed -i 's#"/sequences/src"#"/sequences/.."#' j_seqname.json
reject job-target-name j_seqname.h5 'j_seqname\.json: at /source/sequences/0: the sequence path "/sequences/\.\." gives no usable result name' \
    "$DTX" run j_seqname.json

# ----------------------------------------------- HDF5 from other programs
# Copies of in.h5 with one defect each, written with h5py; each is the
# source file of a job (and must fail `dtx validate` too, except seq_nan:
# the validator does not read every frame).
"$PY" - <<'PY'
import h5py, numpy as np, shutil
def variant(name, fn):
    shutil.copy("in.h5", name + ".h5")
    with h5py.File(name + ".h5", "r+") as f:
        fn(f)
def replace(f, path, data=None, **kw):
    g = f[path.rsplit("/", 1)[0]]
    for a in ("content_hash", "nv", "nf"):
        if a in g.attrs:
            del g.attrs[a]
    del f[path]
    if data is not None or kw:
        f.create_dataset(path, data=data, **kw)
V = "/meshes/src/vertices"; P = "/sequences/src/positions"
variant("h5_dtype", lambda f: replace(f, V, (f[V][...] * 100).astype("i4")))
variant("h5_rank", lambda f: replace(f, V, f[V][...].reshape(-1)))
variant("h5_cols", lambda f: replace(f, "/meshes/src/faces",
                                     np.hstack([f["/meshes/src/faces"][...]] * 2)[:, :4]))
variant("h5_huge", lambda f: replace(f, V, shape=(2**40, 3), dtype="f8", chunks=(1024, 3)))
variant("h5_unstored", lambda f: replace(f, V, shape=(2000000000, 3), dtype="f8",
                                         chunks=(65536, 3)))
variant("h5_missing", lambda f: replace(f, "/meshes/src/faces"))
def version(f): f.attrs["format_version"] = np.int32(2)
variant("h5_version", version)
def notdtx(f): del f.attrs["format"]
variant("h5_notdtx", notdtx)
variant("h5_seqdtype", lambda f: replace(f, P, (f[P][...] * 100).astype("i2"), chunks=(1, 86, 3)))
variant("h5_seqnv", lambda f: replace(f, P, f[P][:, :80, :], chunks=(1, 80, 3)))
variant("h5_seqhuge", lambda f: replace(f, P, shape=(2**40, 86, 3), dtype="f4",
                                        chunks=(1, 86, 3)))
def seqnan(f):
    x = f[P][2]; x[5, 1] = np.nan; f[P][2] = x
variant("h5_seqnan", seqnan)
PY
echo "this is not HDF5" > h5_text.h5
h5job() { # h5job ROW VARIANT PATTERN [validate-pattern]
    job "j_$2" src src tgt
    sed -i "s#\"source\": {\"file\": \"in.h5\"#\"source\": {\"file\": \"$2.h5\"#" "j_$2.json"
    reject "$1" "j_$2.h5" "$3" bash -c "$VLIMIT exec '$DTX' run --quiet j_$2.json"
    if [ -n "${4:-}" ]; then
        reject "$1" "" "$4" "$DTX" validate "$2.h5"
    fi
}
h5job h5-dtype h5_dtype 'h5_dtype\.h5: /meshes/src/vertices: expected float values, found integer' \
    'vertices: expected float values'
h5job h5-rank h5_rank 'h5_rank\.h5: /meshes/src/vertices: expected 2 dimensions nv x 3, found 1' \
    'vertices: expected 2 dimensions'
h5job h5-shape h5_cols 'h5_cols\.h5: /meshes/src/faces: expected shape nf x 3, found 168 x 4' \
    'faces: expected shape nf x 3'
h5job h5-huge h5_huge 'h5_huge\.h5: /meshes/src/vertices: dimension 0 is 1099511627776, more than the 2147483647 dtx supports' \
    'dimension 0 is 1099511627776'
h5job h5-unstored h5_unstored 'h5_unstored\.h5: /meshes/src/vertices: shape 2000000000 x 3 needs 48000000000 bytes, but only 0 bytes are stored' \
    'never fully written'
h5job h5-missing h5_missing 'h5_missing\.h5: /meshes/src/faces: missing' \
    '/meshes/src: missing dataset faces'
h5job h5-version h5_version 'h5_version\.h5: format_version is 2, but this dtx reads version 1 only' \
    '/: attribute format_version is 2, expected 1'
h5job h5-not-dtx h5_notdtx "h5_notdtx\.h5: not a dtx file: the root group has no attribute 'format'" \
    '/: missing attribute format'
h5job h5-not-hdf5 h5_text 'h5_text\.h5: not an HDF5 file' 'not an HDF5 file'
h5job h5-seq-dtype h5_seqdtype 'h5_seqdtype\.h5: /sequences/src/positions: expected float values, found integer' \
    'positions: expected float'
h5job h5-seq-nv h5_seqnv 'h5_seqnv\.h5: /sequences/src has 80 vertices per frame but the source mesh /meshes/src has 86' \
    'nv \(from dimension 1 of positions\) is 80, but nv of /meshes/src is 86'
h5job h5-seq-huge h5_seqhuge 'h5_seqhuge\.h5: /sequences/src/positions: dimension 0 is 1099511627776' \
    'dimension 0 is 1099511627776'
# A NaN in frame 2 (0-based): reported before the transfer with its frame
# and vertex.  Frames done before it stay in OUTPUT.partial (for --resume),
# so only OUTPUT itself must be absent here.
job j_h5_seqnan src src tgt
sed -i 's#"source": {"file": "in.h5"#"source": {"file": "h5_seqnan.h5"#' j_h5_seqnan.json
reject h5-seq-nonfinite "" 'h5_seqnan\.h5: /sequences/src/positions: frame 2 \(0-based\), vertex 5 has a non-finite coordinate' \
    "$DTX" run --quiet j_h5_seqnan.json
if [ -e j_h5_seqnan.h5 ]; then bad h5-seq-nonfinite "j_h5_seqnan.h5 was written"; fi
# dtx export of a sequence with that NaN: every frame is checked before the
# first output, so no output at all is written (not the frames before the
# NaN, not the rest OBJ, PC2 or glb), and an existing --obj-dir keeps only
# what it had.
export_nothing() { # export_nothing DIR OUTPUT-ARGS...
    local dir=$1 left; shift
    reject export-nonfinite "" 'h5_seqnan\.h5: /sequences/src: frame 2 \(0-based\), vertex 5 has a non-finite coordinate \(nan\); nothing was exported' \
        "$DTX" export h5_seqnan.h5 /sequences/src "$@"
    left=$(find . \( -name 'ex.*' -o -name '.ex*' -o -name '*.tmp-*' -o -path "./$dir/*" \) \
        ! -name old.txt | head -5)
    if [ -n "$left" ]; then bad export-nonfinite "left behind: $left"; fi
}
export_nothing exdir --obj-dir exdir
[ -e exdir ] && bad export-nonfinite "exdir was created"
export_nothing exdir --obj-rest ex.obj --pc2 ex.pc2 --glb ex.glb --obj-dir exdir
mkdir -p exkeep && echo keep > exkeep/old.txt
export_nothing exkeep --obj-dir exkeep/ --pc2 ex.pc2
if [ "$(ls -A exkeep)" = old.txt ]; then ok export-nonfinite "exkeep/ holds only old.txt"
else bad export-nonfinite "exkeep/ holds: $(ls -A exkeep)"; fi
# An output that fails after others were written (here --obj-dir under a
# missing directory, last in order) removes the ones this export created.
reject export-later-failure "" 'no-parent/frames: cannot create directory' \
    "$DTX" export in.h5 /sequences/src --obj-rest ex2.obj --pc2 ex2.pc2 --glb ex2.glb \
    --obj-dir no-parent/frames
left=$(find . \( -name 'ex2.*' -o -name '.ex2*' -o -name '*.tmp-*' \) | head -5)
if [ -n "$left" ]; then bad export-later-failure "left behind: $left"
else ok export-later-failure "no rest OBJ, PC2 or glb left"; fi
# The same export from the clean file writes every frame, into a new and
# into an existing directory, and leaves no temporary directory.
if "$DTX" export in.h5 /sequences/src --obj-dir exkeep 2>/dev/null &&
   "$DTX" export in.h5 /sequences/src --obj-dir exnew/ 2>/dev/null &&
   [ "$(ls -A exkeep | tr '\n' ' ')" = "old.txt src-00001.obj src-00002.obj src-00003.obj " ] &&
   [ "$(ls -A exnew | tr '\n' ' ')" = "src-00001.obj src-00002.obj src-00003.obj " ] &&
   [ -z "$(find . -name '*.tmp-*' | head -1)" ]; then
    ok export-nonfinite "clean exports: 3 frames into exkeep/ (old.txt kept) and exnew/, no temporary left"
else
    bad export-nonfinite "clean exports: exkeep: $(ls -A exkeep); exnew: $(ls -A exnew 2>&1)"
fi

# Markers stored with a float dtype.
"$DTX" import markers markers.csv --index-base 0 -o mk.h5 --name m 2>/dev/null
"$PY" -c '
import h5py
with h5py.File("mk.h5", "r+") as f:
    v = f["/markers/m/source_vertex"][...]; del f["/markers/m/source_vertex"]
    f["/markers/m/source_vertex"] = v.astype("f8")'
job j_mkdtype src src tgt
sed -i 's#"csv": "markers.csv", "index_base": 0#"file": "mk.h5", "path": "/markers/m"#' j_mkdtype.json
reject h5-markers-dtype j_mkdtype.h5 'mk\.h5: /markers/m/source_vertex: expected integer values, found float' \
    "$DTX" run --quiet j_mkdtype.json

# --------------------------------------------------------------- markers
# (Out of range and index 0 in a 1-based file: cli.bad_input.)
# Imports into a copy of in.h5, which has both meshes: ranges are checked.
cp in.h5 mkin.h5
printf 'source_vertex,target_vertex,label\n1,1,top\n86,86,bottom\n' > base1.csv
reject mk-base-shifted "" 'base1\.csv: marker 1 \("bottom"\): source vertex 86 out of range \[0, 86\) \(0-based; is the index base right\?\)' \
    "$DTX" import markers base1.csv --index-base 0 -o mkin.h5 --name b --source /meshes/src --target /meshes/tgt
printf 'source_vertex,target_vertex,label\n0,0,top\n1,2,a\n1,3,b\n' > dup.csv
reject mk-duplicate "" 'dup\.csv: source vertex 1 is used by two markers, 1 \("a"\) and 2 \("b"\)' \
    "$DTX" import markers dup.csv --index-base 0 -o mkin.h5 --name d --source /meshes/src --target /meshes/tgt
if "$DTX" validate mkin.h5 >/dev/null 2>&1 && ! h5ls mkin.h5/markers >/dev/null 2>&1; then
    ok mk-duplicate "mkin.h5 still valid, no /markers written"
else
    bad mk-duplicate "mkin.h5 damaged or markers written by failed imports"
fi
job j_mkdup src src tgt
sed -i 's#"csv": "markers.csv"#"csv": "dup.csv"#' j_mkdup.json
reject mk-duplicate j_mkdup.h5 'dup\.csv \(markers of target "tgt"\): source vertex 1 is used by two markers' \
    "$DTX" run --quiet j_mkdup.json
printf 'source_vertex,target_vertex,label\n0,0,top\n86,1,unused\n' > unref.csv
"$DTX" import mesh tgt_unref.obj -o unref.h5 --name src 2>/dev/null
"$DTX" import sequence tgt_unref.obj -o unref.h5 --name s --mesh /meshes/src 2>/dev/null
job j_mkunref src s tgt
sed -i 's#"source": {"file": "in.h5"#"source": {"file": "unref.h5"#; s#"csv": "markers.csv"#"csv": "unref.csv"#' j_mkunref.json
reject mk-unreferenced j_mkunref.h5 'unref\.csv \(markers of target "tgt"\): marker 1 \("unused"\): source vertex 86 is in no triangle of the source mesh' \
    "$DTX" run --quiet j_mkunref.json
printf 'source_vertex,target_vertex\n1,x\n' > mal.csv
reject mk-malformed mk3.h5 "mal\.csv:2: target vertex 'x' is not an integer" \
    "$DTX" import markers mal.csv --index-base 0 -o mk3.h5 --name m
printf 'source_vertex,target_vertex\n' > none.csv
reject mk-empty mk3.h5 'none\.csv: no markers' "$DTX" import markers none.csv --index-base 0 -o mk3.h5 --name m

# ------------------------------------------------- special files, line ends
# A FIFO or a device where a file is expected is refused before reading;
# every run is under `timeout 20`, so a regression (a blocking open, a read
# that never ends) fails instead of hanging (timeout's exit 124 is "a crash?").
mkfifo sp_fifo.obj sp_fifo.csv sp_fifo.json sp_fifo.h5
mkdir -p sp_dir && cp src-1.obj sp_dir/f1.obj && mkfifo sp_dir/f2.obj
ln -sf /dev/zero sp_zero.obj; ln -sf /dev/urandom sp_urandom.ply
reject special-fifo out.h5 'sp_fifo\.obj: not a regular file \(a FIFO\)' \
    timeout 20 "$DTX" import mesh sp_fifo.obj -o out.h5 --name m
cp in.h5 sp_in.h5
reject special-fifo "" 'sp_fifo\.obj: not a regular file \(a FIFO\)' \
    timeout 20 "$DTX" import sequence src-1.obj sp_fifo.obj -o sp_in.h5 --name s --mesh /meshes/src
reject special-fifo "" 'sp_dir/f2\.obj: not a regular file \(a FIFO\)' \
    timeout 20 "$DTX" import sequence sp_dir -o sp_in.h5 --name sp --mesh /meshes/src
reject special-fifo mk3.h5 'sp_fifo\.csv: not a regular file \(a FIFO\)' \
    timeout 20 "$DTX" import markers sp_fifo.csv --index-base 0 -o mk3.h5 --name m
reject special-fifo "" 'sp_fifo\.json: not a regular file \(a FIFO\)' timeout 20 "$DTX" run sp_fifo.json
job j_spfifo src src tgt
sed -i 's#"source": {"file": "in.h5"#"source": {"file": "sp_fifo.h5"#' j_spfifo.json
reject special-fifo j_spfifo.h5 'j_spfifo\.json: at /source/file: not a regular file \(a FIFO\)' \
    timeout 20 "$DTX" run j_spfifo.json
reject special-fifo "" 'sp_fifo\.h5: not a regular file \(a FIFO\)' timeout 20 "$DTX" inspect sp_fifo.h5
reject special-fifo "" 'sp_fifo\.h5 \(the output, -o\) is a FIFO: give a file name for it \(nothing was read or written\)' \
    timeout 20 "$DTX" import mesh src.obj -o sp_fifo.h5 --name m
# /dev/zero and /dev/urandom under a 1 GiB address-space limit: refused
# before anything is read (they used to grow a buffer to 4-8 GB).
reject special-device out.h5 'sp_zero\.obj: not a regular file \(a character device\)' \
    bash -c "$VLIMIT exec timeout 20 '$DTX' import mesh sp_zero.obj -o out.h5 --name m"
reject special-device out.h5 'sp_urandom\.ply: not a regular file \(a character device\)' \
    bash -c "$VLIMIT exec timeout 20 '$DTX' import mesh sp_urandom.ply -o out.h5 --name m"
mkdir -p sp_dirmesh.obj
reject special-dir out.h5 'sp_dirmesh\.obj: not a regular file \(a directory\)' \
    timeout 20 "$DTX" import mesh sp_dirmesh.obj -o out.h5 --name m
# Lone-CR (classic Mac OS), CRLF and LF line ends all read the same.
tr '\n' '\r' < src.obj > cr_src.obj
sed 's/$/\r/' < src.obj > crlf_src.obj
for f in cr_src crlf_src; do
    accept line-ends-cr "" "$DTX" import mesh $f.obj -o le.h5 --name $f
done
w cr.off 'OFF\r3 1 0\r0 0 0\r1 0 0\r0 1 0\r3 0 1 2\r'
accept line-ends-cr "" "$DTX" import mesh cr.off -o le.h5 --name cr_off
w cr.ply "$(printf "${plyh}0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n" | tr '\n' '\r')"
accept line-ends-cr "" "$DTX" import mesh cr.ply -o le.h5 --name cr_ply
if "$PY" -c '
import h5py, numpy as np, sys
f = h5py.File("le.h5", "r"); g = h5py.File("in.h5", "r")
for m in ("cr_src", "crlf_src"):
    assert (f["/meshes/%s/vertices" % m][...] == g["/meshes/src/vertices"][...]).all(), m
    assert (f["/meshes/%s/faces" % m][...] == g["/meshes/src/faces"][...]).all(), m
' 2>/dev/null; then ok line-ends-cr "CR and CRLF copies give the LF mesh exactly"
else bad line-ends-cr "CR or CRLF copy differs from the LF mesh"; fi
# A comment line of any length; a PLY version other than 1.0.
{ echo "# $(head -c 2000000 /dev/zero | tr '\0' c)"; cat src.obj; } > longcomment.obj
accept long-comment "" "$DTX" import mesh longcomment.obj -o le.h5 --name longcomment
w v2.ply "${plyh/format ascii 1.0/format ascii 2.0}0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"
imp_rej ply-version v2.ply "v2\.ply:2: PLY version '2\.0' is not supported \(only 1\.0\)"
# The marker file's own `# index_base:` line, without --index-base; a
# conflict with --index-base is an error.
printf '# index_base: 1\nsource_vertex,target_vertex,label\n1,1,top\n86,86,bottom\n' > ib1.csv
cp in.h5 ib.h5
accept mk-index-base-line "" "$DTX" import markers ib1.csv -o ib.h5 --name ib \
    --source /meshes/src --target /meshes/tgt
ibv=$("$PY" -c 'import h5py; print(list(h5py.File("ib.h5", "r")["/markers/ib/source_vertex"][...]))' 2>&1)
if [ "$ibv" = "[0, 85]" ]; then ok mk-index-base-line "1-based file read as 1-based: $ibv"
else bad mk-index-base-line "source vertices $ibv, expected [0, 85]"; fi
reject mk-index-base-line "" "ib1\.csv:1: the file says index_base 1 but 0-based indices were asked for" \
    "$DTX" import markers ib1.csv --index-base 0 -o ib.h5 --name ib2
printf '0,0\n' > none2.csv
reject mk-index-base-line mk3.h5 "none2\.csv: index base unknown: the file has no '# index_base: 0\|1' line and none was given" \
    "$DTX" import markers none2.csv -o mk3.h5 --name m
# Job text that cJSON would misread or misreport.
job j_nul src src tgt
sed -i 's#"method": "sp04"#"method": "sp04\\u0000x"#' j_nul.json
reject job-nul-escape j_nul.h5 'j_nul\.json: at /method: a string holding \\u0000 \(a NUL character\) is not allowed' \
    "$DTX" run j_nul.json
{ printf '{"dtx_job": 1, "x":\n'; head -c 10000 /dev/zero | tr '\0' '['; } > j_deep.json
reject job-deep-nesting j_deep.h5 'j_deep\.json:2:64: JSON nesting deeper than 64 levels' "$DTX" run j_deep.json

# ------------------------------------------------------------------ jobs
# (Unknown key, syntax error, missing file, output = input: cli.bad_input.)
job j_type src src tgt
sed -i 's#"sequences": \["/sequences/src"\]#"sequences": "/sequences/src"#' j_type.json
reject job-wrong-type j_type.h5 'j_type\.json: at /source/sequences: expected an array, got "/sequences/src"' \
    "$DTX" run j_type.json
job j_type2 src src tgt
sed -i 's#"index_base": 0#"index_base": "0"#' j_type2.json
reject job-wrong-type j_type2.h5 'j_type2\.json: at /targets/0/markers/index_base: expected an integer, got "0"' \
    "$DTX" run j_type2.json
cat > j_noout.json <<'JOB'
{"dtx_job": 1, "method": "sp04",
 "source": {"file": "in.h5", "mesh": "/meshes/src", "sequences": ["/sequences/src"]},
 "targets": [{"file": "in.h5", "mesh": "/meshes/tgt", "markers": {"csv": "markers.csv", "index_base": 0}}]}
JOB
reject job-missing-key "" 'j_noout\.json: at the top level: missing required key "output"' "$DTX" run j_noout.json
job j_outcsv src src tgt
sed -i 's#"file": "j_outcsv.h5"#"file": "markers.csv"#' j_outcsv.json
reject job-output-is-input "" 'j_outcsv\.json: at /output/file: the output file .*markers\.csv is also an input \(/targets/0/markers/csv\)' \
    "$DTX" run j_outcsv.json
[[ $(sed -n 2p markers.csv) == *0,0,top* ]] || bad job-output-is-input "markers.csv was touched"
job j_nomesh src src tgt
sed -i 's#"mesh": "/meshes/src"#"mesh": "/meshes/nope"#' j_nomesh.json
reject job-missing-object j_nomesh.h5 'in\.h5: /meshes/nope: missing \(no such mesh group\)' "$DTX" run j_nomesh.json
job j_noseq src nope tgt
reject job-missing-object j_noseq.h5 'in\.h5: /sequences/nope: missing' "$DTX" run j_noseq.json
job j_version src src tgt
sed -i 's#"dtx_job": 1#"dtx_job": 2#' j_version.json
reject job-version j_version.h5 'j_version\.json: at /dtx_job: expected 1, got 2' "$DTX" run j_version.json
job j_method src src tgt
sed -i 's#"method": "sp04"#"method": "cloth"#' j_method.json
reject job-method j_method.h5 'j_method\.json: at /method: expected one of sp04, multicomponent, springs, biharmonic, got "cloth"' "$DTX" run j_method.json

# ---------------------------------------------------------- output paths
# dtx never writes, renames over or deletes a path the job names as an
# input, nor a partial it did not create; a bad output path is refused
# before any input is read.
unchanged() { # unchanged ROW FILE CKSUM: FILE still there with that checksum
    if [ "$(cksum < "$2" 2>/dev/null)" = "$3" ]; then ok "$1" "$2 unchanged"
    else bad "$1" "$2 was changed or removed"; fi
}
job j_outjob src src tgt
sed -i 's#"file": "j_outjob.h5"#"file": "j_outjob.json"#' j_outjob.json
sum=$(cksum < j_outjob.json)
reject out-is-job-file "" 'j_outjob\.json: /output/file: .*j_outjob\.json \(the output\) is also an input \(the job file j_outjob\.json\)' \
    "$DTX" run --quiet j_outjob.json
unchanged out-is-job-file j_outjob.json "$sum"
# The source file is named OUTPUT.partial of its own job.
cp in.h5 j_outpart.h5.partial
job j_outpart src src tgt
sed -i 's#"source": {"file": "in.h5"#"source": {"file": "j_outpart.h5.partial"#' j_outpart.json
sum=$(cksum < j_outpart.h5.partial)
reject out-partial-is-input "" 'j_outpart\.h5\.partial \(the output.s temporary file\) is also an input \(/source/file' \
    "$DTX" run --quiet j_outpart.json
unchanged out-partial-is-input j_outpart.h5.partial "$sum"
[ ! -e j_outpart.h5 ] && [ ! -e j_outpart.h5.lock ] && ok out-partial-is-input "no j_outpart.h5, no lock" ||
    bad out-partial-is-input "j_outpart.h5 or its lock was written"
# A file named OUTPUT.partial that dtx run did not create (a dtx file
# without the mark, or not HDF5): refused, not deleted, also with --resume.
job j_foreign src src tgt
cp in.h5 j_foreign.h5.partial
sum=$(cksum < j_foreign.h5.partial)
reject out-partial-foreign "" 'j_foreign\.h5\.partial exists but was not created by dtx run \(no dtx_partial_of mark\): dtx does not delete or overwrite it' \
    "$DTX" run --quiet j_foreign.json
reject out-partial-foreign "" 'j_foreign\.h5\.partial exists but was not created by dtx run' \
    "$DTX" run --quiet --resume j_foreign.json
unchanged out-partial-foreign j_foreign.h5.partial "$sum"
echo "notes" > j_foreign.h5.partial
reject out-partial-foreign "" 'j_foreign\.h5\.partial exists and is not a partial output dtx can read .*not an HDF5 file.*does not delete files it cannot recognise' \
    "$DTX" run --quiet j_foreign.json
[ "$(cat j_foreign.h5.partial)" = notes ] && ok out-partial-foreign "the text file is kept" ||
    bad out-partial-foreign "the text file named OUTPUT.partial was changed"
# --summary naming an input (the summary is written aside and renamed over
# its name): refused before anything is read.
job j_sumin src src tgt
sum=$(cksum < markers.csv)
reject out-summary-is-input j_sumin.h5 'markers\.csv \(the run summary\) is also an input \(/targets/0/markers/csv' \
    "$DTX" run --quiet --summary markers.csv j_sumin.json
unchanged out-summary-is-input markers.csv "$sum"
# An existing directory as the output: refused before any input is read
# (the source here is not even HDF5, and that is not what is reported).
job j_outdir src src tgt
mkdir -p j_outdir.h5
sed -i 's#"source": {"file": "in.h5"#"source": {"file": "h5_text.h5"#' j_outdir.json
reject out-directory "" 'j_outdir\.json: /output/file: .*j_outdir\.h5 \(the output\) is a directory: give a file name for it \(nothing was read or written\)' \
    "$DTX" run --quiet j_outdir.json
[ -d j_outdir.h5 ] && [ ! -e j_outdir.h5.partial ] && [ ! -e j_outdir.h5.lock ] &&
    ok out-directory "no j_outdir.h5.partial, no lock left" || bad out-directory "something was written"
# The import commands: an output that is the mesh, a frame or the marker file.
cp src.obj self.obj
sum=$(cksum < self.obj)
reject import-out-is-input "" 'self\.obj \(the output, -o\) is also an input \(the mesh file self\.obj\)' \
    "$DTX" import mesh self.obj -o self.obj --name m
reject import-out-is-input "" 'self\.obj \(the output, -o\) is also an input \(a frame file' \
    "$DTX" import sequence src-1.obj ./self.obj -o self.obj --name s --mesh /meshes/src
unchanged import-out-is-input self.obj "$sum"
reject import-out-directory "" 'j_outdir\.h5 \(the output, -o\) is a directory' \
    "$DTX" import mesh src.obj -o j_outdir.h5 --name m
# A sequence of 0 frames (another program wrote it): the source is named.
cp in.h5 seq0.h5
"$PY" -c '
import h5py
with h5py.File("seq0.h5", "r+") as f:
    s = f["/sequences/src"]; g = f.create_group("/sequences/empty")
    g.attrs["nframes"] = s.attrs["nframes"] * 0; g.attrs["rest_mesh"] = s.attrs["rest_mesh"]
    d = s["positions"]
    g.create_dataset("positions", (0,) + d.shape[1:], dtype=d.dtype, chunks=d.chunks,
                     maxshape=(None,) + d.shape[1:])
    g.create_dataset("frame_names", (0,), dtype=s["frame_names"].dtype)
    g["rest"] = h5py.SoftLink("/meshes/src")'
job j_seq0 src empty tgt
sed -i 's#"source": {"file": "in.h5"#"source": {"file": "seq0.h5"#' j_seq0.json
reject seq-empty j_seq0.h5 'seq0\.h5: /sequences/empty has no frames \(0 frames\); a sequence needs at least 1' \
    "$DTX" run --quiet j_seq0.json
# Disk full: a small tmpfs when this machine lets us mount one (root), else
# a file-size limit (ulimit -f, SIGXFSZ ignored by dtx: writes fail with
# EFBIG).  The message names the system's reason; what is left is told
# truthfully: a partial that reads back is kept and `--resume` completes it
# once there is room, one that does not is removed.
job j_full src src tgt
mkdir -p full
# (DTX_TEST_NO_TMPFS=1 takes the file-size limit here too.)
if [ -z "${DTX_TEST_NO_TMPFS:-}" ] && mount -t tmpfs -o size=1m tmpfs full 2>/dev/null; then
    trap 'umount "$W/full" 2>/dev/null' EXIT
    how=tmpfs reason='No space left on device'
    head -c 1000k /dev/zero > full/filler
    sed -i 's#"file": "j_full.h5"#"file": "full/j_full.h5"#' j_full.json
    limit=""
else
    how="ulimit -f" reason='File too large'
    sed -i 's#"file": "j_full.h5"#"file": "full/j_full.h5"#' j_full.json
    limit="ulimit -f 16;"
fi
echo "disk full simulated with: $how"
msg=$(bash -c "$limit PMIX_MCA_gds=hash OMPI_MCA_btl=self exec '$DTX' run --quiet j_full.json" 2>&1); rc=$?
if [ $rc -ne 1 ]; then bad disk-full "exit $rc: $msg"
elif ! grep -q "full/j_full\.h5\.partial: .*system: $reason" <<<"$msg"; then bad disk-full "no '$reason' in: $msg"
elif [ -e full/j_full.h5 ]; then bad disk-full "full/j_full.h5 appeared"
elif [ -e full/j_full.h5.lock ]; then bad disk-full "the lock was left"
elif [ -e full/j_full.h5.partial ]; then
    if ! grep -q "j_full\.h5\.partial is kept: [0-9]* of 3 frames done; once the cause above is fixed, \`dtx run --resume j_full\.json\` continues" <<<"$msg"; then
        bad disk-full "partial left without saying so truthfully: $msg"
    else
        rm -f full/filler
        if "$DTX" run --quiet --resume j_full.json 2>/dev/null; then finite_valid disk-full full/j_full.h5 /results/tgt/src
        else bad disk-full "--resume after freeing room failed"; fi
    fi
elif grep -q "removed .*j_full\.h5\.partial, which this run created: it does not read back" <<<"$msg"; then
    ok disk-full "$(head -2 <<<"$msg" | tr '\n' ' ')"
else
    bad disk-full "partial removed without saying so: $msg"
fi
[ "$how" = tmpfs ] && umount full
# A NaN in the input: --resume is not offered as the way on (it would stop
# at the same frame).
msg=$("$DTX" run --quiet j_h5_seqnan.json 2>&1)
if grep -q 'is kept (0 of 3 frames done, and its correspondences): `dtx run --resume` would meet the same error' <<<"$msg" &&
   ! grep -q 'continues from there' <<<"$msg"; then ok h5-seq-nonfinite "no --resume offered"
else bad h5-seq-nonfinite "after a NaN input: $msg"; fi

# -------------------------------------------------------------- topology
job j_two src src tgt_two
reject topo-components-target j_two.h5 'in\.h5:/meshes/tgt_two: the target mesh has 2 connected components \(vertex 86 is not connected to vertex 0\) and method sp04 needs one.*multicomponent' \
    "$DTX" run j_two.json
job j_seam src src tgt_seam
# Seam twins are welded for the solve: accepted, and every pair of vertices at
# one rest position moves together in every frame (the result keeps all of them).
accept topo-seam-target 'target mesh .*in\.h5:/meshes/tgt_seam: 12 vertices at the position of another vertex \(seams\) welded for the solve; results keep its 98 vertices' \
    "$DTX" run j_seam.json && finite_valid topo-seam-target j_seam.h5 /results/tgt_seam/src &&
    if msg=$("$PY" - j_seam.h5 <<'PY' 2>&1
import sys, h5py, numpy as np
f = h5py.File(sys.argv[1], "r")
r = f["/results/tgt_seam/src"]
V = r["target/vertices"][...]
X = r["positions"][...]
assert X.shape[1] == V.shape[0] == 98, X.shape
_, first, inv = np.unique(V, axis=0, return_index=True, return_inverse=True)
twins = np.flatnonzero(first[inv.ravel()] != np.arange(len(V)))
assert len(twins) == 12, len(twins)
gap = np.abs(X[:, twins] - X[:, first[inv.ravel()][twins]]).max()
assert gap == 0, "twins apart by %g" % gap
PY
    ); then ok topo-seam-target "12 twins move together exactly"; else bad topo-seam-target "$msg"; fi
# With welding off (weld_tolerance -1) the split target is refused as before.
sed 's#"mesh": "/meshes/tgt_seam",#"mesh": "/meshes/tgt_seam", "weld_tolerance": -1,#' j_seam.json > j_seam_nw.json
sed -i 's#j_seam\.h5#j_seam_nw.h5#' j_seam_nw.json
reject topo-seam-unwelded j_seam_nw.h5 'in\.h5:/meshes/tgt_seam: the target mesh has 2 connected components.*12 of its vertices sit at the position of another vertex \(vertices 25 and 86 first\): split along seams\? a weld_tolerance >= 0 welds them' \
    "$DTX" run j_seam_nw.json
job j_srctwo src_two src_two tgt
accept topo-components-source "" "$DTX" run j_srctwo.json && finite_valid topo-components-source j_srctwo.h5 /results/tgt/src_two
# Accepted target defects, all in one job (one result each).
job j_acc src src tgt_unref tgt_dup tgt_nonman tgt_dupface tgt_zero
if "$DTX" run j_acc.json > /dev/null 2> acc.err; then
    chk() {
        if grep -qE -- "$2" acc.err; then ok "$1" "$(grep -E -- "$2" acc.err | head -1)"
        else bad "$1" "no /$2/ in: $(cat acc.err)"; fi
    }
    chk topo-unreferenced-target 'warning: target mesh .*in\.h5:/meshes/tgt_unref: 1 vertex in no triangle \(vertex 86 first\); accepted'
    chk topo-duplicate-vertex 'target mesh .*in\.h5:/meshes/tgt_dup: 1 vertex at the position of another vertex \(seams\) welded for the solve; results keep its 87 vertices'
    chk topo-nonmanifold-target 'warning: target mesh .*in\.h5:/meshes/tgt_nonman: 1 non-manifold edge \(edge [0-9]+-[0-9]+ first, shared by 3 triangles\); accepted'
    chk topo-duplicate-face 'warning: target mesh .*in\.h5:/meshes/tgt_dupface: .*1 triangle on the same three vertices as another \(faces 7 and 168 first\); accepted'
    chk degenerate-zero-target 'warning: target mesh .*in\.h5:/meshes/tgt_zero: 1 triangle of zero area or thinner than 0\.0001 of the longest edge \(face 20 first'
    finite_valid topo-accepted-targets j_acc.h5 /results/tgt_unref/src /results/tgt_dup/src \
        /results/tgt_nonman/src /results/tgt_dupface/src /results/tgt_zero/src
else
    bad topo-accepted-targets "exit non-zero: $(cat acc.err)"
fi
job j_srcnm src_nonman src_nonman tgt
accept topo-nonmanifold-source 'warning: source mesh .*in\.h5:/meshes/src_nonman: 1 non-manifold edge' \
    "$DTX" run j_srcnm.json && finite_valid topo-nonmanifold-source j_srcnm.h5 /results/tgt/src_nonman
job j_srczero src_zero src_zero tgt
accept degenerate-zero-source 'warning: source mesh .*in\.h5:/meshes/src_zero: 1 triangle of zero area' \
    "$DTX" run j_srczero.json && finite_valid degenerate-zero-source j_srczero.h5 /results/tgt/src_zero
job j_coll src collapsing tgt
accept degenerate-collapsed-frame "" "$DTX" run j_coll.json && finite_valid degenerate-collapsed-frame j_coll.h5 /results/tgt/collapsing

echo "$pass passed, $fails failed"
[ "$fails" -eq 0 ]
