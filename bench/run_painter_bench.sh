#!/usr/bin/env bash
# Regenerates the painter's benchmark tables in docs/: every configuration is run ten
# times, interleaved, and the fastest run is kept (the least disturbed by the other
# tenants of a shared machine); the median is kept beside it.
# Usage: bench/run_painter_bench.sh [build-dir]
set -euo pipefail
cd "$(dirname "$0")/.."
bench=${1:-build}/bench/bench_visibility
runs=10
summarise() {  # stdin: lines "config ms entries"; prints config,min,median,entries
  sort -k1,1 -k2n | awk '{k=$1; v[k]=v[k]" "$2; e[k]=$3; n[k]++}
    END {for (k in v) {split(v[k], s, " "); printf "%s,%s,%s,%s\n", k, s[1], s[int((n[k]+1)/2)], e[k]}}' | sort -t, -k1n
}
{
  echo "resolution,ms_min,ms_median,entries_per_direction"
  for k in $(seq $runs); do
    for r in 128 256 512 1024 2048; do
      "$bench" --resolution "$r" --directions 200 | tail -1 | awk -v r="$r" '{print r, $5, $6}'
    done
  done | summarise
} > docs/bench-painter-resolution.csv
{
  echo "patches,ms_min,ms_median,entries_per_direction"
  for k in $(seq $runs); do
    for ps in 100 53 25 12.5 9; do
      "$bench" --patch-size "$ps" --resolution 512 --directions 50 | tail -1 | awk '{print $3, $5, $6}'
    done
  done | summarise
} > docs/bench-painter-patches.csv
cat docs/bench-painter-resolution.csv docs/bench-painter-patches.csv
