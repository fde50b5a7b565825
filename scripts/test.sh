#!/usr/bin/env bash
# test.sh: set up, build and run the test suite.
#
# Usage: scripts/test.sh [CTEST_ARGS...]      e.g. scripts/test.sh -R core
#   Runs scripts/setup.sh, scripts/build.sh, then
#   `ctest --test-dir build --output-on-failure -j2 CTEST_ARGS...`.
#   With DTX_SANITIZE_TESTS=1 it then also builds build-asan/ (ASan+UBSan, leak
#   checks on, tests/lsan.supp suppressing only OpenMPI/hwloc start-up leaks) and
#   runs the same tests there.
# Environment:
#   CI=true               what CI sets; turns DTX_SANITIZE_TESTS on by default
#   DTX_SANITIZE_TESTS    0/1: also run the sanitizer pass (default 1 if CI=true, else 0)
#   CTEST_JOBS            parallel tests (default 2)
# Exit status: 0 when every pass passed, else the first failing ctest's status
# (or the failing step's). Before the summary, a table of each test's seconds per pass
# and each pass's wall time. The last line sums up all passes: "total: N passed, M failed".
set -uo pipefail

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$repo" || exit 1
unset DTX_BUILD_DIR  # the passes below use build/ and build-asan/

if [[ ${CI:-} == true ]]; then default_san=1; else default_san=0; fi
sanitize_tests=${DTX_SANITIZE_TESTS:-$default_san}
ctest_jobs=${CTEST_JOBS:-2}

"$repo/scripts/setup.sh" || { echo "test: error: scripts/setup.sh failed" >&2; exit 1; }

status=0
summary=()
pass_dirs=()
pass_walls=()
times=$(mktemp -d "${TMPDIR:-/tmp}/dtx-times.XXXXXX")
trap 'rm -rf "$times"' EXIT
total_pass=0
total_fail=0

# run_pass DIR BUILD_ARGS...: build one configuration (in DIR) and run ctest there.
run_pass() {
    local dir=$1 rc log line t f
    shift
    if ! DTX_SKIP_SETUP=1 "$repo/scripts/build.sh" "$@"; then
        echo "test: error: build of $dir failed" >&2
        summary+=("$dir: build failed")
        [[ $status -ne 0 ]] || status=1
        total_fail=$((total_fail + 1))
        return
    fi
    log=$(mktemp "${TMPDIR:-/tmp}/dtx-ctest.XXXXXX")
    echo "test: running ctest in $dir"
    local t0=$SECONDS
    ctest --test-dir "$repo/$dir" --output-on-failure --no-tests=error -j "$ctest_jobs" \
        "${ctest_args[@]}" 2>&1 | tee "$log"
    rc=${PIPESTATUS[0]}
    pass_dirs+=("$dir")
    pass_walls+=($((SECONDS - t0)))
    # "12/72 Test #12: core.sp04 ....   Passed    0.34 sec" -> "core.sp04 0.34"
    sed -nE 's/^ *[0-9]+\/[0-9]+ Test +#[0-9]+: ([^ ]+) .* ([0-9.]+) sec$/\1 \2/p' \
        "$log" > "$times/$dir"
    line=$(grep -E '^[0-9]+% tests passed, [0-9]+ tests? failed out of [0-9]+' "$log" | tail -n 1)
    # LeakSanitizer's own thread-stopping tracer sometimes crashes at exit on
    # a loaded machine ("Tracer caught signal 11", "LeakSanitizer has
    # encountered a fatal error"): that is no finding about dtx. Only then,
    # the failed tests are run once more, and the rerun counts (said loudly).
    if [[ $rc -ne 0 ]] && grep -q "LeakSanitizer has encountered a fatal error" "$log"; then
        echo "test: warning: LeakSanitizer's tracer crashed in $dir; running the failed tests again"
        summary+=("$dir: LeakSanitizer's tracer crashed; failed tests were run again")
        ctest --test-dir "$repo/$dir" --output-on-failure --rerun-failed -j "$ctest_jobs" 2>&1 |
            tee "$log.rerun"
        rc=${PIPESTATUS[0]}
        f=$(grep -E '^[0-9]+% tests passed, [0-9]+ tests? failed out of [0-9]+' "$log.rerun" |
            tail -n 1 | sed -E 's/.* ([0-9]+) tests? failed.*/\1/')
        t=$(sed -E 's/.* out of ([0-9]+).*/\1/' <<< "$line")
        [[ -z $f ]] || line="$(( (t - f) * 100 / t ))% tests passed, $f tests failed out of $t (after the rerun)"
        rm -f "$log.rerun"
    fi
    rm -f "$log"
    if [[ -n $line ]]; then
        f=$(sed -E 's/.* ([0-9]+) tests? failed.*/\1/' <<< "$line")
        t=$(sed -E 's/.* out of ([0-9]+).*/\1/' <<< "$line")
        total_pass=$((total_pass + t - f))
        total_fail=$((total_fail + f))
        summary+=("$dir: $line")
    else
        summary+=("$dir: ctest exited with status $rc and no summary")
        [[ $rc -eq 0 ]] || total_fail=$((total_fail + 1))
    fi
    if [[ $rc -ne 0 && $status -eq 0 ]]; then status=$rc; fi
}

ctest_args=("$@")
run_pass build

if [[ $sanitize_tests == 1 ]]; then
    # Leak checks on; the suppressions cover only MPI_Init's well-known leaks in
    # OpenMPI and its helpers, never dtx code. The sanitizer build never unloads
    # a library (tests/sanitizer/keep_loaded.c), so the fast frame-pointer
    # unwinder's stacks still name OpenMPI's plugins when LeakSanitizer reports
    # at exit (DWARF unwinding of every malloc cost each dtx start 0.6 s).
    export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1}
    export LSAN_OPTIONS=suppressions=$repo/tests/lsan.supp:print_suppressions=0
    export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
    # Lets test scripts know the binaries are sanitized (e.g. to skip valgrind).
    export DTX_SANITIZED=1
    # LeakSanitizer's tracer crashes at exit in ranks OpenMPI starts unbound
    # (--bind-to none) on this kind of machine: this mpirun drops that flag.
    export PATH="$repo/tests/sanitizer-bin:$PATH"
    # hwloc (under MPI_Init) loads its GL and OpenCL plugins when their
    # libraries are on the machine, which Blender and chromium bring; the
    # dynamic TLS of libOpenCL's ICD loader then crashes LeakSanitizer's
    # tracer at exit ("DTLS ... Tracer caught signal 11") in every process
    # that calls MPI_Init.  dtx uses neither: leave them out.
    export HWLOC_COMPONENTS=${HWLOC_COMPONENTS:--gl,-opencl}
    run_pass build-asan --sanitize
fi

# time_table: each test's seconds in each pass (the slowest first, by their
# sum), and each pass's wall time, so the suite's cost is visible in CI's log.
time_table() {
    local i
    [[ ${#pass_dirs[@]} -gt 0 ]] || return 0
    echo
    echo "test: time per test (s; ctest runs $ctest_jobs at a time)"
    (cd "$times" && awk -v dirs="${pass_dirs[*]}" '
        BEGIN { n = split(dirs, d, " ") }
        { t[$1, FILENAME] = $2; sum[$1] += $2; names[$1] = 1 }
        END {
            head = sprintf("  %-32s", "test")
            for (i = 1; i <= n; i++) head = head sprintf(" %10s", d[i])
            print head
            for (k in names) order[++m] = k
            # sort by the sum, largest first (insertion sort: ~100 tests)
            for (i = 2; i <= m; i++) {
                x = order[i]
                for (j = i - 1; j >= 1 && sum[order[j]] < sum[x]; j--) order[j + 1] = order[j]
                order[j + 1] = x
            }
            for (i = 1; i <= m; i++) {
                line = sprintf("  %-32s", order[i])
                for (j = 1; j <= n; j++)
                    line = line sprintf(" %10s", ((order[i], d[j]) in t) ? t[order[i], d[j]] : "-")
                print line
            }
        }' "${pass_dirs[@]}")
    for i in "${!pass_dirs[@]}"; do
        echo "  ${pass_dirs[$i]}: ctest wall time ${pass_walls[$i]} s"
    done
}
time_table

echo
echo "test: summary"
for s in "${summary[@]}"; do echo "  $s"; done
echo "total: $total_pass passed, $total_fail failed"
exit "$status"
