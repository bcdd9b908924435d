#!/usr/bin/env bash
# The light-behind-a-partition scene of docs/importance-sampling.md (issue 12): at
# equal directions (1,000 plain walks of D = 3, 12 seeds averaged), Metropolis's image
# error is below random walks' and below Sobol walks'. The issue's 2x target is not
# met and not asserted; the doc has the measurements. The reference is 40,000 random
# walks (its own error, about 0.19 of a 1,000-walk run's 0.86, adds in quadrature to
# every sampler's alike).
# Usage: test_partition.sh RAYBUNDLE SOURCE_DIR
set -euo pipefail
bin=$1 root=$2
work=$(mktemp -d "${TMPDIR:-/tmp}/raybundle-partition.XXXXXX")
trap 'rm -rf "$work"' EXIT
common=(solve "$root/bench/scenes/partition.json" --method walk --depth 3 --gather 0 --threads 2 -q)
"$bin" "${common[@]}" --iterations 40000 --seed 4242 -o "$work/ref.exr" >/dev/null
for sampler in random sobol metropolis; do
  for seed in $(seq 1 12); do
    "$bin" "${common[@]}" --sampler "$sampler" --iterations 1000 --seed "$seed" --reference "$work/ref.exr" \
      --stats "$work/$sampler-$seed.json" >/dev/null
  done
done
python3 - "$work" <<'PY'
import json, statistics, sys
work = sys.argv[1]
mean = {}
for sampler in ("random", "sobol", "metropolis"):
    errors = [json.load(open(f"{work}/{sampler}-{seed}.json"))["reference"]["relative_l1"] for seed in range(1, 13)]
    mean[sampler] = statistics.mean(errors)
    print(f"{sampler}: {mean[sampler]:.3f} +- {statistics.stdev(errors) / len(errors) ** 0.5:.3f}")
ok = mean["metropolis"] < mean["random"] and mean["metropolis"] < mean["sobol"]
print("metropolis below random and sobol:", "yes" if ok else "NO")
sys.exit(0 if ok else 1)
PY
