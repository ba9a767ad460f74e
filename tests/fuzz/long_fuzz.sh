#!/usr/bin/env bash
# The long run of the CLI property test (tests/cli/test_cli_fuzz.cpp): random command lines against the
# contract for SECONDS seconds (default 600) from a fresh seed. CI runs the same test for 20 s from seed 1.
# Usage: tests/fuzz/long_fuzz.sh [BUILD_DIR] [SECONDS] [SEED]
set -euo pipefail
build=${1:-build}
seconds=${2:-600}
seed=${3:-$(od -An -N4 -tu4 /dev/urandom | tr -d ' ')}
binary="$build/tests/eci_cli_tests"
[ -x "$binary" ] || { echo "long_fuzz.sh: $binary not built (cmake --build $build --target eci_cli_tests)" >&2; exit 2; }
echo "long_fuzz.sh: seed $seed, $seconds s"
ECI_FUZZ_SECONDS=$seconds ECI_FUZZ_SEED=$seed "$binary" --gtest_filter='fuzz.*'
