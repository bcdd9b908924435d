#!/usr/bin/env bash
# One raybundle setting over several seeds: the mean of the estimated error, of the
# true error against a reference image, and of the seconds. A single run's error is a
# poor guide where a few large patterns of noise make it up (light through a door),
# so settings are compared by these means (docs/final-image.md).
#
# Usage: bench/run_seeds.sh [--seeds N] [--reference REF.exr] -- SCENE_ARGS... [SOLVE_FLAGS...]
#   e.g. bench/run_seeds.sh --seeds 3 --reference bench/reference/doorway.exr -- \
#          scenes/examples/doorway.json -D camera.width=256 -D camera.height=256 --time-budget 8
# Prints one line: "seeds N  estimated E  true T  seconds S" (true: "-" without a
# reference). Uses build/apps/raybundle (scripts/build.sh first).
set -euo pipefail
cd "$(dirname "$0")/.."
seeds=3 reference=""
while [ $# -gt 0 ]; do
  case "$1" in
    --seeds) seeds=$2; shift 2 ;;
    --reference) reference=$2; shift 2 ;;
    --) shift; break ;;
    *) echo "run_seeds: unknown option '$1' (see the header)" >&2; exit 2 ;;
  esac
done
[ $# -gt 0 ] || { echo "run_seeds: give the scene and flags after --" >&2; exit 2; }
raybundle=build/apps/raybundle
[ -x "$raybundle" ] || { echo "run_seeds: $raybundle missing (build first)" >&2; exit 1; }
work=$(mktemp -d "${TMPDIR:-/tmp}/raybundle-seeds.XXXXXX")
trap 'rm -rf "$work"' EXIT
number() { grep -o "\"$1\": [0-9.eE+-]*" "$2" | head -1 | awk '{print $2}'; }
for seed in $(seq 1 "$seeds"); do
  "$raybundle" solve "$@" --seed "$seed" -q --stats "$work/s.json" ${reference:+--reference "$reference"}
  # The reference block's relative_l1 is the image's error against the reference.
  truth=-
  [ -n "$reference" ] && truth=$(grep -A3 '"reference"' "$work/s.json" | grep -o '"relative_l1": [0-9.eE+-]*' | awk '{print $2}')
  echo "$(number image_estimated_error "$work/s.json") $truth $(number seconds_total "$work/s.json")" >>"$work/rows"
done
awk -v n="$seeds" '{ e += $1; if ($2 != "-") t += $2; else no = 1; s += $3 }
  END { printf "seeds %d  estimated %.4f  true %s  seconds %.2f\n", n, e / n, no ? "-" : sprintf("%.4f", t / n), s / n }' "$work/rows"
