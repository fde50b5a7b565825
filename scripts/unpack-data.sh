#!/usr/bin/env bash
# unpack-data.sh: extract the bundled cat/lion data into DEST/sumner-cat-lion.
#
# Usage: scripts/unpack-data.sh DEST [TARBALL]
#   DEST     folder to extract into (created if missing)
#   TARBALL  defaults to tests/data/sumner-cat-lion.tar.xz in this repository
#
# Idempotent: DEST/sumner-cat-lion/.dtx-data-sha256 records the sha256 of the
# tarball it came from; when it matches, nothing is done. A different tarball
# replaces the folder. Extraction goes to DEST/.tmp-XXXXXX first and is moved
# into place only when complete, under a lock, so an interrupted or concurrent
# run never leaves a half-extracted folder behind.
set -euo pipefail

die() { echo "unpack-data: error: $*" >&2; exit 1; }

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
[[ $# -ge 1 && $# -le 2 && -n $1 ]] || die "usage: scripts/unpack-data.sh DEST [TARBALL]"
dest=$1
tarball=${2:-$repo/tests/data/sumner-cat-lion.tar.xz}
name=sumner-cat-lion
stamp_name=.dtx-data-sha256

[[ -f $tarball ]] || die "tarball '$tarball' not found"
mkdir -p "$dest" || die "cannot create '$dest'"
sum=$(sha256sum "$tarball" | cut -d' ' -f1)
target=$dest/$name

is_current() { [[ -f $target/$stamp_name && $(< "$target/$stamp_name") == "$sum" ]]; }

# Fast path, no lock needed: the stamp is written before the folder is moved in.
if is_current; then
    exit 0
fi

# Serialise concurrent unpackers of the same DEST (flock is in util-linux).
if command -v flock > /dev/null; then
    exec 9> "$dest/.unpack.lock"
    flock 9
    if is_current; then
        exit 0
    fi
fi

tmp=$(mktemp -d "$dest/.tmp-XXXXXX")
old=""
cleanup() {
    rm -rf "$tmp"
    [[ -z $old ]] || rm -rf "$old"
}
trap cleanup EXIT

tar -xJf "$tarball" -C "$tmp" --no-same-owner --no-same-permissions ||
    die "cannot extract '$tarball'"
for f in source/cat-reference.obj target/lion-reference.obj markers.csv; do
    [[ -f $tmp/$name/$f ]] || die "'$tarball' has no $name/$f"
done
echo "$sum" > "$tmp/$name/$stamp_name"

if [[ -e $target ]]; then
    old=$(mktemp -d "$dest/.old-XXXXXX")
    mv -T "$target" "$old/$name" || die "cannot move the old '$target' aside"
fi
mv -T "$tmp/$name" "$target" || die "cannot move the extracted data to '$target'"
echo "unpack-data: extracted $name into $dest"
