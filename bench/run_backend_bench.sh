#!/usr/bin/env bash
# Seconds per global direction for every visibility backend, versus patch count (the
# Cornell box refined, and the fractal terrain) at 512^2, and versus resolution on the
# default Cornell box. Writes docs/bench-backends-patches.csv and
# docs/bench-backends-resolution.csv; docs/make-plots.sh draws them.
# Usage: bench/run_backend_bench.sh [build-dir]
set -euo pipefail
cd "$(dirname "$0")/.."
bench=${1:-build}/bench/bench_visibility
backends=$("${1:-build}"/apps/raybundle backends | awk '{print $1}')
header="backend,scene,patches,resolution,directions,repeat,seconds_per_direction,seconds_median,ratio_to_first,entries_per_direction,batch,threads"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# Directions per measurement: enough for a stable mean, few for the slow backends.
directions() {
  case $1 in
    exact-painter|painter) echo 50 ;; global-zbuffer) echo 10 ;; zbuffer) echo 5 ;; raycast) echo 3 ;; *) echo 1 ;;
  esac
}

echo "$header" > docs/bench-backends-patches.csv
for b in $backends; do
  "$bench" --backend "$b" --scene cornell-box --patch-size 100 53 25 12.5 9 --resolution 512 \
    --directions "$(directions "$b")" --csv "$tmp/c.csv" > /dev/null
  tail -n +2 "$tmp/c.csv" >> docs/bench-backends-patches.csv
  "$bench" --backend "$b" --scene fractal-terrain --patch-size 1000 500 250 125 100 --resolution 512 \
    --directions "$(directions "$b")" --csv "$tmp/t.csv" > /dev/null
  tail -n +2 "$tmp/t.csv" >> docs/bench-backends-patches.csv
done

echo "$header" > docs/bench-backends-resolution.csv
for b in $backends; do
  [ "$b" = arrangement ] && continue  # continuous: no resolution
  "$bench" --backend "$b" --scene cornell-box --resolution 128 256 512 1024 2048 \
    --directions "$(directions "$b")" --csv "$tmp/r.csv" > /dev/null
  tail -n +2 "$tmp/r.csv" >> docs/bench-backends-resolution.csv
done
column -s, -t docs/bench-backends-patches.csv docs/bench-backends-resolution.csv
