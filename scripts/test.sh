#!/usr/bin/env bash
# Builds everything with warnings as errors and runs the whole test suite, then once more under
# AddressSanitizer + UndefinedBehaviorSanitizer, and keeps the benchmarks compiling (one token iteration each).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
jobs=2

echo "== Release build, -Werror"
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DECI_WERROR=ON >/dev/null
cmake --build build -j$jobs
ctest --test-dir build --output-on-failure -j$jobs

echo "== AddressSanitizer + UndefinedBehaviorSanitizer"
cmake -S . -B build-sanitize -DCMAKE_BUILD_TYPE=RelWithDebInfo -DECI_WERROR=ON -DECI_SANITIZE=ON >/dev/null
cmake --build build-sanitize -j$jobs
ctest --test-dir build-sanitize --output-on-failure -j$jobs

if [ -x bench/run.sh ]; then
  echo "== Benchmarks: build and one token iteration each"
  bench/run.sh --smoke
fi
