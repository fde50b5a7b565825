#!/usr/bin/env bash
# pack-data.sh: rebuild tests/data/sumner-cat-lion.tar.xz from the full data set.
#
# Usage: scripts/pack-data.sh [SRC_DIR] [OUT.tar.xz]
#   SRC_DIR  the full cat/lion folder (default: ../shared/data/sumner-cat-lion
#            next to the repository)
#   OUT      the tarball to write (default: tests/data/sumner-cat-lion.tar.xz)
#
# The bundled copy differs from the original only in that the vertex normals are
# dropped: `vn` lines are removed and `f a//a b//b c//c` becomes `f a b c`. Every
# `v` line, every comment and the face order stay byte-identical. The archive is
# reproducible (sorted names, fixed owner, mode and time, single-threaded xz -9),
# so re-running this script on the same input gives the same bytes.
set -euo pipefail

die() { echo "pack-data: error: $*" >&2; exit 1; }

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
src=${1:-$repo/../shared/data/sumner-cat-lion}
out=${2:-$repo/tests/data/sumner-cat-lion.tar.xz}
name=sumner-cat-lion

[[ -d $src ]] || die "source folder '$src' not found (give it as the first argument)"
src=$(cd "$src" && pwd)

meshes=(source/cat-reference.obj)
for i in 01 02 03 04 05 06 07 08 09; do meshes+=("source/cat-$i.obj"); done
meshes+=(target/lion-reference.obj)
for i in 01 02 03 04 05 06 07 08 09; do meshes+=("paper-results/lion-$i.obj"); done
others=(markers.csv ORIGINAL-README.txt README.md)
for f in "${meshes[@]}" "${others[@]}"; do
    [[ -f $src/$f ]] || die "'$src/$f' is missing"
done

tmp=$(mktemp -d "${TMPDIR:-/tmp}/dtx-pack.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$tmp/$name/source" "$tmp/$name/target" "$tmp/$name/paper-results"

for f in "${meshes[@]}"; do
    in=$src/$f
    o=$tmp/$name/$f
    sed -E -e '/^vn[[:space:]]/d' -e '/^f[[:space:]]/s#//[0-9]+##g' "$in" > "$o"
    # The reduction must keep every vertex and every face, in order.
    nv_in=$(grep -c '^v[[:space:]]' "$in" || true)
    nf_in=$(grep -c '^f[[:space:]]' "$in" || true)
    nv_out=$(grep -c '^v[[:space:]]' "$o" || true)
    nf_out=$(grep -c '^f[[:space:]]' "$o" || true)
    [[ $nv_in -gt 0 && $nf_in -gt 0 ]] || die "$in: no vertices or no faces"
    [[ $nv_in == "$nv_out" && $nf_in == "$nf_out" ]] ||
        die "$f: counts changed ($nv_in/$nf_in -> $nv_out/$nf_out vertices/faces)"
    cmp -s <(grep -v '^vn[[:space:]]' "$in" | grep -v '^f[[:space:]]') \
        <(grep -v '^f[[:space:]]' "$o") || die "$f: non-face lines changed"
    if grep -q -e '^vn' -e '^f.*/' "$o"; then die "$f: normals left after reduction"; fi
done
for f in "${others[@]}"; do cp "$src/$f" "$tmp/$name/$f"; done
# Say in the bundled README itself that this copy is reduced.
cat >> "$tmp/$name/README.md" <<'EOF'

## This copy

This is the reduced copy bundled with dtx (tests/data/sumner-cat-lion.tar.xz): the vertex normals
were dropped (no `vn` lines, faces written `f a b c` instead of `f a//a b//b c//c`); vertex lines,
comments and face order are byte-identical to the published meshes. Rebuild it with
scripts/pack-data.sh.
EOF

mkdir -p "$(dirname "$out")"
tar --sort=name --format=gnu --owner=0 --group=0 --numeric-owner \
    --mode='a+rX,u+w,go-w' --mtime='2004-08-01 00:00:00Z' \
    -C "$tmp" -cf - "$name" | XZ_DEFAULTS='' XZ_OPT='' xz -9 -T1 -c > "$tmp/out.tar.xz"
mv "$tmp/out.tar.xz" "$out"
size=$(stat -c %s "$out")
echo "pack-data: wrote $out ($size bytes, sha256 $(sha256sum "$out" | cut -d' ' -f1))"
