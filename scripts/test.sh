#!/usr/bin/env bash
# Builds everything with warnings as errors and runs the whole test suite (ctest, then the Python module's pytest),
# then the C++ tests once more under AddressSanitizer + UndefinedBehaviorSanitizer, and keeps the benchmarks
# compiling (one token iteration each).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
jobs=2
# ccache: the Python module's objects of the Release build are hits when tests/python/test_pip_install.py builds
# the module again through `pip install .` (6 CPU-minutes cold); paths are hashed relative to the checkout.
export CCACHE_BASEDIR="$PWD"
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
# Ninja for the build trees this script creates (a tree that exists keeps its generator): it schedules the two jobs
# over all targets at once (the sanitizer pass's build: 9.0 against 9.8 minutes with Make), and the pip build of
# tests/python/test_pip_install.py, configured under the same variable, runs its compiles from the same relative
# directory as build/, which ccache needs to give back build/'s objects.
command -v ninja >/dev/null && export CMAKE_GENERATOR=${CMAKE_GENERATOR:-Ninja}
# Each phase says when it starts (minutes:seconds since the script began): where CI's time goes.
phase() { printf '== [%d:%02d] %s\n' $((SECONDS / 60)) $((SECONDS % 60)) "$1"; }

phase "Release build, -Werror"
# Every option the suite needs is set here, not taken from a cache another script configured.
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DECI_WERROR=ON -DECI_BUILD_PYTHON=ON -DECI_BUILD_TESTS=ON \
      -DECI_BUILD_APPS=ON -DECI_BUILD_EXAMPLES=ON -DECI_SANITIZE=OFF "${launcher[@]}" >/dev/null
cmake --build build -j$jobs
ctest --test-dir build --output-on-failure --no-tests=error -j$jobs

phase "Python module: pytest (tests/python, against build/python and build/eci)"
# The interpreter the module was built for (Debian's /usr/bin/python3, not a pyenv python3 earlier on PATH).
python=$(cat build/python/interpreter)
ECI_BUILD_DIR="$PWD/build" "$python" -m pytest -q -p no:cacheprovider tests/python

phase "MPI: the spectral core and eci run spread over 1-3 processes (build-mpi, ECI_MPI=ON, label mpi)"
# Only the MPI targets: the library, the CLI, the MPI test binary and example; their tests (mpirun --oversubscribe,
# as root in CI) compare with the serial runs of the same binaries.
cmake -S . -B build-mpi -DCMAKE_BUILD_TYPE=Release -DECI_WERROR=ON -DECI_MPI=ON -DECI_BUILD_PYTHON=OFF \
      -DECI_BUILD_TESTS=ON -DECI_BUILD_APPS=ON -DECI_BUILD_EXAMPLES=ON -DECI_SANITIZE=OFF "${launcher[@]}" >/dev/null
cmake --build build-mpi -j$jobs --target eci_cli eci_mpi_tests example_spectral_mpi
OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 \
  ctest --test-dir build-mpi --output-on-failure --no-tests=error -L mpi

phase "AddressSanitizer + UndefinedBehaviorSanitizer"
# The library's unit tests and the CLI's tests (the tool itself, every model and output path, under the
# sanitizers); the numeric tests (the same engines on long runs), the spectral model (FFTW's own threads), the
# package consumers and the Python module are covered by the Release pass above: building them a second time
# would double the suite's time. Instrumented targets compile at -Og -g1 (the unit tests -O0) without -Werror
# (CMakeLists.txt, ECI_SANITIZE; GCC's flow warnings differ under the instrumentation, the Release pass holds them).
# The models' compiled runs (src/models) are not instrumented: the tree is configured with the Release tree's type
# and options, so ccache gives back the Release build's objects of them (1030 of the pass's 2230 CPU-seconds when
# they were compiled instrumented); their engines are instrumented in the unit tests' own instantiations.
cmake -S . -B build-sanitize -DCMAKE_BUILD_TYPE=Release -DECI_WERROR=ON -DECI_SANITIZE=ON -DECI_BUILD_TESTS=ON \
      -DECI_BUILD_APPS=ON "${launcher[@]}" >/dev/null
cmake --build build-sanitize -j$jobs --target eci_unit_tests eci_cli_tests eci_cli
ctest --test-dir build-sanitize --output-on-failure --no-tests=error -j$jobs -L 'unit|cli'

if [ -x bench/run.sh ]; then
  phase "Benchmarks: build and one token iteration each"
  bench/run.sh --smoke --apps-from build  # the CLI and the module of the Release build above
fi
phase "done"
