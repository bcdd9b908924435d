#!/usr/bin/env bash
# Refinement driven by the solution against the automatic size and a uniform size, at
# equal time (docs/final-image.md §16): for each setting and seed, the patches and the
# image's errors against a reference (relative L1, 4x4-block L1, worst 16x16 block).
#
# Usage: bench/run_refine_bench.sh --reference REF.exr [--budget S] [--seeds N]
#            [--growth G] [--uniform L] -- SCENE_ARGS... [SOLVE_FLAGS...]
#   e.g. bench/run_refine_bench.sh --reference ref.exr --uniform 0.14 -- \
#          scenes/examples/contact.json --width 128 --height 128
# The reference: the same scene and size, e.g. --method pathtrace --spp 8192 --seed 11
# (its own noise is what two such references with different seeds differ by, / sqrt 2).
# Defaults: --budget 16, --seeds 3, --growth 0.25, no uniform row. Prints one line per
# setting and seed. Uses build/apps/raybundle (scripts/build.sh first).
set -euo pipefail
cd "$(dirname "$0")/.."
reference="" budget=16 seeds=3 growth=0.25 uniform=""
while [ $# -gt 0 ]; do
  case "$1" in
    --reference) reference=$2; shift 2 ;;
    --budget) budget=$2; shift 2 ;;
    --seeds) seeds=$2; shift 2 ;;
    --growth) growth=$2; shift 2 ;;
    --uniform) uniform=$2; shift 2 ;;
    --) shift; break ;;
    *) echo "run_refine_bench: unknown option '$1' (see the header)" >&2; exit 2 ;;
  esac
done
[ -n "$reference" ] || { echo "run_refine_bench: give --reference REF.exr" >&2; exit 2; }
[ $# -gt 0 ] || { echo "run_refine_bench: give the scene and flags after --" >&2; exit 2; }
raybundle=build/apps/raybundle
[ -x "$raybundle" ] || { echo "run_refine_bench: $raybundle missing (build first)" >&2; exit 1; }
work=$(mktemp -d "${TMPDIR:-/tmp}/raybundle-refine.XXXXXX")
trap 'rm -rf "$work"' EXIT
value() { grep -o "\"$1\": [0-9.eE+-]*" "$2" | head -1 | awk '{print $2}'; }
settings=("" "--refine $growth")
[ -n "$uniform" ] && settings+=("--patch-size $uniform")
echo "budget ${budget}s, $(nproc) cores, $(date -u +%Y-%m-%d)"
for setting in "${settings[@]}"; do
  for seed in $(seq 1 "$seeds"); do
    # shellcheck disable=SC2086  # the setting is two words
    "$raybundle" solve "$@" $setting --time-budget "$budget" --seed "$seed" --reference "$reference" \
      -o "$work/image.exr" --stats "$work/s.json" -q 2>/dev/null
    ref=$(grep -A6 '"reference"' "$work/s.json")
    printf '%-22s seed %d  patches %7s  seconds %6.2f  L1 %.4f  4x4 %.4f  worst16 %+.4f\n' \
      "${setting:-(defaults)}" "$seed" "$(value patches "$work/s.json")" "$(value seconds_total "$work/s.json")" \
      "$(echo "$ref" | grep -o '"relative_l1": [0-9.eE+-]*' | awk '{print $2}')" \
      "$(echo "$ref" | grep -o '"block4_relative_l1": [0-9.eE+-]*' | awk '{print $2}')" \
      "$(echo "$ref" | grep -o '"worst_block16": [0-9.eE+-]*' | awk '{print $2}')"
  done
done
