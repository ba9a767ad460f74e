#!/usr/bin/env bash
# Peak memory per MPI process of `mpirun -np P eci run navier-stokes-2d` with and without files (a snapshot and a
# checkpoint every K steps), each process's maximum resident set from /usr/bin/time -f %M. The difference is what
# the files cost a process: a gathered whole field and half plane per process before the files were written by
# blocks, the process's own rows or columns after. Runs the given eci (an MPI build's), nothing is built.
# Usage: bench/mpi_memory.sh ECI [N (2048)] [P (2)] [STEPS (4)]
set -euo pipefail
eci=$(realpath "${1:?usage: mpi_memory.sh ECI [N] [P] [STEPS]}")
n=${2:-2048}
p=${3:-2}
steps=${4:-4}
every=$((steps / 2 > 0 ? steps / 2 : 1))
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
common=(--N "$n" --dt 1e-5 --steps "$steps" --method c-rk4 --update paper --fftw-estimate --fftw-wisdom none)
run() {  # tag, extra options: every process's peak (KiB) in peak.<tag>.<rank>
  local tag=$1
  shift
  mpirun --oversubscribe -np "$p" sh -c 'exec /usr/bin/time -f %M -o "peak.'"$tag"'.$OMPI_COMM_WORLD_RANK" "$@"' \
    sh "$eci" run navier-stokes-2d "${common[@]}" "$@" 2> "log.$tag" || { cat "log.$tag" >&2; exit 1; }
}
run plain
run files --snapshot-every "$every" --checkpoint-every "$every" --snapshot-dir snaps --checkpoint ck.h5
field=$((n * n * 8 / 1024))
half=$((n * (n / 2 + 1) * 16 / 1024))
echo "N = $n, $p processes, $steps C-RK4 steps, files every $every: one field $field KiB, one half plane $half KiB"
echo "rank  peak without files (KiB)  peak with files (KiB)  difference (KiB)  difference / field"
for ((r = 0; r < p; ++r)); do
  a=$(tail -n 1 "peak.plain.$r")
  b=$(tail -n 1 "peak.files.$r")
  awk -v r="$r" -v a="$a" -v b="$b" -v f="$field" \
    'BEGIN { printf "%4d  %24d  %21d  %16d  %18.2f\n", r, a, b, b - a, (b - a) / f }'
done
