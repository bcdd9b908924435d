#!/usr/bin/env bash
# Configures and builds raybundle (Release, Ninja) into ./build. Extra arguments go to
# the configure step (e.g. -DRAYBUNDLE_REQUIRE_OPENCV=ON).
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=${RAYBUNDLE_JOBS:-2}
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release "$@"
cmake --build build -j "$jobs"
