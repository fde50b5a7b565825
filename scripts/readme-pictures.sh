#!/usr/bin/env bash
# readme-pictures.sh: redraw the contact sheets the README shows
# (tests/data/pictures/cat-lion.png, cat-pebble-lion.png,
# cat-pebble-lion-diagonal.png, cat-lion-shirt.png and horse-camel.png) with
# the built dtx.
#
# Usage: scripts/readme-pictures.sh [DTX] [SHARED_DATA]
#   DTX          the dtx binary (default build/dtx)
#   SHARED_DATA  folder holding sumner-horse-camel (default ../shared/data);
#                without it only the cat -> lion sheet is drawn.
# Work files go to a temporary folder that is removed at the end.
set -euo pipefail

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
dtx=$(realpath "${1:-$repo/build/dtx}")
shared=${2:-$repo/../shared/data}
out=$repo/tests/data/pictures
die() { echo "readme-pictures: error: $*" >&2; exit 1; }
[[ -x $dtx ]] || die "$dtx is not an executable (build first: scripts/build.sh)"
export OMP_NUM_THREADS=${OMP_NUM_THREADS:-2} OPENBLAS_NUM_THREADS=1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$out"

# sp04 JOB for SOURCE-SEQUENCE onto TARGET in IN.h5, result in OUT.h5.
job() { # job FILE IN OUT TARGET MARKERS SEQUENCE
    cat > "$1" <<JOB
{"dtx_job": 1, "method": "sp04",
 "source": {"file": "$2", "mesh": "/meshes/src", "sequences": ["/sequences/$6"]},
 "targets": [{"name": "$4", "file": "$2", "mesh": "/meshes/$4",
              "markers": {"file": "$2", "path": "/markers/$5"}}],
 "output": {"file": "$3"}}
JOB
}

# cat -> lion: the bundled data, all nine poses.
"$repo/scripts/unpack-data.sh" "$tmp" > /dev/null
D=$tmp/sumner-cat-lion
"$dtx" import mesh "$D/source/cat-reference.obj" -o "$tmp/cl.h5" --name src 2> /dev/null
"$dtx" import mesh "$D/target/lion-reference.obj" -o "$tmp/cl.h5" --name lion 2> /dev/null
"$dtx" import sequence "$D"/source/cat-0[1-9].obj -o "$tmp/cl.h5" --name cat-poses --mesh /meshes/src 2> /dev/null
"$dtx" import markers "$D/markers.csv" --index-base 0 -o "$tmp/cl.h5" --name m \
    --source /meshes/src --target /meshes/lion 2> /dev/null
job "$tmp/cl.json" "$tmp/cl.h5" "$tmp/cl-out.h5" lion m cat-poses
"$dtx" run --quiet "$tmp/cl.json"
"$dtx" render "$tmp/cl-out.h5" /results/lion/cat-poses -o "$out/cat-lion.png" --count 9 --cols 9 \
    --width 1800

# cat -> multi-component lions (method multicomponent): the pebble lion with
# E3 in relative lengths (the default) and in the paper's absolute lengths,
# and the lion with a shirt; poses 1, 4 and 9.
T=$tmp/mc-targets
DTX=$dtx DTX_DATA_DIR=$tmp "$repo/scripts/make-multicomponent-targets.sh" "$T" 2> /dev/null
for t in pebble-lion lion-garment; do
    "$dtx" import mesh "$T/$t.obj" -o "$tmp/cl.h5" --name "$t" 2> /dev/null
done
for mode in relative diagonal; do
    cat > "$tmp/mc-$mode.json" <<JOB
{"dtx_job": 1, "method": "multicomponent",
 "source": {"file": "$tmp/cl.h5", "mesh": "/meshes/src", "sequences": ["/sequences/cat-poses"]},
 "targets": [
   {"file": "$tmp/cl.h5", "mesh": "/meshes/pebble-lion",
    "markers": {"csv": "$T/pebble-lion-markers.csv", "index_base": 0}},
   {"file": "$tmp/cl.h5", "mesh": "/meshes/lion-garment",
    "markers": {"csv": "$T/lion-garment-markers.csv", "index_base": 0}}],
 "output": {"file": "$tmp/mc-$mode.h5"},
 "multicomponent": {"eps_factor": 0.5, "proximity_lengths": "$mode"}}
JOB
    "$dtx" run --quiet "$tmp/mc-$mode.json"
    "$dtx" render "$tmp/mc-$mode.h5" /results/pebble-lion/cat-poses -o "$tmp/peb-$mode.png" \
        --frames 0,3,8 --color component --width 1200 > /dev/null
done
cp "$tmp/peb-relative.png" "$out/cat-pebble-lion.png"
cp "$tmp/peb-diagonal.png" "$out/cat-pebble-lion-diagonal.png"
"$dtx" render "$tmp/mc-relative.h5" /results/lion-garment/cat-poses -o "$out/cat-lion-shirt.png" \
    --frames 0,3,8 --color component --width 1200 > /dev/null

# horse gallop -> camel: the shared data, every sixth frame.
H=$shared/sumner-horse-camel
if [[ -d $H ]]; then
    "$dtx" import mesh "$H/source/horse-gallop-reference.obj" -o "$tmp/hc.h5" --name src 2> /dev/null
    "$dtx" import mesh "$H/target/camel-reference.obj" -o "$tmp/hc.h5" --name camel 2> /dev/null
    "$dtx" import sequence "$H"/source/horse-gallop-[0-9][0-9].obj -o "$tmp/hc.h5" --name gallop \
        --mesh /meshes/src 2> /dev/null
    "$dtx" import markers "$H/markers.csv" --index-base 0 -o "$tmp/hc.h5" --name m \
        --source /meshes/src --target /meshes/camel 2> /dev/null
    job "$tmp/hc.json" "$tmp/hc.h5" "$tmp/hc-out.h5" camel m gallop
    "$dtx" run --quiet "$tmp/hc.json"
    "$dtx" render "$tmp/hc-out.h5" /results/camel/gallop -o "$out/horse-camel.png" \
        --frames 0,6,12,18,24,30,36,42 --cols 8 --width 1800
else
    echo "readme-pictures: $H not found: horse-camel.png not redrawn" >&2
fi
ls -l "$out"
