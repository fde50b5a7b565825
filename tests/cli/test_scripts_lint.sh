#!/usr/bin/env bash
# Sanity checks on the project's shell scripts, without shellcheck: every script
# parses (bash -n), the entry points are executable and start with the same
# shebang and strict mode, and the LSan suppressions name only OpenMPI's libraries
# (and asprintf, which dtx never calls).
set -euo pipefail

src=${DTX_SRC:?DTX_SRC not set}
scratch=${DTX_TESTDATA:?DTX_TESTDATA not set}
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
first_line_is() { [[ $(head -n 1 "$1") == "$2" ]]; }
not() { ! "$@"; }

# The check itself must be able to fail: a broken script is rejected.
printf '#!/usr/bin/env bash\nif true; then\n  echo x\n' > "$scratch/broken.sh"
check "bash -n accepted a broken script" not bash -n "$scratch/broken.sh" 2> /dev/null

shopt -s nullglob
entry=("$src"/scripts/*.sh "$src/.ci/run")
all=("${entry[@]}" "$src"/tests/*.sh "$src"/tests/*/*.sh)
check "expected scripts/*.sh and .ci/run, found ${#entry[@]} files" test ${#entry[@]} -ge 7

for f in "${all[@]}"; do
    check "$f does not parse (bash -n)" bash -n "$f"
done
for f in "${entry[@]}"; do
    check "$f is not executable (chmod +x)" test -x "$f"
    check "$f: first line is not #!/usr/bin/env bash" first_line_is "$f" '#!/usr/bin/env bash'
    check "$f: no 'set -euo pipefail' (or -uo)" grep -qE '^set -e?uo pipefail' "$f"
done
for s in setup build test demo unpack-data pack-data; do
    check "scripts/$s.sh is missing" test -f "$src/scripts/$s.sh"
done
check ".ci/run does not exec ./scripts/test.sh" grep -qx 'exec ./scripts/test.sh' "$src/.ci/run"

# LSan suppressions: only the MPI stack, never dtx's own code.
supp=$src/tests/lsan.supp
check "tests/lsan.supp is missing" test -f "$supp"
if [[ -f $supp ]]; then
    while IFS= read -r line; do
        [[ -z $line || $line == \#* ]] && continue
        case $line in
            leak:libmpi.so | leak:libopen-pal.so | leak:libopen-rte.so | leak:libhwloc.so | \
                leak:libevent | leak:libpmix.so | leak:mca_ | leak:H5AC__log_flushed_entry | \
                leak:H5AC__log_inserted_entry | leak:__vasprintf_internal) allowed=true ;;
            *) allowed=false ;;
        esac
        check "tests/lsan.supp: unexpected suppression '$line'" $allowed
    done < "$supp"
fi
# The asprintf suppression hides leaks of strings made with asprintf: dtx must
# not make any (a grep that finds the call in a planted file shows it can fail).
uses_asprintf() { grep -rlE '\bv?asprintf[[:space:]]*\(' "$@" > /dev/null; }
printf 'char *s; int n = asprintf(&s, "%%d", 1);\n' > "$scratch/planted.c"
check "the asprintf check does not find a planted call" uses_asprintf "$scratch/planted.c"
check "src/ calls asprintf/vasprintf, whose leaks tests/lsan.supp hides" not uses_asprintf "$src/src"

# The bundled data stays compact and documented.
tarball=$src/tests/data/sumner-cat-lion.tar.xz
size=$(stat -c %s "$tarball" 2> /dev/null || echo 0)
check "$tarball: size $size not in (100 kB, 1.2 MB)" test "$size" -gt 100000 -a "$size" -lt 1200000
check "tests/data/README.md lacks the attribution" \
    grep -q 'Deformation Transfer for Triangle Meshes' "$src/tests/data/README.md"

echo "scripts_lint: $checks passed, $fails failed"
[[ $fails -eq 0 ]]
