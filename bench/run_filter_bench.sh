#!/usr/bin/env bash
# Regenerates docs/filter-bench.csv: milliseconds per filtering of a 1024×768 RGB image
# by our guided filter (1-, 3- and 4-channel guides, radius 8, 24, 32), OpenCV's
# cv::ximgproc::guidedFilter (1- and 3-channel guides; only when the build found OpenCV:
# run scripts/setup-deps.sh --tests before configuring), our cross bilateral filter and
# our À-Trous filter, at 1 and 2 threads. Every configuration runs `runs` times,
# interleaved with the others, and the CSV keeps the fastest run and the median.
# Usage: bench/run_filter_bench.sh [build-dir] [runs]
set -euo pipefail
cd "$(dirname "$0")/.."
bench=${1:-build}/bench/bench_filters
runs=${2:-9}
"$bench" --repetitions "$runs" --radius 8 24 32 --threads 1 2 --bilateral-radius 8 16 \
  --atrous-iterations 4 5 6 > docs/filter-bench.csv.partial
mv docs/filter-bench.csv.partial docs/filter-bench.csv
{ echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')"; cat docs/filter-bench.csv; } >&2
