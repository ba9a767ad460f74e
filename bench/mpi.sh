#!/usr/bin/env bash
# The spectral core on MPI, side by side: builds eci_bench_mpi_step (ECI_MPI=ON, Release) and, at each N,
# times a C-RK4 and an RK4 step of 2-D Navier-Stokes on 1 process (also the serial grid in the same process) with
# 1 and 2 threads, and on 2 processes of 1 thread (the transforms, and the all-to-alls of the retained columns inside
# them, timed too; also with Open MPI's single-copy mechanism off, layout=mpi-nocma); then prints the ratios (2 ranks / 1 rank, MPI / serial) and a model of larger runs (bench/mpi_model.py). Wall
# time, the fastest of the repetitions (each the slowest rank's); run it on an otherwise idle machine.
# Usage: bench/mpi.sh [--sizes 1024,2048] [--reps 5] [--build-dir DIR] [--out DIR]
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
sizes=2048
reps=5
build="$repo/build-bench-mpi"
out=""
while [[ $# -gt 0 ]]; do
  case "$1" in
    --sizes) [[ $# -ge 2 ]] || { echo "mpi.sh: --sizes needs a list" >&2; exit 2; }; sizes=$2; shift ;;
    --reps) [[ $# -ge 2 ]] || { echo "mpi.sh: --reps needs a number" >&2; exit 2; }; reps=$2; shift ;;
    --build-dir) [[ $# -ge 2 ]] || { echo "mpi.sh: --build-dir needs a directory" >&2; exit 2; }; build=$(realpath -m "$2"); shift ;;
    --out) [[ $# -ge 2 ]] || { echo "mpi.sh: --out needs a directory" >&2; exit 2; }; out=$(realpath -m "$2"); shift ;;
    -h|--help) sed -n '2,7p' "$0"; exit 0 ;;
    *) echo "mpi.sh: unknown argument $1" >&2; exit 2 ;;
  esac
  shift
done
out=${out:-$build/results}
mkdir -p "$out"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
echo "== building ($build, Release, ECI_MPI=ON)" >&2
cmake -S "$repo" -B "$build" -DCMAKE_BUILD_TYPE=Release -DECI_MPI=ON -DECI_BUILD_BENCH=ON -DECI_BUILD_TESTS=OFF \
      -DECI_BUILD_APPS=OFF -DECI_BUILD_PYTHON=OFF -DECI_BUILD_EXAMPLES=OFF "${launcher[@]}" > "$out/cmake.log"
cmake --build "$build" -j2 --target eci_bench_mpi_step >> "$out/cmake.log"
bin="$build/bench/eci_bench_mpi_step"
raw="$out/mpi_step.txt"
: > "$raw"
echo "== load before: $(cut -d' ' -f1-3 /proc/loadavg)" | tee -a "$raw" >&2
for n in ${sizes//,/ }; do
  # --bind-to none: the threads of a one-process run may use both cores
  mpirun --oversubscribe --bind-to none -np 1 "$bin" "$n" 1 "$reps" | tee -a "$raw"
  mpirun --oversubscribe --bind-to none -np 1 "$bin" "$n" 2 "$reps" | tee -a "$raw"
  mpirun --oversubscribe --bind-to core -np 2 "$bin" "$n" 1 "$reps" | tee -a "$raw"
  # the same with Open MPI's shared-memory transport copying through its own buffers (copy in, copy out) instead
  # of the single-copy mechanism (CMA, process_vm_readv): layout=mpi-nocma
  mpirun --oversubscribe --bind-to core --mca btl_vader_single_copy_mechanism none -np 2 "$bin" "$n" 1 "$reps" |
    sed 's/layout=mpi /layout=mpi-nocma /' | tee -a "$raw"
done
echo "== load after: $(cut -d' ' -f1-3 /proc/loadavg)" | tee -a "$raw" >&2
/usr/bin/python3 "$repo/bench/mpi_model.py" "$raw"
