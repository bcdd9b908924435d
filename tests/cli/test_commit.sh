#!/usr/bin/env bash
# The outputs of a run are a set (render/output_set.h, apps/signals.h): signals aimed
# at every point of its commit, through a preloaded rename()/unlink()
# (tests/cli/commit_shim.cpp), never leave it part old, part new.
#
# A run writes 12 outputs over an old set (each file holding "old"). Its commit has
# 14 points: 1 the journal made, 2..13 the renames, 14 the journal removed. At each
# of them, in turn:
# - SIGINT (the run stops cleanly; it was complete): exit 130, every output new;
# - SIGINT twice, SIGTERM twice (abandon the run): the commit under way completes,
#   then the process ends by the signal (130, 143): every output new;
# - SIGKILL: exit 137; the next run writing in that folder completes the commit
#   (from point 2 on: every output new) or drops it (point 1: every output old).
# Every time, no temporary or journal is left after the run (after the next run for
# SIGKILL).
# Usage: test_commit.sh PATH/TO/raybundle PATH/TO/commit_shim.so
set -uo pipefail
bin=$1
shim=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work" || exit 1
passed=0
failed=0
fail() { echo "FAIL: $*"; failed=$((failed + 1)); }

run=(solve --builtin cornell-box --width 16 --height 16 --iterations 20 -q)
outputs=(-o d/img.exr -o d/img.png --stats d/s.json --csv d/c.csv --patches d/p.csv --ply d/p.ply --aov d/aov)
files=(d/img.exr d/img.png d/s.json d/c.csv d/p.csv d/p.ply
       d/aov/depth.exr d/aov/direct.exr d/aov/indirect.exr d/aov/indirect-filtered.exr d/aov/bias.exr d/aov/normal.exr)
points=14

reset() {
  rm -rf d && mkdir -p d/aov
  for f in "${files[@]}"; do echo old >"$f"; done
}
# "old", "new" or "mixed (...)": the set's state.
state() {
  local olds=0 f
  for f in "${files[@]}"; do [ "$(head -c 3 "$f" 2>/dev/null)" = old ] && olds=$((olds + 1)); done
  if [ "$olds" -eq ${#files[@]} ]; then echo old
  elif [ "$olds" -eq 0 ]; then echo new
  else echo "mixed ($olds of ${#files[@]} old)"; fi
}
leftovers() { find d -name '.raybundle-*' | tr '\n' ' '; }

# The shim takes effect (a run aimed at point 13 with SIGINT twice ends by it) and the
# set is new without it.
reset
"$bin" "${run[@]}" "${outputs[@]}" || fail "the run without signals failed"
[ "$(state)" = new ] || fail "the run without signals: $(state)"

aim() {  # aim POINT SIGNALS: runs with the shim; prints the exit code
  reset
  LD_PRELOAD=$shim RAYBUNDLE_SHIM_AT=$1 RAYBUNDLE_SHIM_SIGNALS=$2 ASAN_OPTIONS="${ASAN_OPTIONS:-}:verify_asan_link_order=0" \
    "$bin" "${run[@]}" "${outputs[@]}" 2>err.txt
  echo $?
}
for point in $(seq 1 $points); do
  for aimed in "2:130" "2,2:130" "15,15:143"; do
    signals=${aimed%%:*} expected=${aimed##*:}
    rc=$(aim "$point" "$signals")
    what="signals $signals at point $point"
    if [ "$rc" -ne "$expected" ]; then fail "$what: exit $rc, expected $expected: $(cat err.txt)"
    elif [ "$(state)" != new ]; then fail "$what: the outputs are $(state)"
    elif [ -n "$(leftovers)" ]; then fail "$what: left $(leftovers)"
    else passed=$((passed + 1)); fi
  done
  rc=$(aim "$point" 9)
  what="SIGKILL at point $point"
  expected=new
  [ "$point" -eq 1 ] && expected=old
  "$bin" "${run[@]}" -o d/other.png 2>next.txt || fail "$what: the next run failed: $(cat next.txt)"
  if [ "$rc" -ne 137 ]; then fail "$what: exit $rc, expected 137: $(cat err.txt)"
  elif [ "$(state)" != "$expected" ]; then fail "$what: after the next run the outputs are $(state), expected $expected"
  elif [ -n "$(leftovers)" ]; then fail "$what: the next run left $(leftovers)"
  else passed=$((passed + 1)); fi
done

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
