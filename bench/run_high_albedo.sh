#!/usr/bin/env bash
# The issue's high-albedo box (bench/scenes/high-albedo-box.json: a closed unit box,
# albedo 0.99, 0.95, 0.9 and emission 0.01, 0.05, 0.1, radiance 1 everywhere; 1,536
# patches) solved by three estimators at a ladder of steps, on 2 threads: the defaults
# (above sqrt(3)/2 they choose the ambient control variate and frames of three
# directions), the variate with one direction per step (--no-frame), and the paper's
# estimator as it is (--no-ambient --no-frame). Per run: the solve's seconds, the
# area-weighted mean's error per channel and the worst patch's, from --patches.
# Usage: bench/run_high_albedo.sh [OUT.csv]   (default docs/bench-high-albedo.csv;
# build/apps/raybundle, scripts/build.sh first)
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-docs/bench-high-albedo.csv}
raybundle=build/apps/raybundle
[ -x "$raybundle" ] || { echo "run_high_albedo: $raybundle missing (build first)" >&2; exit 1; }
work=$(mktemp -d "${TMPDIR:-/tmp}/raybundle-albedo.XXXXXX")
trap 'rm -rf "$work"' EXIT
echo "estimator,steps,directions,seconds_solve,error_r,error_g,error_b,worst_patch" >"$out"
for estimator in defaults variate-one-direction paper; do
  case $estimator in
    defaults) flags=() ;;
    variate-one-direction) flags=(--ambient --no-frame) ;;
    paper) flags=(--no-ambient --no-frame) ;;
  esac
  for steps in 30 100 300 1000 3000 10000 30000; do
    "$raybundle" solve bench/scenes/high-albedo-box.json --gather 0 --iterations "$steps" --threads 2 --seed 1 \
      "${flags[@]}" --patches "$work/p.csv" --stats "$work/s.json" -q
    seconds=$(grep -o '"seconds_solve": [0-9.eE+-]*' "$work/s.json" | awk '{print $2}')
    directions=$(grep -o '"directions": [0-9]*' "$work/s.json" | head -1 | awk '{print $2}')
    awk -F, -v e="$estimator" -v n="$steps" -v d="$directions" -v t="$seconds" '
      NR > 1 { for (k = 0; k < 3; ++k) { s[k] += $8 * $(9 + k); x = $(9 + k) - 1; if (x < 0) x = -x; if (x > w) w = x }
               A += $8 }
      END { printf "%s,%s,%s,%s,%.6f,%.6f,%.6f,%.5f\n", e, n, d, t, s[0] / A - 1, s[1] / A - 1, s[2] / A - 1, w }' \
      "$work/p.csv" | tee -a "$out"
  done
done
