#!/usr/bin/env bash
# The convergence figure of 004 Fig. 6-7 on the homogeneous box (exact radiance 1, or
# 1 - 2^-(D+1) for walks truncated at D bounces): relative L1 error against walks
# (or steps) and against seconds, for every method and sampler, each the mean over
# four seeds. Writes docs/convergence.csv; docs/make-plots.sh draws the PNGs.
# Usage: bench/run_convergence.sh [build-dir]
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${1:-build}/apps/raybundle
D=5
walks=1000
steps=$((walks * D))  # the same number of visibility transfers
seeds="1 2 3 4"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

run() {  # name sampler count every extra-args...
  local name=$1 sampler=$2 count=$3 every=$4
  shift 4
  for s in $seeds; do
    "$bin" solve --builtin homogeneous-box --iterations "$count" --csv-every "$every" --seed "$s" \
      -o "$tmp/x.exr" --csv "$tmp/$name-$sampler-$s.csv" "$@" 2>/dev/null
  done
  # Mean over seeds of seconds and error, per row.
  awk -F, -v name="$name" -v sampler="$sampler" 'FNR > 1 {
      t[$1] += $2; e[$1] += $3; n[$1]++ }
    END { for (k in t) printf "%s,%s,%d,%.6g,%.6g\n", name, sampler, k, t[k] / n[k], e[k] / n[k] }' \
    "$tmp/$name-$sampler-"*.csv | sort -t, -k3n
}

{
  echo "method,sampler,count,seconds,relative_l1_error"
  run iteration random "$steps" 50 --method iteration
  run iteration-w-only random "$steps" 50 --method iteration --one-way
  for m in walk combined bidirectional; do
    for smp in random halton sobol; do
      run "$m" "$smp" "$walks" 10 --method "$m" --depth "$D" --sampler "$smp"
    done
  done
  run bidirectional-unbiased random "$walks" 10 --method bidirectional --depth "$D" --unbiased
} > docs/convergence.csv
echo "wrote docs/convergence.csv ($(($(wc -l < docs/convergence.csv) - 1)) rows)"
