#!/usr/bin/env bash
# A corrupt global heap collection (where HDF5 keeps variable-length
# strings) is refused by dtx's file driver (src/io/h5guard.c) instead of
# hanging HDF5 1.10.8: a free-space object of size 0 made H5Aread loop for
# ever in H5HG__cache_heap_deserialize (fuzz_h5raw timeout, issue 16), and an
# object whose size runs past the collection made H5HG_read copy outside it.
# Every command is bounded by `timeout 20`: a hang fails (status 124) instead
# of stalling the suite.
set -uo pipefail
. "$DTX_SRC/tests/lib.sh"
W="$DTX_TESTDATA"
PY=/usr/bin/python3
cd "$W" || exit 1

# expect_refused NAME FILE WORDS...: dtx validate FILE exits 1 (not a hang,
# not a crash) and its message names the file and holds every WORD.
expect_refused() {
    local name=$1 file=$2 rc=0 w ok=1
    shift 2
    timeout 20 "$DTX" validate "$file" > "$name.out" 2> "$name.err" || rc=$?
    [ "$rc" -eq 1 ] || { echo "  $name: exit $rc, expected 1"; ok=0; }
    for w in "$file" "$@"; do
        grep -qF -- "$w" "$name.err" || { echo "  $name: no '$w' in: $(cat "$name.err")"; ok=0; }
    done
    [ "$ok" -eq 1 ]
}

# The fuzzer's input: the dtx seed file of tests/fuzz/corpus/h5raw with the
# heap's last object and its free space zeroed.
cp "$DTX_SRC/tests/io/corpus/h5/vlen-gheap-hang.h5" hang.h5
check "fuzz input: validate refuses it at once" \
    expect_refused hang hang.h5 "cannot read attribute format" "corrupt global heap collection" \
    "free space at offset 80 has size 0"
rc=0
timeout 20 "$DTX" inspect hang.h5 > inspect.out 2> inspect.err || rc=$?
check "fuzz input: inspect fails with a message (exit $rc)" \
    bash -c '[ "$1" -ne 0 ] && [ "$1" -ne 124 ] && [ "$1" -lt 128 ] &&
             grep -q "hang.h5: .*corrupt global heap" inspect.err' _ "$rc"

# A fuzz_h5raw crash (ASan: memcpy-param-overlap in H5HG_read): a collection
# declared larger than HDF5's first read, which HDF5 then reads in two parts,
# with an object of about 1 TB.
cp "$DTX_SRC/tests/io/corpus/h5/gheap-two-part-overrun.h5" overrun.h5
check "collection read in two parts, object past its end: refused" \
    expect_refused overrun overrun.h5 "cannot read attribute format" \
    "corrupt global heap collection at address 2048" "has size 1099511626499"

# A file dtx writes itself reads as before through the driver, and the two
# corruptions made on it are each refused.
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n' > tri.obj
"$DTX" import mesh tri.obj -o good.h5 --name tri > /dev/null 2>&1
check "a file dtx wrote validates" timeout 20 "$DTX" validate good.h5
# patch FILE OUT WHAT: OUT is FILE with the first collection's free space
# set to size 0 (WHAT=free) or its first object's size past the end (big).
patch() {
    "$PY" - "$1" "$2" "$3" <<'PYEOF'
import struct, sys
src, out, what = sys.argv[1:]
d = bytearray(open(src, "rb").read())
g = d.find(b"GCOL\x01")
assert g >= 0, "no global heap collection"
size = struct.unpack_from("<Q", d, g + 8)[0]
p = g + 16
while True:  # objects: u16 index, u16 refs, u32 reserved, u64 size, data
    idx, _, _, n = struct.unpack_from("<HHIQ", d, p)
    if what == "big" and idx != 0:
        struct.pack_into("<Q", d, p + 8, size)
        break
    if what == "free" and idx == 0:
        struct.pack_into("<Q", d, p + 8, 0)
        break
    p += n if idx == 0 else 16 + (n + 7) // 8 * 8
open(out, "wb").write(d)
PYEOF
}
patch good.h5 free.h5 free
check "free space of size 0: refused" \
    expect_refused free free.h5 "cannot read attribute" "corrupt global heap collection" \
    "has size 0"
patch good.h5 big.h5 big
check "object larger than its collection: refused" \
    expect_refused big big.h5 "cannot read attribute" "corrupt global heap collection" \
    "bytes are left"
finish
