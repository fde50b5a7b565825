#!/usr/bin/env bash
# bench-import-layouts.sh: how long `dtx import sequence` takes for the same
# frames in each layout it reads (README, "Your own data").
#
# Usage: scripts/bench-import-layouts.sh [DTX]
#   The shared horse gallop (/work/shared/data/sumner-horse-camel, or
#   DTX_HORSE=DIR: 48 OBJ frames of 8,431 vertices) is written once more with
#   numpy/h5py (/usr/bin/python3) as a float32 .npy, a float64 .npy, a PC2
#   cache and a DFAUST-layout HDF5 file ((V, 3, T) float32 with /faces) in a
#   scratch folder; each is imported 3 times into a new file holding the rest
#   mesh, and the best wall time is printed with its ratio to the OBJ folder's.
#   Every import must store the same float32 frames as the OBJ one (checked).
set -euo pipefail

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
DTX=${1:-$repo/build/dtx}
S=${DTX_HORSE:-/work/shared/data/sumner-horse-camel}/source
[[ -x $DTX ]] || { echo "bench: no dtx at $DTX (scripts/build.sh first)" >&2; exit 2; }
[[ -d $S ]] || { echo "bench: no horse data at $S" >&2; exit 2; }
W=$(mktemp -d "${TMPDIR:-/tmp}/dtx-bench-layouts.XXXXXX")
trap 'rm -rf "$W"' EXIT
cd "$W"
mkdir gallop
ln -s "$S"/horse-gallop-[0-9][0-9].obj gallop/
/usr/bin/python3 - <<'PY'
import glob, struct
import h5py, numpy as np
X, F = [], None
for p in sorted(glob.glob("gallop/*.obj")):
    V, F = [], []
    for line in open(p):
        t = line.split()
        if t and t[0] == "v":
            V.append([float(x) for x in t[1:4]])
        elif t and t[0] == "f":
            F.append([int(x.split("/")[0]) - 1 for x in t[1:4]])
    X.append(V)
X = np.array(X)
np.save("gallop.npy", X.astype(np.float32))
np.save("gallop64.npy", X)
with h5py.File("regs.hdf5", "w") as h:
    h["gallop"] = np.ascontiguousarray(X.astype(np.float32).transpose(1, 2, 0))
    h["faces"] = np.array(F, np.int32)
with open("gallop.pc2", "wb") as f:
    f.write(b"POINTCACHE2\0" + struct.pack("<iiffi", 1, X.shape[1], 0.0, 1.0, X.shape[0]))
    f.write(X.astype("<f4").tobytes())
PY

# best LABEL ARGS...: the best of 3 wall times of `dtx import sequence ARGS`.
best() {
    local label=$1 b="" s e d; shift
    for _ in 1 2 3; do
        rm -f "$label.h5"
        "$DTX" import mesh "$S/horse-gallop-reference.obj" -o "$label.h5" --name horse 2> /dev/null
        s=$(date +%s.%N)
        "$DTX" import sequence "$@" -o "$label.h5" --mesh /meshes/horse --name g 2> /dev/null
        e=$(date +%s.%N)
        d=$(echo "$e - $s" | bc)
        if [[ -z $b ]] || (($(echo "$d < $b" | bc))); then b=$d; fi
    done
    echo "$b"
}
declare -A t
t[obj]=$(best obj gallop)
t[npy]=$(best npy gallop.npy)
t[npy64]=$(best npy64 gallop64.npy)
t[pc2]=$(best pc2 gallop.pc2)
t[hdf5]=$(best hdf5 regs.hdf5 --dataset /gallop --axes VCT --faces /faces)
/usr/bin/python3 - <<'PY'
import h5py, numpy as np
ref = h5py.File("obj.h5", "r")["/sequences/g/positions"][...]
for k in ("npy", "npy64", "pc2", "hdf5"):
    got = h5py.File(k + ".h5", "r")["/sequences/g/positions"][...]
    assert np.array_equal(got, ref), k + ": not the OBJ import's frames"
PY
echo "import sequence of the horse gallop (48 frames x 8431 vertices), best of 3:"
for k in obj npy npy64 pc2 hdf5; do
    printf '  %-6s %6.3f s   OBJ folder / this: %4.1fx\n' "$k" "${t[$k]}" \
        "$(echo "${t[obj]} / ${t[$k]}" | bc -l)"
done
