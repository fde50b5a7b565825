#!/usr/bin/env bash
# fuzz.sh: build the libFuzzer harnesses of tests/fuzz/ and run them.
#
# Usage: scripts/fuzz.sh [SECONDS_PER_TARGET] [TARGET...]
#   Builds every tests/fuzz/fuzz_NAME.c with clang, libFuzzer, AddressSanitizer
#   and UndefinedBehaviorSanitizer into build-fuzz/ (its own compile line: the
#   dtx sources of src/core and src/io go into one static library, so each
#   harness links only what it calls), then runs each TARGET (default: all of
#   them) for SECONDS_PER_TARGET seconds (default 600), one after another.
#   SECONDS_PER_TARGET 0 only builds. Targets are the NAMEs: obj ply off csv job
#   json_schema h5validate h5raw (see tests/fuzz/README.md).
#   Each run starts from the seeds in tests/fuzz/corpus/NAME/ plus the inputs
#   kept by earlier runs (build-fuzz/corpus/NAME/), uses tests/fuzz/NAME.dict
#   when present, keeps going after a crash (libFuzzer is started again for
#   the time left), and saves every crashing, leaking, hanging or memory-hungry
#   input under build-fuzz/crashes/NAME/. A summary line per target gives the executions,
#   the time and the number of new crash inputs.
# Environment:
#   DTX_FUZZ_DIR      build folder (default: build-fuzz in the source tree)
#   DTX_SKIP_SETUP=1  do not install clang when missing
#   JOBS              parallel compile jobs (default 2)
#   FUZZ_ARGS         extra libFuzzer arguments, e.g. FUZZ_ARGS=-max_len=4096
# Exit status: 0 when no target produced a crash input, 1 when one did, 2 on a
# usage or build error.
set -euo pipefail

die() { echo "fuzz: error: $*" >&2; exit 2; }

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
seconds=600
if [[ $# -gt 0 && $1 =~ ^[0-9]+$ ]]; then
    seconds=$1
    shift
elif [[ $# -gt 0 && ($1 == -h || $1 == --help) ]]; then
    sed -n '2,/^set -euo/p' "${BASH_SOURCE[0]}" | sed '$d; s/^# \{0,1\}//'
    exit 0
fi
dir=${DTX_FUZZ_DIR:-$repo/build-fuzz}
jobs=${JOBS:-2}

all_targets=()
for f in "$repo"/tests/fuzz/fuzz_*.c; do
    n=${f##*/fuzz_}
    all_targets+=("${n%.c}")
done
[[ ${#all_targets[@]} -gt 0 ]] || die "no harnesses in tests/fuzz/"
targets=("$@")
[[ ${#targets[@]} -gt 0 ]] || targets=("${all_targets[@]}")
for t in "${targets[@]}"; do
    [[ -f $repo/tests/fuzz/fuzz_$t.c ]] ||
        die "unknown target '$t' (known: ${all_targets[*]})"
done

# ---------------------------------------------------------------- clang
# libFuzzer's runtime is libclang-rt-14-dev (pulled in by clang-14) and
# -fopenmp needs libomp-dev; install what is missing, as setup.sh does.
need_pkgs() {
    local missing=() p
    for p in clang libclang-rt-14-dev libomp-dev; do
        dpkg-query -W -f='${Status}' "$p" 2> /dev/null | grep -q "install ok installed" ||
            missing+=("$p")
    done
    echo "${missing[@]}"
}
if ! command -v clang > /dev/null || [[ -n $(need_pkgs) ]]; then
    [[ ${DTX_SKIP_SETUP:-0} != 1 ]] || die "clang/libFuzzer missing and DTX_SKIP_SETUP=1"
    read -r -a pkgs <<< "$(need_pkgs)"
    [[ ${#pkgs[@]} -gt 0 ]] || pkgs=(clang)
    if [[ $(id -u) -eq 0 ]]; then as_root=(); else as_root=(sudo); fi
    echo "fuzz: installing: ${pkgs[*]}"
    "${as_root[@]}" apt-get -q update < /dev/null || die "apt-get update failed"
    "${as_root[@]}" env DEBIAN_FRONTEND=noninteractive apt-get -q install -y \
        --no-install-recommends "${pkgs[@]}" < /dev/null || die "apt-get install ${pkgs[*]} failed"
fi
command -v clang > /dev/null || die "clang not found after installing it"
"$repo/scripts/setup.sh" > /dev/null 2>&1 || [[ ${DTX_SKIP_SETUP:-0} == 1 ]] ||
    echo "fuzz: warning: scripts/setup.sh failed; the build may miss libraries" >&2

# ---------------------------------------------------------------- build
mkdir -p "$dir/obj" "$dir/bin" "$dir/corpus" "$dir/crashes"
version=$(sed -n 's/^project(dtx VERSION \([0-9.]*\).*/\1/p' "$repo/CMakeLists.txt")
hdf5_inc=/usr/include/hdf5/openmpi
hdf5_lib=/usr/lib/x86_64-linux-gnu/hdf5/openmpi
[[ -f $hdf5_inc/hdf5.h ]] || die "parallel HDF5 headers not found in $hdf5_inc"
read -r -a mpi_cflags <<< "$(mpicc --showme:compile)"
read -r -a mpi_libs <<< "$(mpicc --showme:link)"
# shellcheck disable=SC2054 # the commas belong to the compiler flags
cflags=(-std=c11 -g -O1 -fno-omit-frame-pointer -fopenmp
        -fsanitize=address,undefined -fno-sanitize-recover=undefined
        -Wall -Wextra -Wno-unused-parameter
        -D_POSIX_C_SOURCE=200809L "-DDTX_VERSION=\"$version\""
        "-DDTX_SCHEMA_DIR=\"$repo/schemas\"" -DDTX_FUZZING=1
        -I"$repo/src/core" -I"$repo/src/io" -I"$hdf5_inc" -I/usr/include/suitesparse "${mpi_cflags[@]}")
# shellcheck disable=SC2054
libs=(-L"$hdf5_lib" -Wl,-rpath,"$hdf5_lib" -lhdf5 "${mpi_libs[@]}" -lcjson -lpng
      -lcholmod -lsuitesparseconfig -llapack -lopenblas -lm)

# The library: every source newer than its object (or than any header) is
# compiled again, two at a time; a file that does not compile is skipped with
# a warning (another change may be in progress), and only fails the link of a
# harness that needs it.
newest_header=$(find "$repo/src" -name '*.h' -printf '%T@\n' | sort -n | tail -1)
compile_one() {
    local src=$1 obj=$2
    if clang "${cflags[@]}" -fsanitize=fuzzer-no-link -c "$src" -o "$obj.tmp" 2> "$obj.log"; then
        mv "$obj.tmp" "$obj"
    else
        rm -f "$obj.tmp" "$obj"
        echo "fuzz: warning: $src does not compile (skipped; see $obj.log)" >&2
    fi
}
pids=()
objs=()
for src in "$repo"/src/core/*.c "$repo"/src/io/*.c; do
    rel=${src#"$repo"/src/}
    obj=$dir/obj/${rel//\//_}
    obj=${obj%.c}.o
    objs+=("$obj")
    if [[ ! -f $obj || $src -nt $obj ]] ||
        [[ $(stat -c %Y "$obj") -lt ${newest_header%.*} ]]; then
        compile_one "$src" "$obj" &
        pids+=($!)
        if [[ ${#pids[@]} -ge $jobs ]]; then
            wait "${pids[0]}"
            pids=("${pids[@]:1}")
        fi
    fi
done
for p in "${pids[@]}"; do wait "$p"; done
# The job schema is compiled in (as in CMakeLists.txt's dtx_embed).
schema_c=$dir/obj/job_schema_json.c
if [[ ! -f $schema_c || $repo/schemas/job.schema.json -nt $schema_c ]]; then
    cmake -DIN="$repo/schemas/job.schema.json" -DOUT="$schema_c" -DSYM=dtx_job_schema_json \
        -P "$repo/cmake/embed.cmake" || die "embedding schemas/job.schema.json failed"
    compile_one "$schema_c" "${schema_c%.c}.o"
fi
objs+=("${schema_c%.c}.o")
present=()
for o in "${objs[@]}"; do [[ -f $o ]] && present+=("$o"); done
rm -f "$dir/libdtx_fuzz.a"
ar rcs "$dir/libdtx_fuzz.a" "${present[@]}" || die "ar failed"

for t in "${all_targets[@]}"; do
    src=$repo/tests/fuzz/fuzz_$t.c
    echo "fuzz: building fuzz_$t"
    clang "${cflags[@]}" -Werror -fsanitize=fuzzer -I"$repo/tests/fuzz" "$src" \
        "$dir/libdtx_fuzz.a" "${libs[@]}" -o "$dir/bin/fuzz_$t" ||
        die "cannot build fuzz_$t"
done
[[ $seconds -gt 0 ]] || { echo "fuzz: built in $dir/bin (SECONDS_PER_TARGET 0: not run)"; exit 0; }

# ---------------------------------------------------------------- run
export ASAN_OPTIONS=${ASAN_OPTIONS:-abort_on_error=0:detect_leaks=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1
# Scratch files of the HDF5 harnesses (tmpfs when available), removed at the end.
scratch_top=/tmp
[[ -d /dev/shm && -w /dev/shm ]] && scratch_top=/dev/shm
DTX_FUZZ_TMP=$(mktemp -d "$scratch_top/dtx-fuzz-run.XXXXXX")
export DTX_FUZZ_TMP
trap 'rm -rf "$DTX_FUZZ_TMP"' EXIT
trap 'exit 130' INT TERM
read -r -a extra <<< "${FUZZ_ARGS:-}"
status=0
summary=()
for t in "${targets[@]}"; do
    corpus=$dir/corpus/$t
    crashes=$dir/crashes/$t
    log=$dir/fuzz_$t.log
    mkdir -p "$corpus" "$crashes"
    before=$(find "$crashes" -type f | wc -l)
    # LeakSanitizer: the project's suppressions, plus tests/fuzz/NAME.lsan.supp
    # for a target that needs its own (h5raw: leaks inside HDF5 on corrupt files).
    supp=$dir/$t.lsan.supp
    cat "$repo/tests/lsan.supp" > "$supp"
    [[ -f $repo/tests/fuzz/$t.lsan.supp ]] && cat "$repo/tests/fuzz/$t.lsan.supp" >> "$supp"
    export LSAN_OPTIONS=suppressions=$supp:print_suppressions=0
    args=(-timeout=10 -rss_limit_mb=2048 -artifact_prefix="$crashes/" -print_final_stats=1)
    [[ -f $repo/tests/fuzz/$t.dict ]] && args+=(-dict="$repo/tests/fuzz/$t.dict")
    seeds=()
    [[ -d $repo/tests/fuzz/corpus/$t ]] && seeds+=("$repo/tests/fuzz/corpus/$t")
    echo "fuzz: running $t for $seconds s (log: $log)"
    # libFuzzer stops at the first crash, leak or hang: start it again (with
    # the corpus grown so far) for the time left, so that one bug does not
    # end the run, and count the executions of every start.
    : > "$log"
    execs=0
    starts=0
    left=$seconds
    start=$(date +%s)
    while [[ $left -gt 0 ]]; do
        rc=0
        (cd "$dir" && "$dir/bin/fuzz_$t" "${args[@]}" -max_total_time="$left" "${extra[@]}" \
            "$corpus" "${seeds[@]}") > "$dir/fuzz_$t.last.log" 2>&1 || rc=$?
        cat "$dir/fuzz_$t.last.log" >> "$log"
        n=$(sed -n 's/^stat::number_of_executed_units: //p' "$dir/fuzz_$t.last.log" | tail -1)
        execs=$((execs + ${n:-0}))
        starts=$((starts + 1))
        left=$((seconds - ($(date +%s) - start)))
        [[ $rc -ne 0 ]] || break
        # A failure before the corpus was read through (no INITED line) would
        # repeat at every start: an input of the corpus itself fails.
        if ! grep -q INITED "$dir/fuzz_$t.last.log"; then
            echo "fuzz: $t: an input of the corpus fails (status $rc); see $log" >&2
            break
        fi
    done
    elapsed=$(($(date +%s) - start))
    ncorp=$(find "$corpus" -type f | wc -l)
    after=$(find "$crashes" -type f | wc -l)
    new=$((after - before))
    line="$t: $execs executions in $elapsed s ($starts start(s)), $new new crash input(s),"
    line+=" corpus $ncorp"
    if [[ $new -gt 0 ]]; then
        line+=" (see $crashes/ and $log)"
        status=1
    fi
    summary+=("$line")
    echo "fuzz: $line"
done
echo "fuzz: summary"
printf '  %s\n' "${summary[@]}"
exit $status
