#!/usr/bin/env bash
# `dtx rm FILE.h5 PATH...`: removes objects so that a re-import can replace
# them; refuses (changing nothing) an object that something left in the file
# refers to, a missing object, a path named twice and a malformed path;
# removes a whole /results/TARGET group; and `cmake --install` puts a
# working dtx under a prefix.
set -uo pipefail
. "$DTX_SRC/tests/lib.sh"
W="$DTX_TESTDATA"
PY=/usr/bin/python3
cd "$W" || exit 1

cat > tet.obj <<'OBJ'
v 0 0 0
v 1 0 0
v 0 1 0
v 0 0 1
f 1 3 2
f 1 2 4
f 2 3 4
f 1 4 3
OBJ
mkdir -p poses
sed 's/^v 0 0 1$/v 0 0 1.5/' tet.obj > poses/p1.obj
sed 's/^v 0 0 1$/v 0 0 2/' tet.obj > poses/p2.obj
"$DTX" import mesh tet.obj -o f.h5 --name tet > /dev/null 2>&1 &&
    "$DTX" import mesh tet.obj -o f.h5 --name other > /dev/null 2>&1 &&
    "$DTX" import sequence poses -o f.h5 --name walk --mesh /meshes/tet > /dev/null 2>&1
check "the test file is made" test -f f.h5

# objects FILE: the object paths of the file, one per line.
objects() {
    "$PY" - "$1" <<'PY'
import sys, h5py
f = h5py.File(sys.argv[1], "r")
for k in sorted(f):
    for n in sorted(f[k]):
        print("/%s/%s" % (k, n))
PY
}
objects f.h5 > before.txt
out=$("$DTX" import mesh tet.obj -o f.h5 --name tet 2>&1)
check "a re-import points at dtx rm" grep -q "dtx rm" <<<"$out"

out=$("$DTX" rm f.h5 /meshes/tet 2>&1); rc=$?
check "removing a mesh a sequence refers to is refused (exit 1)" test "$rc" -eq 1
check "... naming the referrer and how to remove both" \
    grep -q "/sequences/walk refers to it (rest_mesh); remove both in one command: dtx rm f.h5 /sequences/walk /meshes/tet" <<<"$out"
check "... and the file is unchanged" cmp -s before.txt <(objects f.h5)

out=$("$DTX" rm f.h5 /meshes/nope 2>&1); rc=$?
check "a missing object: exit 1, 'no such object'" test "$rc" -eq 1 -a -n "$(grep 'no such object' <<<"$out")"
out=$("$DTX" rm f.h5 /meshes/other /meshes/nope 2>&1); rc=$?
check "one missing object of two: nothing removed" test "$rc" -eq 1
check "... /meshes/other is still there" cmp -s before.txt <(objects f.h5)
out=$("$DTX" rm f.h5 /meshes/other /meshes/other 2>&1); rc=$?
check "a path named twice: exit 1" test "$rc" -eq 1 -a -n "$(grep 'named twice' <<<"$out")"
for p in meshes/other /meshes/other/ /meshes//other; do
    "$DTX" rm f.h5 "$p" > /dev/null 2>&1; rc=$?
    check "a malformed path '$p': usage error (exit 2)" test "$rc" -eq 2
done
"$DTX" rm f.h5 > /dev/null 2>&1; rc=$?
check "no path: usage error (exit 2)" test "$rc" -eq 2

out=$("$DTX" rm f.h5 /sequences/walk /meshes/tet 2>&1); rc=$?
check "removing the sequence with its mesh works (exit 0)" test "$rc" -eq 0
check "... and says what it removed" test "$(grep -c '^removed ' <<<"$out")" -eq 2
check "... both are gone, the rest stays" test "$(objects f.h5 | tr '\n' ' ')" = "/meshes/other "
check "the file still validates" "$DTX" validate f.h5
check "a re-import under the removed name works" \
    "$DTX" import mesh tet.obj -o f.h5 --name tet

# /results/TARGET: a whole target's results (a result group made with h5py in
# the shape dtx writes is enough for the removal; its target refers to /meshes/tet).
"$PY" - f.h5 <<'PY'
import sys, h5py, numpy as np
f = h5py.File(sys.argv[1], "a")
for s in ("a", "b"):
    g = f.create_group("/results/tet/" + s)
    g.attrs["target_mesh"] = "/meshes/tet"
    g["positions"] = np.zeros((1, 4, 3))
PY
out=$("$DTX" rm f.h5 /meshes/tet 2>&1); rc=$?
check "a mesh a result refers to is refused" test "$rc" -eq 1 -a -n "$(grep 'refers to it (target_mesh)' <<<"$out")"
check "removing /results/tet/a keeps /results/tet/b" "$DTX" rm f.h5 /results/tet/a
check "... /results/tet/b is there" grep -qx "/results/tet" <(objects f.h5)
check "removing /results/tet removes the group" "$DTX" rm f.h5 /results/tet
check "... no /results/tet left" test -z "$(objects f.h5 | grep '^/results/tet')"

# Installation under a prefix.
prefix="$W/prefix"
if cmake --install "$DTX_BUILD" --prefix "$prefix" > install.log 2>&1; then
    check "cmake --install puts bin/dtx under the prefix" test -x "$prefix/bin/dtx"
    check "... which runs" test "$("$prefix/bin/dtx" --version)" = "$("$DTX" --version)"
    check "... with the schemas and example jobs in share/dtx" \
        test -f "$prefix/share/dtx/schemas/job.schema.json" -a -f "$prefix/share/dtx/jobs/cat-lion.json"
    check "the installed dtx works away from the source tree" \
        env -C / "$prefix/bin/dtx" validate "$W/f.h5"
else
    check "cmake --install succeeds" false
    cat install.log
fi
finish
