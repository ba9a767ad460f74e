#!/usr/bin/env bash
# Records what the eci CLI writes for the paper's runs (figures' CSVs and scripts, `eci run` CSV, JSON and summary)
# so that two builds can be compared byte for byte: tests/cli/record_outputs.sh ECI_BINARY OUT_DIR, then diff -r.
# Only what depends on the clock is masked: wall time, and figures 8-9's CPU times (summary.csv rows *_cpu_*).
set -euo pipefail

if [[ $# -ne 2 ]]; then
  echo "usage: $0 ECI_BINARY OUT_DIR" >&2
  exit 2
fi
eci=$(realpath "$1")
out=$(realpath -m "$2")
mkdir -p "$out/figures" "$out/run"

# Figures: gnuplot is not needed to compare the data, so the plotting program is one that never starts.
ECI_GNUPLOT=/nonexistent/gnuplot "$eci" figures --out "$out/figures" > "$out/figures/stdout.txt" 2> /dev/null
# The printed table and summary.csv hold CPU times and the elapsed time; drop those lines.
sed -i -e '/_cpu_/d' -e '/CPU time/d' -e '/^wrote .* in .* s$/d' "$out/figures/stdout.txt" "$out/figures/summary.csv"

# One `eci run`: CSV (when asked), JSON summary without wall_seconds, and the stderr summary without wall time.
run() {
  local name=$1
  shift
  "$eci" run "$@" --summary-json "$out/run/$name.json" 2> "$out/run/$name.txt"
  sed -i '/"wall_seconds"/d' "$out/run/$name.json"
  sed -i -E 's/wall time [^ ]+ s/wall time - s/' "$out/run/$name.txt"
}

for model in three-wave n-wave n-wave-complex kepler; do
  run "$model-default" "$model" --output "$out/run/$model-default.csv"
done
# The Lotka-Volterra default is 8e5 steps: its summary measures every step, its CSV keeps every 100th.
run lotka-volterra-default lotka-volterra --output "$out/run/lotka-volterra-default.csv" --every 100

for method in c-pc pc rk4 c-rk4 c-euler rk2 c-rk2 c-pc-compensated implicit-midpoint euler; do
  run "three-wave-$method" three-wave --method "$method" --output "$out/run/three-wave-$method.csv"
done
run three-wave-fig5 three-wave --psi 1.2247448713915889,1,1.2247448713915889 --dt 0.2 --t-end 20 \
    --output "$out/run/three-wave-fig5.csv"
for method in c-pc pc rk4 c-rk4 c-euler c-pc-compensated; do
  run "n-wave-$method" n-wave --method "$method" --modes 60 --seed 7 --output "$out/run/n-wave-$method.csv" --every 10
  run "n-wave-complex-$method" n-wave-complex --method "$method" --modes 12 --triads-per-mode 4 \
      --output "$out/run/n-wave-complex-$method.csv"
done
for method in c-pc pc kahan c-rk4 rk4; do
  run "lotka-volterra-$method" lotka-volterra --method "$method" --t-end 200 --output "$out/run/lotka-volterra-$method.csv"
done
run lotka-volterra-mu lotka-volterra --mu 0.7 --x 2 --y 0.5 --steps 5000 --output "$out/run/lotka-volterra-mu.csv"
for method in c-pc pc c-rk4 rk4 c-rk2 euler; do
  run "kepler-$method" kepler --method "$method" --output "$out/run/kepler-$method.csv"
done
run kepler-pc-fig8 kepler --method pc --dt 0.08 --steps 1313 --output "$out/run/kepler-pc-fig8.csv"
run kepler-params kepler --K 2 --ell 1.2 --r 0.9 --v-r 0.1 --theta 0.3 --steps 3000 --dt 0.01 \
    --output "$out/run/kepler-params.csv"

# The spectral equations on a small grid (FFTW_ESTIMATE plans and no wisdom file, so that a run repeats bit for bit):
# every method, forcing, dissipation, the dispersive equation, snapshots, a checkpoint and the restart from it, a
# step so long that it is halved and retried in the advective form, a blow-up and a refused method.
spectral() {
  run "$@" --N 32 --fftw-estimate --fftw-wisdom none
}
for method in c-rk4 c-pc c-rk2 rk4 pc rk2 euler; do
  spectral "ns2d-$method" navier-stokes-2d --method "$method" --steps 40 --every 5 --output "$out/run/ns2d-$method.csv"
done
spectral ns2d-stochastic navier-stokes-2d --nu 0.01 --forcing stochastic --injection-rate 0.5 --steps 30 \
    --output "$out/run/ns2d-stochastic.csv"
spectral ns2d-deterministic navier-stokes-2d --hyper-nu 1e-6 --drag 0.05 --hypo-nu 0.01 --forcing deterministic \
    --method c-pc --steps 30 --every 3 --output "$out/run/ns2d-deterministic.csv"
spectral ns2d-taylor-green navier-stokes-2d --ic taylor-green --dt 0.05 --steps 20 --output "$out/run/ns2d-taylor-green.csv"
spectral chm charney-hasegawa-mima --beta 2 --deformation 1 --nu 0.001 --steps 30 --output "$out/run/chm.csv"
spectral sqg surface-qg --steps 30 --every 2 --output "$out/run/sqg.csv"
mkdir -p "$out/run/snapshots"
ECI_GNUPLOT=/nonexistent/gnuplot spectral ns2d-snapshots navier-stokes-2d --forcing stochastic --nu 0.01 --steps 20 \
    --snapshot-every 10 --snapshot-dir "$out/run/snapshots" --checkpoint "$out/run/ns2d-checkpoint.h5" \
    --checkpoint-every 10 --output "$out/run/ns2d-snapshots.csv"
"$eci" run navier-stokes-2d --restart "$out/run/ns2d-checkpoint.h5" --steps 35 --fftw-wisdom none \
    --checkpoint "$out/run/ns2d-restarted.h5" --checkpoint-every 7 --every 4 --output "$out/run/ns2d-restart.csv" \
    --summary-json "$out/run/ns2d-restart.json" 2> "$out/run/ns2d-restart.txt"
sed -i '/"wall_seconds"/d' "$out/run/ns2d-restart.json"
sed -i -E 's/wall time [^ ]+ s/wall time - s/' "$out/run/ns2d-restart.txt"
rm -f "$out"/run/snapshots/*.png
spectral ns2d-halvings navier-stokes-2d --dt 5 --steps 10 --output "$out/run/ns2d-halvings.csv"
"$eci" run navier-stokes-2d --N 32 --fftw-estimate --fftw-wisdom none --method rk4 --dt 2 --steps 50 \
    2> "$out/run/ns2d-blow-up.txt" && exit 1
"$eci" run navier-stokes-2d --N 32 --method dp54 2> "$out/run/ns2d-refused.txt" && exit 1

# Adaptive step control (--rtol/--atol): every pair, rows per accepted step or at --output-dt times (landing or
# dense output), and fixed steps with --output-dt (rows every k steps); then the refusals of --output-dt.
for method in c-dp54 dp54 c-bs32 bs32 c-ck54 c-dp853 dp853 c-f78 f78; do
  run "three-wave-adaptive-$method" three-wave --method "$method" --rtol 1e-8 --t-end 20 \
      --output "$out/run/three-wave-adaptive-$method.csv"
done
run kepler-adaptive-output-dt kepler --method c-dp54 --rtol 1e-9 --atol 1e-12 --t-end 30 --output-dt 0.5 \
    --output "$out/run/kepler-adaptive-output-dt.csv"
run lotka-volterra-adaptive-output-dt lotka-volterra --method c-dp853 --rtol 1e-7 --t-end 20 --output-dt 0.25 \
    --output "$out/run/lotka-volterra-adaptive-output-dt.csv"
run n-wave-adaptive n-wave --method c-dp54 --atol 1e-7 --modes 30 --seed 3 --t-end 3 --every 5 \
    --output "$out/run/n-wave-adaptive.csv"
run three-wave-output-dt three-wave --method c-rk4 --dt 0.01 --t-end 10 --output-dt 0.25 \
    --output "$out/run/three-wave-output-dt.csv"
run three-wave-output-dt-steps three-wave --method c-pc --dt 0.02 --steps 500 --output-dt 0.1 \
    --output "$out/run/three-wave-output-dt-steps.csv"
run three-wave-rrk-output-dt three-wave --method rrk-rk4 --dt 0.05 --t-end 10 --output-dt 0.5 \
    --output "$out/run/three-wave-rrk-output-dt.csv"
i=0
for options in "--dt 0.03 --output-dt 0.25" "--output-dt 0" "--output-dt -1" \
               "--method c-dp54 --rtol 1e-6 --output-dt 1e-7" "--method c-dp54 --rtol 1e-6 --steps 10" \
               "--method c-dp54 --rtol 0" "--method c-dp54 --atol -1"; do
  i=$((i + 1))
  # shellcheck disable=SC2086
  "$eci" run three-wave $options 2> "$out/run/refused-$i.txt" && exit 1
done

# The user-facing text: `eci list`, and help (help legitimately changes when defaults are printed exactly).
"$eci" list > "$out/list.txt"
for model in three-wave n-wave n-wave-complex lotka-volterra kepler navier-stokes-2d charney-hasegawa-mima surface-qg; do
  "$eci" run "$model" --help > "$out/help-$model.txt"
done
echo "recorded in $out" >&2
