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

# The user-facing text: `eci list`, and help (help legitimately changes when defaults are printed exactly).
"$eci" list > "$out/list.txt"
for model in three-wave n-wave n-wave-complex lotka-volterra kepler; do
  "$eci" run "$model" --help > "$out/help-$model.txt"
done
echo "recorded in $out" >&2
