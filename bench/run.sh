#!/usr/bin/env bash
# Builds the benchmarks in Release, runs them all and prints one table of side-by-side ratios with their targets.
# Usage: bench/run.sh [--quick | --smoke] [--json FILE] [--out DIR] [--build-dir DIR]
#   --quick  smaller large systems and fewer repetitions (under two minutes)
#   --smoke  every program for a token run (CI: keeps them compiling and running, under a minute); numbers meaningless
set -euo pipefail

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
mode=full
json=""
out=""
build="$repo/build-bench-release"
while [[ $# -gt 0 ]]; do
  case "$1" in
    --quick) mode=quick ;;
    --smoke) mode=smoke ;;
    --json) [[ $# -ge 2 ]] || { echo "run.sh: --json needs a file name" >&2; exit 2; }; json=$(realpath -m "$2"); shift ;;
    --out) [[ $# -ge 2 ]] || { echo "run.sh: --out needs a directory" >&2; exit 2; }; out=$(realpath -m "$2"); shift ;;
    --build-dir) [[ $# -ge 2 ]] || { echo "run.sh: --build-dir needs a directory" >&2; exit 2; }; build=$(realpath -m "$2"); shift ;;
    -h|--help) sed -n '2,6p' "$0"; exit 0 ;;
    *) echo "run.sh: unknown argument $1" >&2; exit 2 ;;
  esac
  shift
done
out=${out:-$build/results-$mode}
mkdir -p "$out"

# Sizes and repetitions per mode. The large n-wave systems are 3e6 real modes (memory bound); --quick keeps that
# size for the cheap right-hand side (the C-PC / PC target's size) and takes 3e5 for the realistic one.
case $mode in
  full)  big=3000000; big_real=3000000; reps=9; big_pairs=11; min_time=0.1;  mem_n=9999999; mem_reps=3; drift_steps=10000000; drift_members=8; wp_quick=0 ;;
  quick) big=3000000; big_real=300000;  reps=5; big_pairs=7;  min_time=0.05; mem_n=9999999; mem_reps=1; drift_steps=1000000;  drift_members=4; wp_quick=1 ;;
  smoke) big=3003;    big_real=3003;    reps=1; big_pairs=1;  min_time=1e-6; mem_n=30000;   mem_reps=1; drift_steps=1000;     drift_members=1; wp_quick=1 ;;
esac

echo "== building ($build, Release, same flags for eci and Boost.Odeint)" >&2
cmake -S "$repo" -B "$build" -DCMAKE_BUILD_TYPE=Release -DECI_BUILD_BENCH=ON -DECI_BUILD_TESTS=OFF \
      -DECI_BUILD_APPS=OFF -DECI_BUILD_EXAMPLES=OFF > "$out/cmake.log"
cmake --build "$build" -j2 --target eci_bench_step eci_bench_memory_driver eci_bench_work_precision eci_bench_drift \
      eci_bench_compare_methods \
      >> "$out/cmake.log"
bin="$build/bench"

echo "== per-step cost ($reps interleaved repetitions, large systems N=$big and $big_real)" >&2
"$bin/eci_bench_step" --eci_big=$big --eci_big_realistic=$big_real --eci_big_realistic_pairs=$big_pairs \
    --eci_min_time=$min_time --benchmark_repetitions=$reps --benchmark_enable_random_interleaving=true --benchmark_report_aggregates_only=true \
    --benchmark_out="$out/step.json" --benchmark_out_format=json > "$out/step.txt" 2>&1

echo "== peak memory, N=$mem_n, each stepper in its own process" >&2
: > "$out/memory.txt"
for ((r = 0; r < mem_reps; ++r)); do
  for s in none pc c_pc c_pc_compensated rk4 c_rk4; do
    "$bin/eci_bench_memory_driver" $s $mem_n 3 >> "$out/memory.txt"
  done
done

echo "== long-run drift, $drift_steps steps x $drift_members initial conditions" >&2
"$bin/eci_bench_drift" $drift_steps $drift_members "$out/drift.csv" > "$out/drift.txt"

echo "== work-precision" >&2
"$bin/eci_bench_work_precision" $wp_quick "$out/work_precision.csv" > "$out/work_precision.txt"

echo "== keeping invariants: every family head to head (docs/comparison.md)" >&2
"$bin/eci_bench_compare_methods" $wp_quick "$out/compare.csv" "$out/compare.md" > "$out/compare.txt"

if command -v gnuplot > /dev/null; then
  for problem in $(tail -n +2 "$out/compare.csv" | cut -d, -f1 | sort -u); do
    gnuplot -e "csv='$out/compare.csv'; problem='$problem'; out='$out/cmp_$problem'" "$repo/bench/plot_compare.gp" 2> /dev/null
  done
  for model in $(tail -n +2 "$out/work_precision.csv" | cut -d, -f1 | sort -u); do
    gnuplot -e "csv='$out/work_precision.csv'; model='$model'; out='$out/wp_$model'" "$repo/bench/plot_work_precision.gp"
  done
  gnuplot -e "csv='$out/drift.csv'; out='$out/drift'" "$repo/bench/plot_drift.gp"
else
  echo "run.sh: gnuplot not found, figures skipped" >&2
fi

echo "== results in $out" >&2
python3 "$repo/bench/report.py" --steps "$out/step.json" --memory "$out/memory.txt" --drift "$out/drift.txt" \
    --mem-n $mem_n --drift-steps $drift_steps ${json:+--json "$json"} | tee "$out/table.txt"
if [ "$mode" = smoke ]; then echo "(smoke run: every program ran once, at token sizes: the ratios above mean nothing)"; fi
grep -h "^wp " "$out/work_precision.txt" | grep -v "lvk=" > "$out/work_precision_summary.txt" || true
