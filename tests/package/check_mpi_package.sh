#!/usr/bin/env bash
# An MPI build's eci::spectral as an installed package: installs the MPI build BUILD_DIR (ECI_MPI=ON) into a
# temporary prefix, then builds and runs the spectral consumer through find_package(eci COMPONENTS spectral), which
# must find MPI and FFTW's MPI library for it (cmake/eci-config.cmake.in).
set -euo pipefail
src=$(cd "$(dirname "$0")/../.." && pwd)
build=$(realpath "$1")
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
grep -q '^ECI_MPI:BOOL=ON' "$build/CMakeCache.txt" || { echo "$build is not an MPI build (ECI_MPI=ON)" >&2; exit 1; }
cmake --install "$build" --prefix "$work/prefix" >/dev/null
grep -q 'fftw3_mpi' "$work/prefix/share/cmake/eci/eci-config.cmake"
cmake -S "$src/tests/package/spectral_consumer" -B "$work/consumer" -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_PREFIX_PATH="$work/prefix" >/dev/null
cmake --build "$work/consumer" >/dev/null
"$work/consumer/consumer"
