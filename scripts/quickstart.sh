#!/usr/bin/env bash
# Command 1 of the README: install the dependencies, build, and solve the built-in
# Cornell box with the default settings (stochastic iteration, the diffuse shot chosen
# for the scene, the final gather with the guided filter), writing out/cornell.{exr,png},
# out/cornell.ply (the patch radiance) and out/cornell-{stats.json,convergence.csv}.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup-deps.sh
bash scripts/build.sh
./build/apps/raybundle solve --builtin cornell-box \
  -o out/cornell.exr -o out/cornell.png --exposure 1 --ply out/cornell.ply \
  --stats out/cornell-stats.json --csv out/cornell-convergence.csv
