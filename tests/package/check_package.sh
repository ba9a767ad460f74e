#!/usr/bin/env bash
# Installs eci into a temporary prefix, then builds and runs two consumers with their own default flags: one
# through find_package(eci CONFIG REQUIRED), one through FetchContent from this checkout. Also checks that C-PC's
# finishing pass was vectorized without -fno-math-errno from the consumer (packed square roots in the binary).
set -euo pipefail
src=$(cd "$(dirname "$0")/../.." && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
generator=()
command -v ninja >/dev/null 2>&1 && generator=(-G Ninja)

# The library alone, installed without a build (the Python module needs one: tests/python/test_install.py; the
# compiled eci::spectral is checked below).
cmake -S "$src" -B "$work/eci" "${generator[@]}" -DECI_BUILD_TESTS=OFF -DECI_BUILD_APPS=OFF -DECI_BUILD_PYTHON=OFF \
      -DECI_BUILD_EXAMPLES=OFF -DECI_BUILD_SPECTRAL=OFF -DCMAKE_INSTALL_PREFIX="$work/prefix" >/dev/null
cmake --install "$work/eci" >/dev/null
test -f "$work/prefix/include/eci/version.hpp"
test -f "$work/prefix/share/cmake/eci/eci-config-version.cmake"

for consumer in find_package subdirectory; do
  cmake -S "$src/tests/package/${consumer}_consumer" -B "$work/$consumer" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release \
        -DCMAKE_PREFIX_PATH="$work/prefix" -DECI_SOURCE_DIR="$src" --no-warn-unused-cli >/dev/null
  cmake --build "$work/$consumer" >/dev/null
  "$work/$consumer/consumer"
done

# Without eci::spectral installed, asking for it must fail.
mkdir -p "$work/no_spectral"
cat >"$work/no_spectral/CMakeLists.txt" <<'CMAKE'
cmake_minimum_required(VERSION 3.25)
project(no_spectral LANGUAGES CXX)
find_package(eci CONFIG REQUIRED COMPONENTS spectral)
CMAKE
if cmake -S "$work/no_spectral" -B "$work/no_spectral/build" -DCMAKE_PREFIX_PATH="$work/prefix" >/dev/null 2>&1; then
  echo "find_package(eci COMPONENTS spectral) was accepted without eci::spectral installed" >&2
  exit 1
fi

# eci::spectral (FFTW3): built, installed into its own prefix, found as a component by a consumer that runs it.
if pkg-config --exists fftw3 2>/dev/null; then
  cmake -S "$src" -B "$work/eci-spectral" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release -DECI_BUILD_TESTS=OFF \
        -DECI_BUILD_APPS=OFF -DECI_BUILD_PYTHON=OFF -DECI_BUILD_EXAMPLES=OFF -DECI_BUILD_SPECTRAL=ON \
        -DCMAKE_INSTALL_PREFIX="$work/prefix-spectral" >/dev/null
  cmake --build "$work/eci-spectral" --target eci_spectral >/dev/null
  cmake --install "$work/eci-spectral" >/dev/null
  cmake -S "$src/tests/package/spectral_consumer" -B "$work/spectral" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release \
        -DCMAKE_PREFIX_PATH="$work/prefix-spectral" >/dev/null
  cmake --build "$work/spectral" >/dev/null
  "$work/spectral/consumer"
  # the build tree itself as eci_DIR, no install (eci-targets.cmake and the others exported beside its config)
  cmake -S "$src/tests/package/spectral_consumer" -B "$work/spectral-build-tree" "${generator[@]}" \
        -DCMAKE_BUILD_TYPE=Release -Deci_DIR="$work/eci-spectral" >/dev/null
  cmake --build "$work/spectral-build-tree" >/dev/null
  "$work/spectral-build-tree/consumer"
fi

# The header-only library's build tree as eci_DIR.
cmake -S "$src/tests/package/find_package_consumer" -B "$work/build-tree" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release \
      -Deci_DIR="$work/eci" --no-warn-unused-cli >/dev/null
cmake --build "$work/build-tree" >/dev/null
"$work/build-tree/consumer"

# A consumer that asks for an incompatible version must be refused.
mkdir -p "$work/too_new"
cat >"$work/too_new/CMakeLists.txt" <<'CMAKE'
cmake_minimum_required(VERSION 3.25)
project(too_new LANGUAGES CXX)
find_package(eci 99 CONFIG REQUIRED)
CMAKE
if cmake -S "$work/too_new" -B "$work/too_new/build" -DCMAKE_PREFIX_PATH="$work/prefix" >/dev/null 2>&1; then
  echo "find_package(eci 99) was accepted" >&2
  exit 1
fi

if [ "$(uname -m)" = x86_64 ] && command -v objdump >/dev/null 2>&1 && "${CXX:-c++}" --version | grep -qi 'free software foundation'; then
  packed=$(objdump -d --no-show-raw-insn "$work/find_package/consumer" | grep -c 'sqrtpd' || true)
  [ "$packed" -gt 0 ] || { echo "C-PC's finishing pass was not vectorized in the consumer (no sqrtpd)" >&2; exit 1; }
  echo "packed square roots in the consumer: $packed"
fi
