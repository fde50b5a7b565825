#!/usr/bin/env bash
# scripts/unpack-data.sh: extracts the bundled data completely, is idempotent,
# re-extracts when the tarball changes, and leaves nothing half-done on failure.
set -euo pipefail

src=${DTX_SRC:?DTX_SRC not set}
scratch=${DTX_TESTDATA:?DTX_TESTDATA not set}
unpack=$src/scripts/unpack-data.sh
tarball=$src/tests/data/sumner-cat-lion.tar.xz
fails=0
checks=0
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
no_leftovers() { [[ -z $(find "$1" -maxdepth 1 -name '.tmp-*' -o -maxdepth 1 -name '.old-*') ]]; }

# ---------------------------------------------------------------- first extraction
dest=$scratch/d
bash "$unpack" "$dest" > /dev/null
d=$dest/sumner-cat-lion
for f in source/cat-reference.obj target/lion-reference.obj markers.csv README.md \
    ORIGINAL-README.txt; do
    check "$f missing" test -f "$d/$f"
done
for i in 01 02 03 04 05 06 07 08 09; do
    check "cat-$i.obj missing" test -f "$d/source/cat-$i.obj"
    check "lion-$i.obj missing" test -f "$d/paper-results/lion-$i.obj"
done
check "cat vertex count" test "$(count '^v ' "$d/source/cat-05.obj")" -eq 7207
check "cat face count" test "$(count '^f ' "$d/source/cat-reference.obj")" -eq 14410
check "lion vertex count" test "$(count '^v ' "$d/target/lion-reference.obj")" -eq 5000
check "lion face count" test "$(count '^f ' "$d/paper-results/lion-09.obj")" -eq 9996
check "normals were not dropped" test "$(cat "$d"/*/*.obj | count '^vn')" -eq 0
check "faces still carry // normal indices" test "$(cat "$d"/*/*.obj | count '^f.*/')" -eq 0
check "count() is broken" test "$(cat "$d"/*/*.obj | count '^f ')" -eq $((10 * 14410 + 10 * 9996))
check "markers.csv has 55 markers" test "$(($(wc -l < "$d/markers.csv") - 1))" -eq 55
check "stamp does not hold the tarball's sha256" \
    test "$(cat "$d/.dtx-data-sha256")" = "$(sha256sum "$tarball" | cut -d' ' -f1)"
check "temporary folders left behind" no_leftovers "$dest"

# ---------------------------------------------------------------- idempotent
touch "$d/sentinel"
out=$(bash "$unpack" "$dest")
check "second run re-extracted (sentinel gone)" test -f "$d/sentinel"
check "second run printed '$out'" test -z "$out"

# ---------------------------------------------------------------- changed tarball
mkdir -p "$scratch/repack"
cp -r "$d" "$scratch/repack/"
rm -f "$scratch/repack/sumner-cat-lion/sentinel" "$scratch/repack/sumner-cat-lion/.dtx-data-sha256"
echo new > "$scratch/repack/sumner-cat-lion/NEW"
tar -C "$scratch/repack" -cJf "$scratch/other.tar.xz" sumner-cat-lion
bash "$unpack" "$dest" "$scratch/other.tar.xz" > /dev/null
check "changed tarball not re-extracted (sentinel kept)" not test -e "$d/sentinel"
check "changed tarball's new file missing" test -f "$d/NEW"
check "stamp not updated" \
    test "$(cat "$d/.dtx-data-sha256")" = "$(sha256sum "$scratch/other.tar.xz" | cut -d' ' -f1)"
check "old copy left behind" no_leftovers "$dest"

# ---------------------------------------------------------------- bad input
head -c 5000 "$tarball" > "$scratch/truncated.tar.xz"
check "truncated tarball accepted" not bash "$unpack" "$dest" "$scratch/truncated.tar.xz" 2> /dev/null
check "failed run damaged the existing copy" test -f "$d/NEW"
check "failed run left a temporary folder" no_leftovers "$dest"
mkdir -p "$scratch/wrong/other"
echo x > "$scratch/wrong/other/file"
tar -C "$scratch/wrong" -cJf "$scratch/wrong.tar.xz" other
check "tarball without sumner-cat-lion/ accepted" \
    not bash "$unpack" "$scratch/d2" "$scratch/wrong.tar.xz" 2> /dev/null
check "missing tarball accepted" not bash "$unpack" "$dest" "$scratch/nope.tar.xz" 2> /dev/null
check "missing DEST accepted" not bash "$unpack" 2> /dev/null

# ---------------------------------------------------------------- concurrent runs
bash "$unpack" "$scratch/c" > /dev/null & p1=$!
bash "$unpack" "$scratch/c" > /dev/null & p2=$!
check "first concurrent run failed" wait $p1
check "second concurrent run failed" wait $p2
check "concurrent runs: data incomplete" test -f "$scratch/c/sumner-cat-lion/paper-results/lion-09.obj"
check "concurrent runs: nested copy" not test -e "$scratch/c/sumner-cat-lion/sumner-cat-lion"
check "concurrent runs left temporaries" no_leftovers "$scratch/c"

echo "unpack_data: $checks passed, $fails failed"
[[ $fails -eq 0 ]]
