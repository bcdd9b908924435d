#!/usr/bin/env bash
# Command 2 of the README: install the dependencies, build, and run every test.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup-deps.sh --tests
# The tests compare the guided filter with OpenCV's and VEGAS with GSL's, and run two
# MPI ranks: a build without OpenCV, GSL or MPI must fail here.
bash scripts/build.sh -DRAYBUNDLE_REQUIRE_OPENCV=ON -DRAYBUNDLE_REQUIRE_GSL=ON -DRAYBUNDLE_REQUIRE_MPI=ON
ctest --test-dir build --output-on-failure -j "${RAYBUNDLE_JOBS:-2}"
