#!/usr/bin/env bash
# The README's "Your own data" walkthrough works when pasted: the sh block
# after the `<!-- walkthrough` marker runs as written, from a folder laid
# out like the repository after ./scripts/demo.sh (build/ with dtx and the
# unpacked data), and leaves what it says: a valid result of the 9 poses, a
# page and the exported files.
set -uo pipefail
. "$DTX_SRC/tests/lib.sh"
W="$DTX_TESTDATA"
PY=/usr/bin/python3
cd "$W" || exit 1

awk '/<!-- walkthrough/ { f = 1; next } f && /^```sh$/ { g = 1; next } g && /^```$/ { exit } g' \
    "$DTX_SRC/README.md" > walkthrough.sh
check "the README has the walkthrough block" test "$(wc -l < walkthrough.sh)" -gt 10
mkdir -p root && ln -sfn "$DTX_BUILD" root/build
check "the walkthrough runs as pasted (exit 0)" bash -c 'cd root && set -e && . ../walkthrough.sh > ../walkthrough.log 2>&1'
[ "$fails" -eq 0 ] || cat walkthrough.log
M=root/mine
check "out.h5 validates" "$DTX" validate "$M/out.h5"
check "the result has the 9 poses, all done" "$PY" -c "
import h5py, numpy as np
r = h5py.File('$M/out.h5', 'r')['/results/lion/walk']
assert r['positions'].shape == (9, 5000, 3), r['positions'].shape
assert r['frame_done'][...].all() and np.isfinite(r['positions'][...]).all()
assert r.attrs['fps'] == 24
"
for f in out.html lion.glb lion.obj lion.pc2; do
    check "it leaves $f" test -s "$M/$f"
done
# (Output to a file first: `dtx inspect | grep -q` can end in SIGPIPE.)
"$DTX" inspect "$M/in.h5" --frames > frames.txt 2>&1
check "the reference pose was left out of the sequence" \
    bash -c "grep -q '8: cat-09.obj' frames.txt && ! grep -qE '[0-9]+: .*reference' frames.txt"
# The result names its source by a path relative to itself, so the two can
# move together: the folder moved elsewhere still renders with its source row.
"$DTX" inspect "$M/out.h5" > out-inspect.txt 2>&1
check "the result names its source relative to itself (in.h5:/sequences/walk)" \
    grep -qE 'source sequence +in\.h5:/sequences/walk$' out-inspect.txt
mv "$M" moved
check "after moving the folder, render finds the source (run from elsewhere)" \
    bash -c "cd / && '$DTX' render '$W/moved/out.h5' /results/lion/walk -o '$W/moved.png' --count 2"
check "... and writes the picture" test -s moved.png

finish
