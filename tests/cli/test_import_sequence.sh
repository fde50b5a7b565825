#!/usr/bin/env bash
# `dtx import sequence` on a folder as datasets come: --glob takes only the
# matching files, --exclude leaves files out, a frame identical to the rest
# mesh (the reference pose kept in the folder) is warned about, and the frame
# file names are stored and listed by `dtx inspect` (--frames: all of them;
# --json: frame_names).
set -uo pipefail
. "$DTX_SRC/tests/lib.sh"
W="$DTX_TESTDATA"
PY=/usr/bin/python3
cd "$W" || exit 1

cat > rest.obj <<'OBJ'
v 0 0 0
v 1 0 0
v 0 1 0
v 0 0 1
f 1 3 2
f 1 2 4
f 2 3 4
f 1 4 3
OBJ
mkdir -p poses
cp rest.obj poses/horse-reference.obj
for i in 1 2 3 4 5 6 7 8 9 10 11 12; do
    sed "s/^v 0 0 1\$/v 0 0 1.$i/" rest.obj > "poses/gallop-$i.obj"
done
cp poses/gallop-1.obj poses/notes-1.obj
"$DTX" import mesh rest.obj -o f.h5 --name horse > /dev/null 2>&1
check "rest mesh imported" test -f f.h5

out=$("$DTX" import sequence poses -o f.h5 --name all --mesh /meshes/horse 2>&1); rc=$?
check "a folder with the reference pose in it imports (exit 0)" test "$rc" -eq 0
check "... with 14 frames" grep -q "^dtx: 14 frames -> f.h5:/sequences/all" <<<"$out"
check "... and a warning naming the frame identical to the rest mesh" \
    grep -q "warning: poses/horse-reference.obj: frame 12 is identical to the rest mesh /meshes/horse (the reference pose? --exclude 'horse-reference.obj' leaves it out)" <<<"$out"

out=$("$DTX" import sequence poses -o f.h5 --name gallop --mesh /meshes/horse --glob 'gallop-*.obj' 2>&1); rc=$?
check "--glob takes only the matching files (12 frames)" \
    test "$rc" -eq 0 -a -n "$(grep '^dtx: 12 frames' <<<"$out")"
check "... in natural order, with no identical-frame warning" test -z "$(grep warning <<<"$out")"
out=$("$DTX" import sequence poses -o f.h5 --name ex --mesh /meshes/horse --exclude '*reference*' --exclude 'notes-*' 2>&1); rc=$?
check "--exclude (twice) leaves those out (12 frames)" \
    test "$rc" -eq 0 -a -n "$(grep '^dtx: 12 frames' <<<"$out")"
out=$("$DTX" import sequence poses -o f.h5 --name none --mesh /meshes/horse --glob '*.ply' 2>&1); rc=$?
check "a --glob that leaves nothing: exit 1, said so" \
    test "$rc" -eq 1 -a -n "$(grep 'no .obj, .ply or .off files left by --glob and --exclude' <<<"$out")"
out=$("$DTX" import sequence poses/gallop-1.obj poses/notes-1.obj -o f.h5 --name l --mesh /meshes/horse --exclude 'notes-*' 2>&1); rc=$?
check "--exclude applies to a list of files too (1 frame)" \
    test "$rc" -eq 0 -a -n "$(grep '^dtx: 1 frames' <<<"$out")"

"$DTX" inspect f.h5 > inspect.txt 2>&1
check "inspect lists the first and last frame files" \
    grep -q "frame files *gallop-1.obj, gallop-2.obj, gallop-3.obj, gallop-4.obj, ... (6 more; dtx inspect --frames lists all), gallop-11.obj, gallop-12.obj" inspect.txt
"$DTX" inspect f.h5 --frames > frames.txt 2>&1
check "inspect --frames lists every frame file with its index" grep -q "^ *12: horse-reference.obj$" frames.txt
check "... all 14 of /sequences/all" test "$(sed -n '/\/sequences\/all:/,/^  \//p' frames.txt | grep -cE '^ +(frame files +)?[0-9]+: ')" -eq 14
"$DTX" inspect f.h5 --json > inspect.json 2>&1
check "inspect --json has frame_names" "$PY" -c '
import json, sys
d = json.load(open("inspect.json"))
seqs = [o for o in d["sequences"] if o["path"] == "/sequences/gallop"]
assert seqs and seqs[0]["frame_names"] == ["gallop-%d.obj" % i for i in range(1, 13)], seqs
'
finish
