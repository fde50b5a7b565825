#!/usr/bin/env bash
# make-multicomponent-targets.sh: multi-component targets with a known structure,
# made from the bundled lion, for the multicomponent method (Zhou, Xu, Tong &
# Desbrun 2010).
#
# Usage: scripts/make-multicomponent-targets.sh DIR
#   Writes into DIR (created if missing), for each target NAME below:
#     NAME.obj          the mesh
#     NAME-map.csv      generated_vertex,original_vertex: for every vertex of NAME.obj
#                       the lion vertex it was made from (0-based; -1: none)
#     NAME-markers.csv  the bundled cat/lion markers (0-based) with every lion vertex
#                       replaced by its lowest copy in NAME.obj (source, labels kept)
#   Takes well under a second after the data is unpacked. Safe to re-run (files are
#   replaced atomically).
# Environment:
#   DTX           the dtx executable (default: build/dtx of this repository)
#   DTX_DATA_DIR  where the bundled data is unpacked, by scripts/unpack-data.sh
#                 (default: DIR/data; the tests pass their build tree's data/)
#
# The targets (all made by `dtx generate`; see src/gen/generate.h):
#
#   pebble-lion   `dtx generate pebbles`: the lion's surface cut into 250 connected
#                 patches ("pebbles", as the paper's pebble camel), pieces sharing no
#                 vertex. Seeds are spread by farthest-point sampling of the face
#                 centroids from face 0; every face joins the seed nearest to it over
#                 the surface (Dijkstra over shared edges), so every pebble is one
#                 connected patch. Each pebble is then shrunk about its area centroid
#                 so that cracks about 0.3% of the lion's bounding-box diagonal wide
#                 open between neighbours. Open patches (no thickness): every lion
#                 face is in exactly one pebble, and every pebble vertex is a copy of
#                 one lion vertex, within about the crack width of it. Options not
#                 used here: --thickness T closes each pebble into a stone,
#                 --subdivide L refines the lion first (more vertices per pebble).
#
#   lion-garment  `dtx generate garment`: the lion (unchanged, vertices first) plus
#                 a separate shell, a "shirt" over the torso: copies of the lion
#                 faces whose centroid lies between 45% and 72% of the lion's extent
#                 along z (its long axis: tail tip at 0%, nose at 100%; the band runs
#                 from behind the hind quarters to the shoulders, legs excluded), with
#                 the vertices pushed out along the lion's vertex normals by 1% of the
#                 diagonal. Two components; the shell's map points at the lion
#                 vertex under each shell vertex.
#
#   lion-eyes     `dtx generate eyes`: the lion plus two small closed spheres (eyes,
#                 radius 0.4% of the diagonal) floating 0.2% of the diagonal off the
#                 surface. Anchors: for each eye, the lion vertex nearest to the mean
#                 of the three marker vertices labelled "left eye ..." (inner, outer,
#                 upper) or "right eye ..." in markers.csv; each sphere starts on the
#                 anchor's normal and is moved off the eye socket until the lion is
#                 at least radius + gap from its centre. Three components; the
#                 spheres' map entries point at their anchors.
set -euo pipefail

die() { echo "make-multicomponent-targets: error: $*" >&2; exit 1; }

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
[[ $# -eq 1 && -n $1 ]] || die "usage: scripts/make-multicomponent-targets.sh DIR"
out=$1
dtx=${DTX:-$repo/build/dtx}
[[ -x $dtx ]] || die "dtx executable '$dtx' not found (build it, or set DTX)"
mkdir -p "$out" || die "cannot create '$out'"
data_dir=${DTX_DATA_DIR:-$out/data}
bash "$repo/scripts/unpack-data.sh" "$data_dir" > /dev/null
data=$data_dir/sumner-cat-lion
lion=$data/target/lion-reference.obj
markers=$data/markers.csv

# ---------------------------------------------------------------- parameters
pebbles=250
pebble_gap=0.003
garment_axis=z
garment_lo=0.45
garment_hi=0.72
garment_offset=0.01
eye_radius=0.004
eye_gap=0.002

# The lion vertex nearest to the mean of the markers labelled "SIDE eye ...".
# Markers are 0-based, like the vertex numbers counted here.
eye_anchor() {
    awk -F, -v side="$1" '
        NR == FNR {
            if (FNR > 1 && $3 ~ ("^" side " eye ")) want[$2] = 1
            next
        }
        /^v / { split($0, f, " "); x[n] = f[2]; y[n] = f[3]; z[n] = f[4]; n++ }
        END {
            for (i in want) { cx += x[i]; cy += y[i]; cz += z[i]; m++ }
            if (m == 0) exit 1
            cx /= m; cy /= m; cz /= m
            best = -1
            for (i = 0; i < n; i++) {
                d = (x[i] - cx) ^ 2 + (y[i] - cy) ^ 2 + (z[i] - cz) ^ 2
                if (best < 0 || d < bd) { best = i; bd = d }
            }
            print best
        }' "$markers" "$lion"
}
left_eye=$(eye_anchor left) || die "no 'left eye' markers in $markers"
right_eye=$(eye_anchor right) || die "no 'right eye' markers in $markers"

# ---------------------------------------------------------------- generate
# gen NAME KIND OPTIONS...
gen() {
    local name=$1 kind=$2
    shift 2
    "$dtx" generate "$kind" "$lion" "$out/$name.obj" "$@" --map "$out/$name-map.csv" \
        --markers "$markers" --index-base 0 --markers-out "$out/$name-markers.csv" ||
        die "dtx generate $kind failed for $name"
}
gen pebble-lion pebbles --pieces "$pebbles" --gap "$pebble_gap"
gen lion-garment garment --axis "$garment_axis" --lo "$garment_lo" --hi "$garment_hi" \
    --offset "$garment_offset"
gen lion-eyes eyes --anchors "$left_eye,$right_eye" --radius "$eye_radius" --gap "$eye_gap"
echo "make-multicomponent-targets: wrote pebble-lion, lion-garment and lion-eyes (eye anchors: lion vertices $left_eye and $right_eye) into $out"
