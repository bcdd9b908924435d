#!/usr/bin/env bash
# Command 2 of the README: install the dependencies, build, and run every test.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup-deps.sh
bash scripts/build.sh
ctest --test-dir build --output-on-failure -j "${RAYBUNDLE_JOBS:-2}"
