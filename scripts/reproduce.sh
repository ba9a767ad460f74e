#!/usr/bin/env bash
# The main job: build eci and reproduce the paper's experiments (all nine figures and their key numbers).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
# Sets only what it needs: the tests stay configured (scripts/test.sh shares build/), only the tool is built.
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j2 --target eci_cli
./build/eci figures --out figures "$@"
