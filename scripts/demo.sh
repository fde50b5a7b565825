#!/usr/bin/env bash
# demo.sh: the cat -> lion example of the paper, end to end.
#
# Usage: scripts/demo.sh
#   Sets up, builds build/, unpacks the bundled meshes into build/data, imports
#   them into build/demo/cat-lion.h5, runs jobs/cat-lion.json under mpirun,
#   validates the result, draws a contact sheet of it (build/demo/cat-lion.png),
#   writes the report and exports the result for Blender (build/demo/blender/).
#   Safe to re-run (build/demo/cat-lion.h5 is rebuilt).
# Environment:
#   DTX_NP                MPI ranks (default 2)
#   OMP_NUM_THREADS       threads per rank (default 1)
#   OPENBLAS_NUM_THREADS  (default 1: BLAS threads would fight with OpenMP)
#   DTX_SKIP_SETUP=1      do not run scripts/setup.sh
set -euo pipefail

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$repo"

step="start"
on_exit() {
    local rc=$?
    if [[ $rc -ne 0 ]]; then echo "demo: FAILED at step: $step (exit status $rc)" >&2; fi
}
trap on_exit EXIT
run() {
    step=$1
    shift
    echo "demo: $step"
    "$@"
}

dtx=build/dtx
data=build/data/sumner-cat-lion
demo=build/demo
h5=$demo/cat-lion.h5
result=$demo/cat-lion-result.h5
job=jobs/cat-lion.json
np=${DTX_NP:-2}
# Count CPUs before setting OMP_NUM_THREADS: GNU nproc honours it.
ncpu=$(env -u OMP_NUM_THREADS -u OMP_THREAD_LIMIT nproc)
export OMP_NUM_THREADS=${OMP_NUM_THREADS:-1}
export OPENBLAS_NUM_THREADS=${OPENBLAS_NUM_THREADS:-1}

if [[ ${DTX_SKIP_SETUP:-0} != 1 ]]; then
    run "setup (scripts/setup.sh)" scripts/setup.sh
fi
run "build (scripts/build.sh)" env DTX_SKIP_SETUP=1 scripts/build.sh
step="check the build"
[[ -x $dtx ]] || { echo "demo: $dtx was not built" >&2; exit 1; }
[[ -f $job ]] || { echo "demo: job file $job not found" >&2; exit 1; }
run "unpack the data into build/data" scripts/unpack-data.sh build/data

# Start from scratch so that the demo is repeatable.
mkdir -p "$demo"
rm -rf "$h5" "$result" "$demo/lion-obj"
run "import the cat" "$dtx" import mesh "$data/source/cat-reference.obj" -o "$h5" --name cat
run "import the lion" "$dtx" import mesh "$data/target/lion-reference.obj" -o "$h5" --name lion
poses=()
for i in 01 02 03 04 05 06 07 08 09; do poses+=("$data/source/cat-$i.obj"); done
run "import the cat poses" "$dtx" import sequence "${poses[@]}" -o "$h5" --name cat-poses \
    --mesh /meshes/cat
run "import the markers" "$dtx" import markers "$data/markers.csv" --index-base 0 -o "$h5" \
    --name cat-lion --source /meshes/cat --target /meshes/lion

mpi=(mpirun -np "$np")
if [[ $(id -u) -eq 0 ]]; then
    export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
fi
if [[ $ncpu -lt $np ]]; then
    mpi+=(--oversubscribe)
fi
run "run $job on $np ranks x $OMP_NUM_THREADS threads" "${mpi[@]}" "$dtx" run "$job"
run "validate $result" "$dtx" validate "$result"
run "render a contact sheet of the result" "$dtx" render "$result" /results/lion/cat-poses \
    -o "$demo/cat-lion.png"
run "write the job report" "$dtx" report "$result" -o "$demo/report.md"
mkdir -p "$demo/blender"
run "export for Blender (README: Using results in Blender)" "$dtx" export "$result" \
    /results/lion/cat-poses --obj-rest "$demo/blender/lion.obj" --pc2 "$demo/blender/lion.pc2" \
    --mdd "$demo/blender/lion.mdd" --glb "$demo/blender/lion.glb"

step="report"
echo
echo "demo: done"
echo "  input:        $h5"
echo "  result:       $result"
echo "  report:       $demo/report.md (pictures in $demo/report-pictures/)"
echo "  for Blender:  $demo/blender/ (lion.glb; lion.obj with lion.pc2 or lion.mdd)"
if [[ -d $demo/lion-obj ]]; then
    echo "  OBJ frames:   $demo/lion-obj/ ($(find "$demo/lion-obj" -name '*.obj' | wc -l) files)"
else
    echo "  OBJ frames:   $demo/lion-obj/ (not written: check export_obj_dir in $job)"
fi
shopt -s nullglob
pictures=("$demo"/*.png)
for p in "${pictures[@]}"; do
    echo "  picture:      $p"
done
