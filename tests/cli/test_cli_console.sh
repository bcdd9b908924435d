#!/usr/bin/env bash
# What a run shows and how it spreads: threads default to all cores and any count
# gives the same result; the progress bar on a narrow terminal; --quiet; the
# summary line.
# Usage: test_cli_console.sh PATH/TO/raybundle SOURCE_DIR
# shellcheck source=tests/cli/cli_common.sh
source "$(dirname "${BASH_SOURCE[0]}")/cli_common.sh"

# Threads default to all cores, and any count gives the same result.
"$bin" solve --builtin homogeneous-box --width 32 --height 32 --patch-size 0.34 --iterations 50 --stats t.json --patches tall.csv >/dev/null 2>&1
grep -q "\"threads_requested\": $(nproc)," t.json
check $? "threads default is not $(nproc): $(grep threads_requested t.json)"
"$bin" solve --builtin homogeneous-box --width 32 --height 32 --patch-size 0.34 --iterations 50 --threads 1 --patches t1.csv >/dev/null 2>&1 &&
  "$bin" solve --builtin homogeneous-box --width 32 --height 32 --patch-size 0.34 --iterations 50 --threads 3 --patches t3.csv >/dev/null 2>&1 &&
  cmp -s t1.csv t3.csv && cmp -s t1.csv tall.csv
check $? "--threads 1 and 3 differ"

# The progress bar on a 50-column terminal: every phase, elapsed and remaining time,
# no line of 50 characters or more; then one summary line. --quiet: nothing at all.
if command -v script >/dev/null; then
  script -qc "stty cols 50 2>/dev/null; '$bin' solve --builtin cornell-box --patch-size 60 --iterations 2000 --diffuse-shot \
    --gather 4 --width 64 --height 64 -o bar.exr 2>&1 >/dev/null" /dev/null | tr '\r' '\n' | sed 's/[[:space:]]*$//' \
    | grep -v '^$' > bar.txt
  ok=0
  for phase in "diffuse shot" solve "final gather" filter; do grep -q "^$phase " bar.txt || { fail "progress bar lacks $phase"; ok=1; }; done
  grep -q "s left" bar.txt || { fail "progress bar lacks the time left"; ok=1; }
  long=$(awk 'length($0) >= 50' bar.txt | wc -l)
  [ "$long" -eq 0 ] || { fail "progress bar wider than 49 columns: $(awk 'length($0) >= 50' bar.txt | head -1)"; ok=1; }
  check $ok "progress bar"
  # A scene file's preparation and check: each step and its seconds, then the line cleared.
  script -qc "stty cols 50 2>/dev/null; '$bin' check '$src/scenes/examples/minimal.json' 2>&1 >/dev/null" /dev/null \
    | tr '\r' '\n' | sed 's/[[:space:]]*$//' | grep -v '^$' > prep.txt
  ok=0
  for step in reading normals refining contacts check; do
    grep -Eq "^scene: $step  [0-9]+\.[0-9] s$" prep.txt || { fail "preparation lacks its step $step: $(tr '\n' '|' <prep.txt)"; ok=1; }
  done
  check $ok "preparation progress"
else
  skip "progress bar: no script(1) to give the run a terminal (Debian: bsdutils)"
fi
script -qc "'$bin' solve --builtin cornell-box --patch-size 100 --iterations 200 --width 32 --height 32 --quiet -o q.exr" /dev/null > q.txt 2>&1
check $(( $(wc -c <q.txt) != 0 )) "--quiet printed: $(head -c 200 q.txt)"
"$bin" solve --builtin cornell-box --width 32 --height 32 --patch-size 100 --iterations 20 -o s.exr >sum.txt 2>/dev/null
[ "$(wc -l <sum.txt)" -eq 1 ] && grep -q "cornell-box: .* patches, iteration 20 steps in .*; wrote s.exr" sum.txt
check $? "summary line: $(cat sum.txt)"

finish cli-console
