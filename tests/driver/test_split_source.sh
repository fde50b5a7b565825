#!/usr/bin/env bash
# A seam-split SOURCE (issue 17): the cat split the way a DCC export splits
# it (`dtx generate uvsplit`: UV seam and two materials), with its poses
# stored in the split order (tests/driver/split_poses.py applies the split
# to each pose OBJ: the split depends on the rest mesh's geometry, so
# running uvsplit on each pose would cut elsewhere).  The run welds the
# source for the solve and compacts its frames; the result equals the
# welded cat's exactly, for sp04 and multicomponent.
set -euo pipefail
D="$DTX_BUILD/data/sumner-cat-lion"
W="$DTX_TESTDATA"
. "$DTX_SRC/tests/lib.sh"
cd "$W"

same() { # same FILE1 FILE2 PATH1 PATH2: equal, and comparable (same shape)
    local out
    out=$(h5diff -c "$@" 2>&1) && ! grep -qi "not comparable" <<< "$out"
}

"$DTX" generate uvsplit "$D/source/cat-reference.obj" cat-uv.obj 2> gen.log
check "the split cat has duplicated vertices" grep -Eq 'cat-uv.obj: [0-9]+ vertices \([1-9]' gen.log
mkdir -p poses
for k in 1 2; do ln -s "$D/source/cat-0$k.obj" "poses/cat-$k.obj"; done
python3 "$DTX_SRC/tests/driver/split_poses.py" cat-uv.obj "$D/source/cat-reference.obj" \
    poses/cat-1.obj poses/cat-2.obj split-poses

"$DTX" import mesh "$D/source/cat-reference.obj" -o in.h5 --name cat 2> /dev/null
"$DTX" import sequence poses -o in.h5 --name poses --mesh /meshes/cat --dtype float64 2> /dev/null
"$DTX" import mesh cat-uv.obj -o in.h5 --name cat-uv 2> /dev/null
"$DTX" import sequence split-poses -o in.h5 --name split-poses --mesh /meshes/cat-uv \
    --dtype float64 2> /dev/null
"$DTX" import mesh "$D/target/lion-reference.obj" -o in.h5 --name lion 2> /dev/null

job() { # job NAME METHOD MESH SEQUENCE
    cat > "$1.json" <<JOB
{"dtx_job": 1, "method": "$2",
 "source": {"file": "in.h5", "mesh": "/meshes/$3", "sequences": ["/sequences/$4"]},
 "targets": [
  {"file": "in.h5", "mesh": "/meshes/lion", "markers": {"csv": "$D/markers.csv", "index_base": 0}}],
 "output": {"file": "$1.h5", "dtype": "float64"},
 "multicomponent": {"max_iter": 5}}
JOB
}
for m in sp04 multicomponent; do
    job $m-welded $m cat poses
    job $m-split $m cat-uv split-poses
    "$DTX" run --quiet $m-welded.json
    "$DTX" run --quiet $m-split.json
    check "$m: the split source's result equals the welded source's exactly" \
        same $m-welded.h5 $m-split.h5 /results/lion/poses/positions /results/lion/split-poses/positions
done
check "the split result validates" "$DTX" validate sp04-split.h5
finish
