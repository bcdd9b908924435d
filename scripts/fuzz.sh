#!/usr/bin/env bash
# Fuzzing: builds the libFuzzer harnesses of tests/fuzz with clang, ASan and UBSan (in
# build-fuzz/; clang and libFuzzer installed by scripts/setup-deps.sh --fuzz) and runs
# each for SECONDS, two at a time. Limits per input: 1 GB of memory (-rss_limit_mb,
# the process's resident memory, and -malloc_limit_mb) and 10 s (-timeout); inputs up
# to 64 KiB (checkpoints 320 KiB). Each corpus grows in build-fuzz/corpus/NAME, seeded from
# tests/fuzz/corpus/NAME; findings (crash-*, leak-*, timeout-*, oom-*) are written to
# build-fuzz/findings/NAME/. Prints a line per harness and writes them to
# build-fuzz/fuzz-report.md; exits 1 on any finding.
# Usage: scripts/fuzz.sh [SECONDS] [HARNESS ...]   (default: 600 s; scene obj
#        ply-ascii ply-binary off checkpoint mtl gltf glb)
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-600}
shift || true
harnesses=("$@")
[ ${#harnesses[@]} -gt 0 ] || harnesses=(scene obj ply-ascii ply-binary off checkpoint mtl gltf glb)
jobs=${RAYBUNDLE_JOBS:-2}

./scripts/setup-deps.sh --fuzz
cmake -S . -B build-fuzz -G Ninja -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DRAYBUNDLE_FUZZ=ON -DRAYBUNDLE_BUILD_TESTS=OFF -DRAYBUNDLE_BUILD_BENCH=OFF >/dev/null
targets=()
for h in "${harnesses[@]}"; do targets+=("fuzz_${h//-/_}"); done
cmake --build build-fuzz -j "$jobs" --target "${targets[@]}"

# ASan's quarantine kept small, so that the 1 GB limit measures the inputs, not it.
export ASAN_OPTIONS="quarantine_size_mb=64:detect_leaks=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
run() {
  local h=$1 name=fuzz_${1//-/_} start=$SECONDS max_len=65536
  # A Metropolis walk's checkpoint (a seed of its own) is 270 KB.
  [ "$h" = checkpoint ] && max_len=327680
  mkdir -p "build-fuzz/corpus/$h" "build-fuzz/findings/$h"
  "build-fuzz/tests/fuzz/$name" -max_total_time="$seconds" -rss_limit_mb=1024 -malloc_limit_mb=1024 \
    -timeout=10 -max_len="$max_len" -print_final_stats=1 -artifact_prefix="build-fuzz/findings/$h/" \
    "build-fuzz/corpus/$h" "tests/fuzz/corpus/$h" >"build-fuzz/fuzz-$h.log" 2>&1 || true
  echo $((SECONDS - start)) >"build-fuzz/fuzz-$h.seconds"
}
active=0
for h in "${harnesses[@]}"; do
  run "$h" &
  active=$((active + 1))
  if [ "$active" -ge "$jobs" ]; then
    wait -n
    active=$((active - 1))
  fi
done
wait

found=0
{
  echo "| harness | seconds | runs | exec/s | coverage (edges) | corpus | peak RSS | slowest input | findings |"
  echo "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"
  for h in "${harnesses[@]}"; do
    log="build-fuzz/fuzz-$h.log"
    stat() { grep "^stat::$1:" "$log" | tail -1 | awk '{print $NF}'; }
    runs=$(stat number_of_executed_units)
    speed=$(stat average_exec_per_sec)
    rss=$(stat peak_rss_mb)
    slowest=$(stat slowest_unit_time_sec)
    cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | awk '{print $2}')
    corpus=$(ls "build-fuzz/corpus/$h" | wc -l)
    findings=$(ls "build-fuzz/findings/$h" | wc -l)
    [ "$findings" -eq 0 ] && grep -q 'ERROR: \|SUMMARY: ' "$log" && findings="see log"
    [ "$findings" = "0" ] || found=1
    echo "| $h | $(cat "build-fuzz/fuzz-$h.seconds") | ${runs:-?} | ${speed:-?} | ${cov:-?} | $corpus | ${rss:-?} MB | ${slowest:-?} s | $findings |"
  done
} | tee build-fuzz/fuzz-report.md
[ "$found" -eq 0 ] || { echo "fuzz: findings in build-fuzz/findings/ (logs: build-fuzz/fuzz-*.log)" >&2; exit 1; }
