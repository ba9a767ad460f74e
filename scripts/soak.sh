#!/usr/bin/env bash
# The long soak tests a CI run leaves out (label "long": the N = 128 Navier-Stokes run of 10^4 steps per method),
# in a Release build of their own. Usage: scripts/soak.sh [build dir]   (minutes; prints each test's output)
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${1:-"$repo/build-soak"}
cmake -S "$repo" -B "$build" -DCMAKE_BUILD_TYPE=Release -DECI_WERROR=ON -DECI_LONG_TESTS=ON > /dev/null
cmake --build "$build" -j2 --target eci_spectral_tests
ctest --test-dir "$build" --output-on-failure --no-tests=error -V -L long
