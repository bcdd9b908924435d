#!/usr/bin/env bash
# Installs raybundle's build dependencies from Debian 12 packages (apt-get only).
# Idempotent: packages already present are not touched, and apt-get runs only
# when something is missing.
# Usage: scripts/setup-deps.sh [--tests] [--fuzz]
#   --tests   also the packages only the tests and benchmarks use: OpenCV with its
#             contrib modules (the guided filter is compared with
#             cv::ximgproc::guidedFilter), GSL (our VEGAS tables are compared
#             with gsl_monte_vegas), Open MPI (the tests run the solver on
#             two ranks with mpirun) and Python 3 (tests/cli/test_mpi.sh reads the
#             stats and CSVs with it); and the Khronos glTF validator (npm's
#             gltf-validator, in .deps/node; Node.js from Debian where the machine has
#             no npm) that tests/cli/test_glb.sh runs. scripts/test.sh passes it.
#   --fuzz    also clang and its libFuzzer runtime (scripts/fuzz.sh passes it).
set -euo pipefail

packages=(
  build-essential cmake ninja-build ccache pkg-config
  libopenmesh-dev libcgal-dev libgmp-dev libmpfr-dev libboost-dev
  libeigen3-dev libglm-dev libosmesa6-dev
  catch2 libembree-dev libopenexr-dev libpng-dev libjpeg-dev zlib1g-dev
  nlohmann-json3-dev libcli11-dev libtbb-dev libtinygltf-dev
)
test_packages=(libopencv-dev libopencv-contrib-dev libgsl-dev libopenmpi-dev openmpi-bin python3)
fuzz_packages=(clang libclang-rt-dev)

tests=0
for arg in "$@"; do
  case "$arg" in
    --tests) packages+=("${test_packages[@]}"); tests=1 ;;
    --fuzz) packages+=("${fuzz_packages[@]}") ;;
    *) echo "setup-deps: unknown option '$arg' (known: --tests, --fuzz)" >&2; exit 2 ;;
  esac
done

# Node.js may come from elsewhere (NodeSource's nodejs has npm inside): Debian's
# packages only where there is no npm at all.
if [ "$tests" -eq 1 ] && ! command -v npm >/dev/null; then packages+=(nodejs npm); fi

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup-deps: all ${#packages[@]} packages present"
else
  echo "setup-deps: installing ${missing[*]}"
  sudo_cmd=()
  if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi
  export DEBIAN_FRONTEND=noninteractive
  "${sudo_cmd[@]}" apt-get update -qq
  "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

# The glTF validator, pinned, beside the sources (not system-wide).
validator_version=2.0.0-dev.3.10
if [ "$tests" -eq 1 ]; then
  root=$(cd "$(dirname "$0")/.." && pwd)
  installed=$(node -p "require('$root/.deps/node/node_modules/gltf-validator/package.json').version" 2>/dev/null || true)
  if [ "$installed" != "$validator_version" ]; then
    echo "setup-deps: installing gltf-validator $validator_version (npm) in .deps/node"
    mkdir -p "$root/.deps/node"
    npm install --prefix "$root/.deps/node" --no-audit --no-fund --no-save --loglevel=error \
      "gltf-validator@$validator_version"
  fi
fi
