#!/usr/bin/env bash
# `dtx import` must not write what `dtx run` and `dtx validate` reject later
# (rows [mesh-repeated-vertex] and [mk-duplicate] of the bad-input table):
# a mesh with a face that repeats a vertex, in any format, and a marker file
# that uses a vertex twice, also when no meshes are named to check ranges
# against.  Each import must fail naming the file and the item, and leave
# no output file.
set -uo pipefail
W="$DTX_TESTDATA"
cd "$W" || exit 1
pass=0 fails=0
reject() { # reject ROW OUTPUT PATTERN COMMAND...
    local row=$1 out=$2 pattern=$3 msg rc; shift 3
    msg=$("$@" 2>&1); rc=$?
    if [ $rc -eq 0 ]; then echo "FAILED: [$row] exit 0: $msg"; fails=$((fails + 1)); return; fi
    if ! grep -qE -- "$pattern" <<<"$msg"; then
        echo "FAILED: [$row] message lacks /$pattern/: $msg"; fails=$((fails + 1)); return
    fi
    if [ -e "$out" ]; then echo "FAILED: [$row] $out was left behind"; fails=$((fails + 1)); return; fi
    echo "ok: [$row] $msg"; pass=$((pass + 1))
}

printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 4\nf 1 1 2\n' > rep.obj
printf 'OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 3\n3 0 0 1\n' > rep.off
printf 'ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 3\n3 0 0 1\n' > rep.ply
for x in obj off ply; do
    reject mesh-repeated-vertex out.h5 "rep\\.$x(:[0-9]+)?: face 1 \\(0-based\\) repeats a vertex \\(0 0 1\\)" \
        "$DTX" import mesh rep.$x -o out.h5 --name m
done

printf 'source_vertex,target_vertex,label\n0,0,top\n1,2,a\n1,3,b\n' > dup.csv
reject mk-duplicate mk.h5 'dup\.csv: source vertex 1 is used by two markers, 1 \("a"\) and 2 \("b"\)' \
    "$DTX" import markers dup.csv --index-base 0 -o mk.h5 --name d
printf 'source_vertex,target_vertex\n0,5\n1,5\n' > dupt.csv
reject mk-duplicate mk.h5 'dupt\.csv: target vertex 5 is used by two markers, 0 and 1' \
    "$DTX" import markers dupt.csv --index-base 0 -o mk.h5 --name d

echo "$pass passed, $fails failed"
[ "$fails" -eq 0 ]
