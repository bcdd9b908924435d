#!/usr/bin/env bash
# The exact painter (the default backend) against the centre-sorted painter and the
# global z-buffer: ms per global direction versus patch count (the Cornell box refined,
# 512^2) and versus map resolution (the default Cornell box), one thread. The backends
# are measured in one run, interleaved (bench_visibility --repeat), and each row keeps
# the fastest of the rounds beside the median. First the reference point of the target
# (the default Cornell box at 512^2) with 25 rounds, pinned to one core when taskset
# exists. Writes docs/bench-exact-reference.csv, docs/bench-exact-patches.csv and
# docs/bench-exact-resolution.csv, then prints the growth exponents (least-squares
# slopes in log-log).
# Usage: bench/run_exact_bench.sh [build-dir] [rounds]
set -euo pipefail
cd "$(dirname "$0")/.."
bench=${1:-build}/bench/bench_visibility
rounds=${2:-7}
backends=(exact-painter painter global-zbuffer)
pin=()
command -v taskset >/dev/null && pin=(taskset -c 0)

"${pin[@]}" "$bench" --backend exact-painter painter --scene cornell-box --resolution 512 --directions 100 \
  --repeat 25 --csv docs/bench-exact-reference.csv

"${pin[@]}" "$bench" --backend "${backends[@]}" --scene cornell-box --patch-size 100 53 30 17 9.5 --resolution 512 \
  --directions 40 --repeat "$rounds" --csv docs/bench-exact-patches.csv
"${pin[@]}" "$bench" --backend "${backends[@]}" --scene cornell-box --resolution 128 256 512 1024 2048 \
  --directions 40 --repeat "$rounds" --csv docs/bench-exact-resolution.csv

# Slope of log(ms) against log(x) per backend; x is column $2 of the input.
slopes() {
  awk -F, '{ n[$1]++; lx = log($2); ly = log($3); sx[$1] += lx; sy[$1] += ly; sxx[$1] += lx * lx; sxy[$1] += lx * ly }
    END { for (b in n) printf "  %-15s %.2f\n", b, (n[b] * sxy[b] - sx[b] * sy[b]) / (n[b] * sxx[b] - sx[b] * sx[b]) }' | sort
}
echo "growth exponent with patch count (512^2):"
tail -n +2 docs/bench-exact-patches.csv | awk -F, '{print $1 "," $3 "," $7}' | slopes
echo "growth exponent with pixels (resolution^2):"
tail -n +2 docs/bench-exact-resolution.csv | awk -F, '{print $1 "," $4 * $4 "," $7}' | slopes
