#!/usr/bin/env bash
# build.sh: configure and build dtx with CMake.
#
# Usage: scripts/build.sh [--sanitize] [--debug] [-- CMAKE_ARGS...]
#   (default)    Release build in build/
#   --sanitize   AddressSanitizer + UBSan build (RelWithDebInfo) in build-asan/
#   --debug      Debug build (in build-debug/, or build-asan/ with --sanitize)
#   -- ARGS      extra arguments for the cmake configure step
# Environment:
#   DTX_BUILD_DIR     build folder to use instead of the defaults above
#   DTX_WERROR=0      do not treat warnings as errors (default: on, as in CI)
#   DTX_SKIP_SETUP=1  do not run scripts/setup.sh first
#   JOBS              parallel build jobs (default: nproc)
set -euo pipefail

die() { echo "build: error: $*" >&2; exit 1; }

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
sanitize=0
debug=0
cmake_args=()
while [[ $# -gt 0 ]]; do
    case $1 in
        --sanitize) sanitize=1 ;;
        --debug) debug=1 ;;
        --) shift; cmake_args+=("$@"); break ;;
        -h | --help) sed -n '2,/^set -euo/p' "${BASH_SOURCE[0]}" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
        *) die "unknown option '$1' (see --help)" ;;
    esac
    shift
done

if [[ ${DTX_SKIP_SETUP:-0} != 1 ]]; then
    "$repo/scripts/setup.sh" || die "scripts/setup.sh failed"
fi

if [[ $sanitize == 1 ]]; then
    dir=build-asan
    type=RelWithDebInfo
    cmake_args=(-DDTX_SANITIZE=ON "${cmake_args[@]}")
else
    dir=build
    type=Release
    cmake_args=(-DDTX_SANITIZE=OFF "${cmake_args[@]}")
fi
if [[ $debug == 1 ]]; then
    type=Debug
    [[ $sanitize == 1 ]] || dir=build-debug
fi
dir=${DTX_BUILD_DIR:-$repo/$dir}
case ${DTX_WERROR:-1} in
    0 | OFF | off | no) werror=OFF ;;
    *) werror=ON ;;
esac
# GNU nproc honours OMP_NUM_THREADS, which says nothing about the compiler's jobs.
jobs=${JOBS:-$(env -u OMP_NUM_THREADS -u OMP_THREAD_LIMIT nproc)}

mkdir -p "$dir"
log=$dir/dtx-configure.log
echo "build: configuring $dir ($type, sanitize=$sanitize, werror=$werror)"
cmake -S "$repo" -B "$dir" -DCMAKE_BUILD_TYPE="$type" -DDTX_WERROR="$werror" \
    "${cmake_args[@]}" > "$log" 2>&1 || {
    cat "$log" >&2
    die "cmake configure of $dir failed (log: $log)"
}
echo "build: building $dir with $jobs jobs"
cmake --build "$dir" -j "$jobs" || die "build of $dir failed"
echo "build: done: $dir"
