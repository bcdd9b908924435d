#!/usr/bin/env bash
# What every part of the command-line tests shares (sourced by tests/cli/test_cli_*.sh):
# the raybundle under test and the source tree from the arguments, a scratch directory
# removed at exit, the counters, expect_bad, and the small scenes the parts read.
# Usage of a part: test_cli_PART.sh PATH/TO/raybundle SOURCE_DIR
set -uo pipefail
bin=$1
src=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work" || exit 1
passed=0
failed=0
skipped=0
fail() { echo "FAIL: $*"; failed=$((failed + 1)); }
skip() { echo "SKIP: $*"; skipped=$((skipped + 1)); }
# check STATUS MESSAGE: count a check (STATUS first: it is expanded before any $(...)
# in the message runs).
check() { if [ "$1" -eq 0 ]; then passed=$((passed + 1)); else fail "$2"; fi; }

camera='"camera": {"eye": [0.5, 0.5, 3], "target": [0.5, 0.5, 0], "width": 32, "height": 32}'
materials='"materials": {"w": {"albedo": [0.5, 0.5, 0.5], "emission": [1, 1, 1]}}'
quad='{"quad": [[0,0,0], [1,0,0], [1,1,0], [0,1,0]], "material": "w"}'
scene() { printf '{%s, %s, "objects": [%s]%s}\n' "$camera" "$materials" "$1" "${2:-}"; }

# expect_bad NAME EXPECTED_TEXT ARGS... : exit 2, one stderr line containing the text,
# and the sentinel output untouched, no other output created.
expect_bad() {
  local name=$1 text=$2
  shift 2
  rm -rf outdir && mkdir outdir
  echo "previous" > outdir/img.exr
  "$bin" "$@" -o outdir/img.exr -o outdir/img.png --stats outdir/s.json --csv outdir/c.csv \
    --patches outdir/p.csv --ply outdir/p.ply >out.txt 2>err.txt
  local rc=$?
  local lines
  lines=$(wc -l <err.txt)
  if [ "$rc" -ne 2 ]; then fail "$name: exit code $rc, expected 2 ($(cat err.txt))"; return; fi
  if [ "$lines" -ne 1 ]; then fail "$name: $lines lines on stderr: $(cat err.txt)"; return; fi
  if ! grep -qF -- "$text" err.txt; then fail "$name: stderr lacks '$text': $(cat err.txt)"; return; fi
  if [ "$(cat outdir/img.exr)" != "previous" ]; then fail "$name: output file was touched"; return; fi
  if [ "$(ls outdir | wc -l)" -ne 1 ]; then fail "$name: outputs created: $(ls outdir)"; return; fi
  passed=$((passed + 1))
}

scene "$quad" > good.json
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n' > range.obj
printf 'v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n' > nan.obj
printf 'OFF\n4 2 0\n0 0 0\n1 0 0\n' > short.off
scene '{"mesh": "range.obj", "material": "w"}' > range.json
scene '{"mesh": "nan.obj", "material": "w"}' > nan.json
scene '{"mesh": "short.off", "material": "w"}' > short.json
printf '{\n  "camera": {\n    "eye": [0, 0,, 1]\n' > malformed.json
scene "$quad" ', "patchsize": 1' > unknown-key.json
scene '{"quad": [[0,0,0], [1,0,0], [1,1,0], [0,1,0]], "material": "red"}' > unknown-material.json
printf '{%s, "materials": {"w": {"albedo": [0.6, 0.5, 0.5], "specular": [0.4, 0.1, 0.1], "exponent": 10}}, "objects": [%s]}\n' "$camera" "$quad" > albedo.json
printf '{%s, "materials": {"w": {"albedo": [0.4, 0.4, 0.4], "specular": [0.4, 0.1, 0.1], "exponent": 10}}, "objects": [%s]}\n' "$camera" "$quad" > albedo-ok.json
printf '{%s, "materials": {"w": {"albedo": [0.5, 0.5, 0.5], "emission": [0, -2, 0]}}, "objects": [%s]}\n' "$camera" "$quad" > emission.json
printf '{"camera": {"eye": [0.5, 0.5, 3], "target": [0.5, 0.5, 0], "fov_y": 200}, %s, "objects": [%s]}\n' "$materials" "$quad" > fov.json
scene "$quad" ', "patch_size": 0' > patch-size.json
scene "" > empty.json

# The first number a key has in a JSON file.
json_number() { grep -o "\"$1\": [0-9.e+-]*" "$2" | head -1 | awk '{print $2}'; }

# finish NAME: the counts, and the exit status of the part.
finish() {
  echo "$1: $passed passed, $failed failed, $skipped skipped"
  [ "$failed" -eq 0 ]
}
