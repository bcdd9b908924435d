#!/usr/bin/env bash
# Quasi-random walks against random ones on the homogeneous box (exact answer
# 1 - 2^-(D+1) for walks truncated at D bounces): the field's relative L1 error of
# `raybundle solve --builtin homogeneous-box --method M --depth 5 --iterations 1000
# --gather 0 --sampler S [--no-diffuse-shot] --seed k`, k = 1..SEEDS, for every walk
# method, sampler and diffuse-shot setting: the mean, the sample standard deviation, and
# the ratio of each sampler's mean to random's, and the mean of the run's own estimate of
# that error (from its two chains' disagreement). The command line's own path: two chains
# of 500 walks each (their difference is the run's error estimate), the default
# backend and map; one thread (the results are the same for any count, and one thread
# leaves the other core to the tests beside it). Writes CSV to standard output
# (docs/benchmarks.md, "Quasi-random walks").
# Usage: bench/run_qmc.sh [RAYBUNDLE] [SEEDS]   (default build/apps/raybundle, 5 seeds)
set -euo pipefail
cd "$(dirname "$0")/.."
raybundle=${1:-$PWD/build/apps/raybundle}
seeds=${2:-5}
[ -x "$raybundle" ] || { echo "run_qmc: $raybundle missing (build first)" >&2; exit 1; }
work=$(mktemp -d "${TMPDIR:-/tmp}/raybundle-qmc.XXXXXX")
trap 'rm -rf "$work"' EXIT

echo "method,diffuse_shot,sampler,seeds,mean_error,sd_error,ratio_to_random,mean_estimated_error"
for method in walk combined bidirectional; do
  for shot in --diffuse-shot --no-diffuse-shot; do
    random_mean=
    for sampler in random halton sobol; do
      for seed in $(seq 1 "$seeds"); do
        "$raybundle" solve --builtin homogeneous-box --method "$method" --depth 5 --iterations 1000 --gather 0 \
          --sampler "$sampler" "$shot" --seed "$seed" --threads 1 -q -o "$work/x.pfm" --stats "$work/s.json"
        python3 -c "import json,sys; d = json.load(open(sys.argv[1]))
print(d['relative_l1_error'], d['estimate']['field_estimated_error'])" "$work/s.json"
      done > "$work/errors"
      read -r mean sd estimate < <(awk '{s += $1; q += $1 * $1; e += $2} END {m = s / NR; v = NR > 1 ? (q - NR * m * m) / (NR - 1) : 0;
                                         printf "%.5f %.5f %.5f\n", m, sqrt(v > 0 ? v : 0), e / NR}' "$work/errors")
      [ "$sampler" = random ] && random_mean=$mean
      ratio=$(awk -v a="$mean" -v b="$random_mean" 'BEGIN {printf "%.3f", a / b}')
      echo "$method,${shot#--},$sampler,$seeds,$mean,$sd,$ratio,$estimate"
    done
  done
done
