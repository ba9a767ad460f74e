#!/usr/bin/env bash
# Builds the benchmarks in Release, runs them all and prints one table of side-by-side ratios with their targets.
# Usage: bench/run.sh [--quick | --smoke] [--ns2d] [--pyfftw-sizes LIST] [--long] [--json FILE] [--out DIR]
#                     [--build-dir DIR] [--apps-from DIR]
#   --quick  smaller large systems and fewer repetitions (under two minutes)
#   --smoke  every program for a token run, compiled at -O0 in build-bench-smoke/ (CI: keeps them compiling and
#            running); numbers meaningless
#   --ns2d   also the 2-D Navier-Stokes benchmarks (N = 1024 steps, threads, N = 128..4096 scaling x 3, radicands
#            at N = 256 and 1024, NumPy; ~30 min) and eci against the pyFFTW script (N = 256..4096, 1 and 2
#            threads; --quick 256..1024; --smoke only its check at N = 32; skipped if python3-pyfftw is missing)
#   --pyfftw-sizes LIST  the N of the pyFFTW comparison, e.g. 256,512,1024
#   --long   also the 1e7-step round-off runs of compensated C-RK4 / C-DP54 (adaptive bench; minutes)
#   --apps-from DIR  take the CLI (DIR/eci) and the Python module (DIR/python) from a Release build DIR instead of
#            building them here (CI's smoke run, after scripts/test.sh's own Release build)
set -euo pipefail

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
mode=full
json=""
out=""
build=""
ns2d=0
long=0
apps=""
pyfftw_sizes=""
while [[ $# -gt 0 ]]; do
  case "$1" in
    --quick) mode=quick ;;
    --smoke) mode=smoke ;;
    --ns2d) ns2d=1 ;;
    --long) long=1 ;;
    --pyfftw-sizes) [[ $# -ge 2 ]] || { echo "run.sh: --pyfftw-sizes needs a list" >&2; exit 2; }; pyfftw_sizes=$2; shift ;;
    --json) [[ $# -ge 2 ]] || { echo "run.sh: --json needs a file name" >&2; exit 2; }; json=$(realpath -m "$2"); shift ;;
    --out) [[ $# -ge 2 ]] || { echo "run.sh: --out needs a directory" >&2; exit 2; }; out=$(realpath -m "$2"); shift ;;
    --build-dir) [[ $# -ge 2 ]] || { echo "run.sh: --build-dir needs a directory" >&2; exit 2; }; build=$(realpath -m "$2"); shift ;;
    --apps-from) [[ $# -ge 2 ]] || { echo "run.sh: --apps-from needs a directory" >&2; exit 2; }; apps=$(realpath -m "$2"); shift ;;
    -h|--help) sed -n '2,14p' "$0"; exit 0 ;;
    *) echo "run.sh: unknown argument $1" >&2; exit 2 ;;
  esac
  shift
done
# --smoke only keeps the programs compiling and running, so it compiles them at -O0 (the same sources; at -O1
# step_bench.cpp alone took 159-231 s of a cold CI's compiles, at -O0 12 s, and the token runs stay short), in a
# tree of its own, so that a timed run's tree never holds its flags.
opt=-O3  # CMake's Release flags for GCC, given explicitly: a tree a smoke run configured keeps no -O0
if [ -z "$build" ]; then
  if [ "$mode" = smoke ]; then build="$repo/build-bench-smoke"; else build="$repo/build-bench-release"; fi
fi
[ "$mode" = smoke ] && opt=-O0
out=${out:-$build/results-$mode}
mkdir -p "$out"

# Sizes and repetitions per mode. The large n-wave systems are 3e6 real modes (memory bound); --quick keeps that
# size for the cheap right-hand side (the C-PC / PC target's size) and takes 3e5 for the realistic one.
case $mode in
  full)  big=3000000; big_real=3000000; reps=9; big_pairs=11; odeint_pairs=9; min_time=0.1;  mem_n=9999999; mem_reps=3; drift_steps=10000000; drift_members=8; wp_quick=0 ;;
  quick) big=3000000; big_real=300000;  reps=5; big_pairs=7;  odeint_pairs=5; min_time=0.05; mem_n=9999999; mem_reps=1; drift_steps=1000000;  drift_members=4; wp_quick=1 ;;
  smoke) big=3003;    big_real=3003;    reps=1; big_pairs=1;  odeint_pairs=1; min_time=1e-6; mem_n=30000;   mem_reps=1; drift_steps=1000;     drift_members=1; wp_quick=1 ;;
esac
# The cost of conservation at the users' step sizes (CLI default dt = 0.01, CFL-like, and the old dt = 1e-5),
# realistic n-wave system, remedy against the halving it replaces.
case $mode in
  full)  remedy_sizes=100000,1000000; remedy_pairs=7; remedy_before=1 ;;
  quick) remedy_sizes=100000;         remedy_pairs=5; remedy_before=1 ;;
  smoke) remedy_sizes=3000;           remedy_pairs=1; remedy_before=1 ;;
esac

echo "== building ($build, Release at $opt, same flags for eci and Boost.Odeint)" >&2
cmake -S "$repo" -B "$build" -DCMAKE_BUILD_TYPE=Release -DECI_BUILD_BENCH=ON -DECI_BUILD_TESTS=OFF \
      -DECI_BUILD_APPS=ON -DECI_BUILD_PYTHON=ON -DPython3_EXECUTABLE=/usr/bin/python3 -DECI_BUILD_EXAMPLES=OFF \
      -DCMAKE_CXX_FLAGS_RELEASE="$opt -DNDEBUG" > "$out/cmake.log"
# eci_cli and eci_python: the Python module against the CLI, both built here with the same flags (or taken from
# --apps-from's build)
cmake --build "$build" -j2 --target eci_bench_step eci_bench_memory_driver eci_bench_work_precision eci_bench_drift \
      eci_bench_remedy eci_bench_adaptive eci_bench_adaptive_nwave eci_bench_compare_methods $([ -z "$apps" ] && echo eci_cli eci_python) \
      $([ $ns2d = 1 ] && echo eci_bench_ns2d_step eci_bench_ns2d_radicand) >> "$out/cmake.log"
bin="$build/bench"
apps=${apps:-$build}

echo "== per-step cost ($reps interleaved repetitions, large systems N=$big and $big_real)" >&2
"$bin/eci_bench_step" --eci_big=$big --eci_big_realistic=$big_real --eci_big_realistic_pairs=$big_pairs \
    --eci_odeint_pairs=$odeint_pairs --eci_min_time=$min_time --benchmark_repetitions=$reps --benchmark_enable_random_interleaving=true --benchmark_report_aggregates_only=true \
    --benchmark_out="$out/step.json" --benchmark_out_format=json > "$out/step.txt" 2>&1

echo "== conservation at the users' step sizes: remedy vs halving, N=$remedy_sizes, $remedy_pairs paired steps" >&2
"$bin/eci_bench_remedy" --sizes=$remedy_sizes --pairs=$remedy_pairs --before-pairs=$remedy_before \
    --csv="$out/remedy.csv" > "$out/remedy.txt"

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

echo "== adaptive: work-precision against odeint, per-step cost C-DP54/DP54 (N=$big_real)" >&2
long_steps=0
if [ "$long" = 1 ]; then long_steps=10000000; fi
if [ "$mode" = smoke ]; then long_steps=$((long * 1000)); fi
"$bin/eci_bench_adaptive" $wp_quick "$out/adaptive.csv" $big_real $long_steps > "$out/adaptive.txt"

echo "== adaptive: c-dp54 against dp54 at equal error on random n-wave systems (conditioned update)" >&2
"$bin/eci_bench_adaptive_nwave" "$out/adaptive_nwave.csv" >> "$out/adaptive.txt"

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
  for model in $(tail -n +2 "$out/adaptive.csv" | cut -d, -f1 | sort -u); do
    gnuplot -e "csv='$out/adaptive.csv'; model='$model'; out='$out/adaptive_$model'" "$repo/bench/plot_adaptive.gp"
  done
else
  echo "run.sh: gnuplot not found, figures skipped" >&2
fi

echo "== results in $out" >&2
python3 "$repo/bench/report.py" --steps "$out/step.json" --memory "$out/memory.txt" --drift "$out/drift.txt" \
    --mem-n $mem_n --drift-steps $drift_steps ${json:+--json "$json"} | tee "$out/table.txt"
echo
echo "negative radicands at the users' step sizes (realistic n-wave, 20 triads/mode; per step; cpu ratio = fastest"
echo "paired steps (median of pair ratios)); targets C-PC/PC and C-RK4/RK4 <= 1.10 in rhs and cpu, no halvings:"
tee -a "$out/table.txt" < "$out/remedy.txt"

# Python: a built-in model through eci.solve against `eci run` (target <= 1.05), and the overhead per
# right-hand-side call of a Python fun against solve_ivp's (target <= 1); each side by side in one process.
echo "== Python: eci.solve against eci run, and per-call overhead against solve_ivp" >&2
case $mode in
  full)  py_opts="--reps 7" ;;
  quick) py_opts="--reps 5 --quick" ;;
  smoke) py_opts="--reps 1 --smoke" ;;
esac
{
  echo
  echo "Python: a built-in model through eci.solve / eci run of the same integration (bench/python_vs_cli.py)"
  PYTHONPATH="$apps/python" /usr/bin/python3 "$repo/bench/python_vs_cli.py" --cli "$apps/eci" $py_opts \
    || echo "(python_vs_cli: a target MISSED)"
  echo
  echo "Python: overhead per fun call, eci.solve / solve_ivp RK45 (bench/python_overhead.py)"
  PYTHONPATH="$apps/python" /usr/bin/python3 "$repo/bench/python_overhead.py" $py_opts \
    || echo "(python_overhead: a target MISSED)"
  echo
  echo "Python: eci's pairs as SciPy solvers, cost per step against RK45 (bench/scipy_overhead.py)"
  PYTHONPATH="$apps/python" /usr/bin/python3 "$repo/bench/scipy_overhead.py" $py_opts
} | tee -a "$out/table.txt" | tee "$out/python.txt"
if [ "$mode" = smoke ]; then echo "(smoke run: every program ran once, at token sizes: the ratios above mean nothing)"; fi
grep -h "^wp " "$out/work_precision.txt" | grep -v "lvk=" > "$out/work_precision_summary.txt" || true

if [ $ns2d = 1 ]; then
  # 2-D Navier-Stokes: every ratio measured side by side in one process; the wisdom file keeps plans.
  wisdom="$out/fftw-wisdom"
  case $mode in
    full)  sizes="128 256 512 1024 2048 4096"; big=1024; reps=5; rad="256:100 1024:50"; scal_runs=3 ;;
    quick) sizes="128 256 512 1024"; big=1024; reps=3; rad="256:20"; scal_runs=1 ;;
    smoke) sizes="32 64"; big=64; reps=1; rad="64:2"; scal_runs=1 ;;
  esac
  echo "== ns2d: per-step cost, N=$big, 1 thread (CPU time), and 2 threads against 1 (wall time, paired)" >&2
  : > "$out/ns2d_step.txt"
  for t in 1 2; do "$bin/eci_bench_ns2d_step" $big $t $reps "$wisdom" >> "$out/ns2d_step.txt"; done
  echo "== ns2d: step time against N^2 log N (N = $sizes, $scal_runs runs each), peak memory" >&2
  : > "$out/ns2d_scaling.txt"
  for ((run = 0; run < scal_runs; ++run)); do
    for n in $sizes; do
      /usr/bin/time -f "ns2d-memory N=$n peak_kib=%M" "$bin/eci_bench_ns2d_step" $n 1 $reps "$wisdom" \
        >> "$out/ns2d_scaling.txt" 2>> "$out/ns2d_scaling.txt"
    done
  done
  echo "== ns2d: negative radicands at CFL 0.5 (N:steps = $rad)" >&2
  : > "$out/ns2d_radicand.txt"
  for r in $rad; do "$bin/eci_bench_ns2d_radicand" ${r%:*} ${r#*:} >> "$out/ns2d_radicand.txt"; done
  echo "== ns2d: independent NumPy solver" >&2
  {
    /usr/bin/python3 "$repo/bench/ns2d_numpy.py" check "$apps/eci" || echo "ns2d-numpy check FAILED"
    [ "$mode" = smoke ] || /usr/bin/python3 "$repo/bench/ns2d_numpy.py" time "$apps/eci"
  } > "$out/ns2d_numpy.txt"
  # A careful pyFFTW script (both forms of the nonlinear term) against eci, side by side; its check runs
  # in every mode, the timing outside --smoke. Without python3-pyfftw a line says so and nothing fails.
  case $mode in
    full)  pf_sizes=256,512,1024,2048,4096; pf_rounds=3; pf_reps=5; pf_check="--n 128 --steps 100" ;;
    quick) pf_sizes=256,512,1024;           pf_rounds=3; pf_reps=3; pf_check="--n 128 --steps 100" ;;
    smoke) pf_sizes="";                     pf_rounds=1; pf_reps=1; pf_check="--n 32 --steps 20" ;;
  esac
  pf_sizes=${pyfftw_sizes:-$pf_sizes}
  {
    if /usr/bin/python3 -c "import pyfftw, h5py" 2> /dev/null; then
      echo "== ns2d: against a pyFFTW script (N = ${pf_sizes:-none, check only})" >&2
      /usr/bin/python3 "$repo/bench/ns2d_pyfftw.py" check "$apps/eci" $pf_check || echo "ns2d-pyfftw check FAILED"
      if [ -n "$pf_sizes" ]; then
        uptime
        /usr/bin/python3 "$repo/bench/ns2d_vs_pyfftw.py" --bench "$bin/eci_bench_ns2d_step" --eci "$apps/eci" \
          --sizes "$pf_sizes" --rounds $pf_rounds --reps $pf_reps --out "$out/pyfftw" 2> "$out/ns2d_pyfftw_rows.txt" \
          || echo "ns2d-vs-pyfftw FAILED (rows so far in $out/ns2d_pyfftw_rows.txt)"
        uptime
      fi
    else
      echo "ns2d-pyfftw: SKIPPED, python3-pyfftw (or h5py) is not installed for /usr/bin/python3 (scripts/setup.sh)"
    fi
  } > "$out/ns2d_pyfftw.txt"
  python3 - "$out" <<'PY'
import re, sys
out = sys.argv[1]
def fields(line):
    return dict(kv.split("=", 1) for kv in line.split()[1:] if "=" in kv)
steps = [fields(l) for l in open(out + "/ns2d_step.txt") if l.startswith("ns2d-step")]
print("\n2-D Navier-Stokes (targets in brackets)")
for s in steps:
    print("  N=%s threads=%s (%s time): C-RK4/RK4 %s [<= 1.03], C-PC/PC %s [<= 1.03], C-RK4 step / its FFTs %s [<= 1.3], "
          "right-hand sides / their FFTs %s" % (s["N"], s["threads"], s["clock"], s["c_rk4/rk4"], s["c_pc/pc"], s["c_rk4/fft"],
                                                s["rhs/fft"]))
for l in open(out + "/ns2d_step.txt"):
    if l.startswith("ns2d-threads"):
        f = fields(l)
        print("  2 threads vs 1 (C-RK4 step, paired, wall time): %s [>= 1.6]" % f["speedup"])
import math, statistics
scal = [fields(l) for l in open(out + "/ns2d_scaling.txt") if l.startswith("ns2d-step")]
mem = {f["N"]: f["peak_kib"] for f in (fields(l) for l in open(out + "/ns2d_scaling.txt") if l.startswith("ns2d-memory"))}
by_n = {}
for s in scal: by_n.setdefault(int(s["N"]), []).append(s)
with open(out + "/ns2d_scaling.csv", "w") as f:
    f.write("N,c_rk4_step_seconds,per_N2logN,peak_kib,c_rk4_over_fft\n")
    for n in sorted(by_n):
        t = statistics.median(float(s["c_rk4"]) for s in by_n[n])
        r = [float(s["c_rk4/fft"]) for s in by_n[n]]
        f.write("%d,%.6g,%.6g,%s,%.4f\n" % (n, t, t / (n * n * math.log2(n)), mem.get(str(n), ""), statistics.median(r)))
        print("  N=%5d: C-RK4 step %.4g s (median of %d runs, CPU), per N^2 log2 N %.3g ns, step / FFTs %.3f-%.3f, "
              "peak memory %s KiB" % (n, t, len(r), 1e9 * t / (n * n * math.log2(n)), min(r), max(r), mem.get(str(n), "?")))
for l in open(out + "/ns2d_numpy.txt"): print("  " + l.strip())
for l in open(out + "/ns2d_radicand.txt"): print("  " + l.strip())
print("\n2-D Navier-Stokes against the pyFFTW script (targets at N = 1024: C-RK4 / script <= 0.7 on 1 thread, "
      "<= 0.6 on 2; C-RK4 / FFTs <= 1.15; C-RK4 / RK4 <= 1.03)")
for l in open(out + "/ns2d_pyfftw.txt"): print("  " + l.rstrip())
PY
  if command -v gnuplot > /dev/null; then
    gnuplot -e "set terminal pngcairo size 640,480; set output '$out/ns2d_scaling.png'; set datafile separator ','; \
      set logscale xy; set xlabel 'N'; set ylabel 'C-RK4 step (s)'; set key top left; set fit logfile '$out/fit.log'; \
      f(x) = c * x**2 * log(x); c = 1e-9; fit f(x) '$out/ns2d_scaling.csv' skip 1 using 1:2 via c; \
      plot '$out/ns2d_scaling.csv' skip 1 using 1:2 with linespoints pt 7 title 'eci C-RK4', f(x) title 'c N^2 log N'" \
      2> /dev/null || true
  fi
fi
cat "$out/adaptive.txt"
