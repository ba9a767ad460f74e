#!/usr/bin/env bash
# Installs the Debian packages eci builds, tests and draws with, where they are missing (a fresh Debian 12 as root);
# the Python module is built for Debian's /usr/bin/python3, where python3-numpy and the others live; setuptools,
# wheel, pip, venv and build are for `pip install .` and `python3 -m build` (offline, --no-build-isolation);
# ninja-build is the generator of scripts/test.sh's build trees; python3-pyfftw is the competitor of
# bench/ns2d_pyfftw.py (bench/run.sh --ns2d); ccache lets the test suite's `pip install .` reuse the module's objects
# from the suite's own build, and its MPI build the CLI's ODE models. openmpi-bin, libopenmpi-dev,
# libfftw3-mpi-dev and libhdf5-openmpi-dev (parallel HDF5: every process writes its block of a snapshot or checkpoint
# at once, through MPI-IO) are for the MPI build (-DECI_MPI=ON, build-mpi in scripts/test.sh); a build without MPI
# needs none of them and keeps the serial HDF5 (libhdf5-dev, also h5py's). The two HDF5s install side by side; the
# parallel one takes over Debian's plain hdf5.pc alternative, so the builds ask pkg-config for hdf5-serial and
# hdf5-openmpi by name (cmake/hdf5.cmake).
set -euo pipefail

packages=(g++ cmake make ninja-build libboost-dev libcli11-dev libgtest-dev libbenchmark-dev gnuplot-nox
          python3 python3-dev pybind11-dev python3-pybind11 python3-numpy python3-scipy python3-pytest
          python3-matplotlib pkg-config libfftw3-dev libhdf5-dev python3-h5py python3-pyfftw
          python3-setuptools python3-wheel python3-pip python3-venv python3-build ccache
          openmpi-bin libopenmpi-dev libfftw3-mpi-dev libhdf5-openmpi-dev)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0

echo "eci setup: installing ${missing[*]}" >&2
if [ "$(id -u)" -ne 0 ]; then
  echo "eci setup: these Debian packages are missing and installing them needs root: ${missing[*]}" >&2
  exit 1
fi
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
