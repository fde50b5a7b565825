#!/usr/bin/env bash
# blender-picture.sh: redraw tests/data/pictures/lion-textured.png, the
# README's picture of a textured result: the lion split along a UV seam
# with two materials (dtx generate uvsplit), a UV checker texture
# (scripts/uv-checker.py) on its lower material through map_Kd, animated by
# the cat's poses with sp04, exported as glb and rendered by Blender
# (headless, Cycles on the CPU) at result frames 2 and 5, side by side
# (scripts/blender-picture.py).
#
# Usage: scripts/blender-picture.sh [DTX]
#   DTX  the dtx binary (default build/dtx); needs blender on PATH.
# Work files go to a temporary folder that is removed at the end.
set -euo pipefail

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
dtx=$(realpath "${1:-$repo/build/dtx}")
out=$repo/tests/data/pictures/lion-textured.png
die() { echo "blender-picture: error: $*" >&2; exit 1; }
[[ -x $dtx ]] || die "$dtx is not an executable (build first: scripts/build.sh)"
command -v blender > /dev/null || die "blender is not installed (Debian: apt-get install blender)"
export OMP_NUM_THREADS=${OMP_NUM_THREADS:-2} OPENBLAS_NUM_THREADS=1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cd "$tmp"

"$repo/scripts/unpack-data.sh" "$tmp" > /dev/null
D=$tmp/sumner-cat-lion
"$dtx" generate uvsplit "$D/target/lion-reference.obj" lion-uv.obj 2> /dev/null
python3 "$repo/scripts/uv-checker.py" checker.png 256 8
sed -i '/^newmtl dtx_lower/a map_Kd checker.png' lion-uv.mtl
"$dtx" import mesh "$D/source/cat-reference.obj" -o cl.h5 --name cat 2> /dev/null
"$dtx" import mesh lion-uv.obj -o cl.h5 --name lion 2> /dev/null
"$dtx" import sequence "$D"/source/cat-0[1-9].obj -o cl.h5 --name cat-poses --mesh /meshes/cat 2> /dev/null
"$dtx" import markers "$D/markers.csv" --index-base 0 -o cl.h5 --name cat-lion \
    --source /meshes/cat --target /meshes/lion 2> /dev/null
cat > job.json <<'JOB'
{"dtx_job": 1, "method": "sp04",
 "source": {"file": "cl.h5", "mesh": "/meshes/cat", "sequences": ["/sequences/cat-poses"]},
 "targets": [{"name": "lion", "file": "cl.h5", "mesh": "/meshes/lion",
              "markers": {"file": "cl.h5", "path": "/markers/cat-lion"}}],
 "output": {"file": "out.h5"}}
JOB
"$dtx" run --quiet job.json
"$dtx" export out.h5 /results/lion/cat-poses --glb lion.glb
blender -b --factory-startup --python-exit-code 1 --python "$repo/scripts/blender-picture.py" \
    -- lion.glb "$tmp/lion-textured.png" 2 5 > blender.log 2>&1 ||
    { tail -n 20 blender.log; die "blender failed"; }
mkdir -p "$(dirname "$out")"
mv "$tmp/lion-textured.png" "$out"
echo "blender-picture: $out ($(stat -c %s "$out") bytes)"
