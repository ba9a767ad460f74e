#!/usr/bin/env bash
# Installs the Debian packages eci builds, tests and draws with, where they are missing (a fresh Debian 12 as root).
set -euo pipefail

packages=(g++ cmake make pkg-config libboost-dev libcli11-dev libgtest-dev libbenchmark-dev gnuplot-nox libfftw3-dev libhdf5-dev)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
# bench/run.sh's report is a small standard-library Python script; any python3 on PATH will do.
command -v python3 >/dev/null 2>&1 || missing+=(python3)
[ ${#missing[@]} -eq 0 ] && exit 0

echo "eci setup: installing ${missing[*]}" >&2
if [ "$(id -u)" -ne 0 ]; then
  echo "eci setup: these Debian packages are missing and installing them needs root: ${missing[*]}" >&2
  exit 1
fi
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
