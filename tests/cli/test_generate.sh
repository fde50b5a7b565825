#!/usr/bin/env bash
# `dtx generate` and scripts/make-multicomponent-targets.sh: the script writes
# its nine files, the meshes have the expected sizes and component counts (as
# dtx generate reports them; the core test checks the geometry), every map row
# points at a lion vertex, the remapped markers point at copies of the original
# marker vertices and import cleanly, and bad arguments fail with a clear
# message, the right exit status and no output file.
set -euo pipefail

dtx=${DTX:?DTX not set}
src=${DTX_SRC:?DTX_SRC not set}
build=${DTX_BUILD:?DTX_BUILD not set}
scratch=${DTX_TESTDATA:?DTX_TESTDATA not set}
data=$build/data/sumner-cat-lion
lion=$data/target/lion-reference.obj
fails=0
checks=0
# check MESSAGE COMMAND...: count a pass if COMMAND succeeds, else report MESSAGE.
check() {
    local msg=$1
    shift
    if "$@"; then
        checks=$((checks + 1))
    else
        echo "FAIL: $msg" >&2
        fails=$((fails + 1))
    fi
}
not() { ! "$@"; }
count() { grep -c "$@" || true; }
contains() { grep -qF -- "$2" "$1"; }

# ---------------------------------------------------------------- the script
out=$scratch/targets
check "make-multicomponent-targets.sh failed" \
    env DTX="$dtx" DTX_DATA_DIR="$build/data" bash "$src/scripts/make-multicomponent-targets.sh" \
    "$out" 2> "$scratch/script.err"
cat "$scratch/script.err" >&2
for name in pebble-lion lion-garment lion-eyes; do
    for f in "$name.obj" "$name-map.csv" "$name-markers.csv"; do
        check "$f missing" test -s "$out/$f"
    done
    nv=$(count '^v ' "$out/$name.obj")
    check "$name: map has $(($(wc -l < "$out/$name-map.csv") - 1)) rows for $nv vertices" \
        test "$(($(wc -l < "$out/$name-map.csv") - 1))" -eq "$nv"
    check "$name: map header" test "$(head -n 1 "$out/$name-map.csv")" = \
        "generated_vertex,original_vertex"
    check "$name: map rows are not 'v,lion vertex' in order" awk -F, -v nv="$nv" '
        NR > 1 && ($1 != NR - 2 || $2 < 0 || $2 >= 5000) { bad = 1 }
        END { exit bad }' "$out/$name-map.csv"
    check "$name: markers file lost markers" \
        test "$(grep -vc '^#' "$out/$name-markers.csv")" -eq 56
    # Every remapped target is a copy of the original target: map[new] == old.
    check "$name: a remapped marker is not a copy of its lion vertex" awk -F, '
        FILENAME ~ /-map.csv$/ { if (FNR > 1) m[$1] = $2; next }
        FILENAME ~ /-markers.csv$/ && !/^#/ && FNR > 3 { new[$3] = $2 }
        FILENAME ~ /markers.csv$/ && FILENAME !~ /-markers.csv$/ && FNR > 1 { old[$3] = $2 }
        END {
            for (l in old) { n++; if (!(l in new) || m[new[l]] != old[l]) exit 1 }
            exit n != 55
        }' "$out/$name-map.csv" "$out/$name-markers.csv" "$data/markers.csv"
    check "$name: dtx import mesh rejected the mesh" \
        "$dtx" import mesh "$out/$name.obj" -o "$scratch/$name.h5" --name "$name" 2> /dev/null
    check "$name: dtx import markers rejected the remapped markers" \
        "$dtx" import markers "$out/$name-markers.csv" --index-base 0 -o "$scratch/$name.h5" \
        --name m --source /meshes/none --target "/meshes/$name" 2> /dev/null
done
check "pebbles: not 250 components" contains "$scratch/script.err" \
    "pebble-lion.obj: 250 pieces, gap 0.003, thickness 0, subdivide 0; "
check "pebbles: component count" grep -q 'pebble-lion.obj.* 250 connected components' \
    "$scratch/script.err"
check "garment: component count" grep -q 'lion-garment.obj.* 2 connected components' \
    "$scratch/script.err"
check "eyes: component count" grep -q 'lion-eyes.obj.* 3 connected components' \
    "$scratch/script.err"
check "pebbles: every lion face once" test "$(count '^f ' "$out/pebble-lion.obj")" -eq 9996
check "garment: no shell faces" test "$(count '^f ' "$out/lion-garment.obj")" -gt 9996
check "eyes: two spheres of 320 faces" test "$(count '^f ' "$out/lion-eyes.obj")" -eq $((9996 + 640))
check "eyes: two spheres of 162 vertices" test "$(count '^v ' "$out/lion-eyes.obj")" -eq $((5000 + 324))
# Re-running gives the same bytes (deterministic, atomically replaced).
cp "$out/pebble-lion.obj" "$scratch/first.obj"
env DTX="$dtx" DTX_DATA_DIR="$build/data" bash "$src/scripts/make-multicomponent-targets.sh" \
    "$out" 2> /dev/null
check "second run differs" cmp -s "$out/pebble-lion.obj" "$scratch/first.obj"
check "script without DIR accepted" not bash "$src/scripts/make-multicomponent-targets.sh" \
    2> /dev/null
check "script with a missing dtx accepted" not env DTX="$scratch/nope" \
    bash "$src/scripts/make-multicomponent-targets.sh" "$scratch/t2" 2> /dev/null

# ---------------------------------------------------------------- options
check "thickness and subdivide" "$dtx" generate pebbles "$lion" "$scratch/stones.obj" \
    --pieces 300 --thickness 0.003 --subdivide 1 2> "$scratch/stones.err"
check "stones: component count" grep -q ' 300 connected components' "$scratch/stones.err"
check "dtx help generate lists its generators" bash -c "'$dtx' help generate | grep -q 'dtx generate pebbles'"

# ---------------------------------------------------------------- bad arguments
# bad STATUS MESSAGE-PART ARGS...: dtx generate ARGS fails with STATUS, says
# MESSAGE-PART on stderr, and leaves no file at $bad_out, $bad_map, $bad_mk.
bad_out=$scratch/bad/out.obj
bad_map=$scratch/bad/map.csv
bad_mk=$scratch/bad/mk.csv
mkdir -p "$scratch/bad"
bad() {
    local want=$1 msg=$2 rc=0
    shift 2
    "$dtx" generate "$@" > /dev/null 2> "$scratch/bad.err" || rc=$?
    check "generate $* exited $rc, not $want" test "$rc" -eq "$want"
    check "generate $*: no '$msg' in: $(head -n 1 "$scratch/bad.err")" contains "$scratch/bad.err" "$msg"
    check "generate $* left an output file" \
        not test -e "$bad_out" -o -e "$bad_map" -o -e "$bad_mk"
    rm -f "$bad_out" "$bad_map" "$bad_mk"
}
bad 2 "generate what?"
bad 2 "unknown generator 'rocks'" rocks "$lion" "$bad_out"
bad 2 "pebbles needs --pieces" pebbles "$lion" "$bad_out"
bad 2 "--pieces must be an integer >= 1" pebbles "$lion" "$bad_out" --pieces 0
bad 2 "--pieces must be an integer >= 1" pebbles "$lion" "$bad_out" --pieces 12x
bad 2 "--gap must be a finite number" pebbles "$lion" "$bad_out" --pieces 5 --gap nan
bad 2 "--gap and --thickness must be >= 0" pebbles "$lion" "$bad_out" --pieces 5 --gap -1
bad 2 "--subdivide must be an integer in [0, 8]" pebbles "$lion" "$bad_out" --pieces 5 --subdivide 9
bad 2 "pebbles does not take the option --radius" pebbles "$lion" "$bad_out" --pieces 5 --radius 1
bad 2 "unknown option -x" pebbles "$lion" "$bad_out" --pieces 5 -x
bad 2 "--pieces needs a value" pebbles "$lion" "$bad_out" --pieces
bad 2 "--pieces given twice" pebbles "$lion" "$bad_out" --pieces 5 --pieces 6
bad 2 "needs two files" pebbles "$lion" --pieces 5
bad 2 "needs two files" pebbles "$lion" "$bad_out" extra.obj --pieces 5
bad 2 "go together" pebbles "$lion" "$bad_out" --pieces 5 --markers "$data/markers.csv"
bad 2 "--index-base must be 0 or 1" pebbles "$lion" "$bad_out" --pieces 5 \
    --markers "$data/markers.csv" --index-base 2 --markers-out "$bad_mk"
bad 2 "the output files must differ" pebbles "$lion" "$bad_out" --pieces 5 --map "$bad_out"
bad 2 "would overwrite an input" pebbles "$lion" "$lion" --pieces 5
bad 1 "only 9996 faces" pebbles "$lion" "$bad_out" --pieces 20000 --map "$bad_map"
bad 1 "cannot" pebbles "$scratch/missing.obj" "$bad_out" --pieces 5
bad 1 "nodir" pebbles "$lion" "$scratch/nodir/out.obj" --pieces 5
bad 2 "--axis must be x, y or z" garment "$lion" "$bad_out" --axis w --lo 0 --hi 1
bad 2 "garment needs --axis, --lo and --hi" garment "$lion" "$bad_out" --axis z --lo 0
bad 2 "--lo must be below --hi" garment "$lion" "$bad_out" --axis z --lo 0.7 --hi 0.3
bad 2 "--offset must be > 0" garment "$lion" "$bad_out" --axis z --lo 0.3 --hi 0.7 --offset 0
bad 1 "no face of the body" garment "$lion" "$bad_out" --axis z --lo 2 --hi 3 --map "$bad_map"
bad 2 "eyes needs --anchors" eyes "$lion" "$bad_out"
bad 2 "--anchors must be comma-separated" eyes "$lion" "$bad_out" --anchors 1,,2
bad 2 "--anchors must be comma-separated" eyes "$lion" "$bad_out" --anchors -3
bad 2 "--radius must be > 0" eyes "$lion" "$bad_out" --anchors 1 --radius 0
bad 1 "anchor 1 is vertex 5000" eyes "$lion" "$bad_out" --anchors 1,5000 --map "$bad_map"
# A marker whose lion vertex is out of range is named with its label.
printf 'source_vertex,target_vertex,label\n1,2,fine\n3,5000,too far\n' > "$scratch/mk-range.csv"
bad 1 'marker 1 ("too far"): target vertex 5000' pebbles "$lion" "$bad_out" --pieces 5 \
    --map "$bad_map" --markers "$scratch/mk-range.csv" --index-base 0 --markers-out "$bad_mk"
# A lion vertex in no face has no copy among the pebbles.
{ cat "$lion"; echo "v 9 9 9"; } > "$scratch/lion-extra.obj"
printf 'source_vertex,target_vertex,label\n1,2,fine\n3,5001,lonely\n' > "$scratch/mk-lonely.csv"
bad 1 'marker 1 ("lonely"): target vertex 5001' pebbles "$scratch/lion-extra.obj" "$bad_out" \
    --pieces 5 --markers "$scratch/mk-lonely.csv" --index-base 1 --markers-out "$bad_mk"
# A write that fails after the mesh was written takes the mesh away again.
bad 1 "nodir" pebbles "$lion" "$bad_out" --pieces 5 --map "$bad_map" \
    --markers "$data/markers.csv" --index-base 0 --markers-out "$scratch/nodir/mk.csv"

# 1-based markers stay 1-based.
printf '# index_base: 1\nsource_vertex,target_vertex,label\n7,1,"a, quoted"\n' \
    > "$scratch/mk1.csv"
check "1-based markers failed" "$dtx" generate garment "$lion" "$scratch/g.obj" --axis z --lo 0.4 \
    --hi 0.6 --markers "$scratch/mk1.csv" --index-base 1 --markers-out "$scratch/g-mk.csv" \
    2> /dev/null
check "1-based markers: not kept 1-based" test "$(tail -n 1 "$scratch/g-mk.csv")" = '7,1,"a, quoted"'

# reshape: the same faces, every vertex kept (the map is the identity), the
# lion (axis z: its length here) 1.25 times wider in x and longer along z.
check "reshape failed" "$dtx" generate reshape "$lion" "$scratch/r.obj" --axis z --thicken 1.25 \
    --legs 1.5 --lo 0.3 --map "$scratch/r-map.csv" 2> "$scratch/r.err"
check "reshape: faces changed" cmp -s <(grep '^f ' "$lion") <(grep '^f ' "$scratch/r.obj")
check "reshape: vertex count changed" \
    test "$(count '^v ' "$lion")" -eq "$(count '^v ' "$scratch/r.obj")"
check "reshape: map not the identity" \
    awk -F, 'NR > 1 { if ($1 != $2) exit 1; n++ } END { exit n == 5000 ? 0 : 1 }' "$scratch/r-map.csv"
extent() { awk -v k="$2" '$1 == "v" { x = $(k + 2) + 0; if (!n++ || x < lo) lo = x; if (n == 1 || x > hi) hi = x }
                          END { print hi - lo }' "$1"; }
check "reshape: not 1.25 times wider in x" \
    awk -v a="$(extent "$lion" 0)" -v b="$(extent "$scratch/r.obj" 0)" 'BEGIN { exit (b / a > 1.2499 && b / a < 1.2501) ? 0 : 1 }'
check "reshape: not taller along z" \
    awk -v a="$(extent "$lion" 2)" -v b="$(extent "$scratch/r.obj" 2)" 'BEGIN { exit (b / a > 1.1) ? 0 : 1 }'
bad 2 "reshape needs --axis" reshape "$lion" "$bad_out"
bad 2 "--thicken and --legs must be > 0" reshape "$lion" "$bad_out" --axis y --legs 0
bad 2 "--lo must be in [0, 1]" reshape "$lion" "$bad_out" --axis y --lo 1.5
bad 2 "reshape does not take the option --pieces" reshape "$lion" "$bad_out" --axis y --pieces 3

# subdivide: one level splits each of the lion's 9996 faces in four, adds one
# vertex per edge (closed mesh: 3 * 9996 / 2), keeps the lion's vertices
# first with their indices, so the markers come out as they went in.
check "subdivide failed" "$dtx" generate subdivide "$lion" "$scratch/s.obj" --levels 1 \
    --map "$scratch/s-map.csv" --markers "$data/markers.csv" --index-base 0 \
    --markers-out "$scratch/s-mk.csv" 2> "$scratch/s.err"
check "subdivide: not 4 x 9996 faces" test "$(count '^f ' "$scratch/s.obj")" -eq 39984
check "subdivide: not 5000 + 14994 vertices" test "$(count '^v ' "$scratch/s.obj")" -eq 19994
check "subdivide: the lion's vertices moved" cmp -s <(awk '$1 == "v" && n++ < 5000 { print $2 + 0, $3 + 0, $4 + 0 }' "$scratch/s.obj") \
    <(awk '$1 == "v" { print $2 + 0, $3 + 0, $4 + 0 }' "$lion")
check "subdivide: map not v -> v then -1" awk -F, 'NR > 1 { v = NR - 2; if ($1 != v || $2 != (v < 5000 ? v : -1)) exit 1 }' \
    "$scratch/s-map.csv"
check "subdivide: markers changed" cmp -s <(grep -v '^#' "$data/markers.csv") <(grep -v '^#' "$scratch/s-mk.csv")
check "subdivide: not one component" grep -q ' 1 connected components' "$scratch/s.err"
bad 2 "subdivide needs --levels" subdivide "$lion" "$bad_out"
bad 2 "--levels must be an integer in [0, 8]" subdivide "$lion" "$bad_out" --levels 9
bad 2 "subdivide does not take the option --pieces" subdivide "$lion" "$bad_out" --levels 1 --pieces 3

echo "generate: $checks passed, $fails failed"
[[ $fails -eq 0 ]]
