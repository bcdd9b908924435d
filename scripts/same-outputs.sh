#!/usr/bin/env bash
# Whether two builds of raybundle write the same outputs for the same commands: for a
# refactoring that must not change a result. Runs a set of solves (every built-in
# scene, the examples, every method and sampler family, the patch image and the final
# gather (both direct-light methods), rounds to a target error, the path
# tracer on the box and on glossy and point-lit scenes, a checkpoint resumed) with each
# program and compares every file they write byte for byte: images, per-patch CSV and
# PLY; the stats and the convergence CSV without their timings (keys and columns of
# seconds); the summary line without its seconds.
# Usage: scripts/same-outputs.sh OLD_RAYBUNDLE NEW_RAYBUNDLE   (exit 0: all the same)
set -euo pipefail
[ $# -eq 2 ] || { echo "usage: scripts/same-outputs.sh OLD_RAYBUNDLE NEW_RAYBUNDLE" >&2; exit 2; }
root=$(cd "$(dirname "$0")/.." && pwd)
old=$(realpath "$1") new=$(realpath "$2")
work=$(mktemp -d "${TMPDIR:-/tmp}/raybundle-same.XXXXXX")
trap 'rm -rf "$work"' EXIT
examples=$root/scenes/examples

run_all() {  # BIN DIR
  local bin=$1 dir=$2
  run() {
    local name=$1
    shift
    mkdir -p "$dir/$name"
    (cd "$dir/$name" && { "$bin" solve "$@" -q -o img.exr -o img.png --stats stats.json --csv conv.csv \
      --patches p.csv --ply p.ply >out.txt 2>err.txt; echo "exit $?" >>out.txt; })
  }
  run box --builtin cornell-box --width 64 --height 64 --iterations 200
  run box-cut --builtin cornell-box-cut --width 48 --height 48 --iterations 100 --gather 0
  run homogeneous --builtin homogeneous-box --width 32 --height 32 --iterations 300 --gather 0
  run sobol --builtin homogeneous-box --width 32 --height 32 --method bidirectional --depth 4 --iterations 100 \
    --sampler sobol
  run metropolis --builtin cornell-box --width 32 --height 32 --method walk --depth 3 --iterations 120 \
    --sampler metropolis --gather 0
  run vegas --builtin cornell-box --width 32 --height 32 --method combined --depth 3 --iterations 150 \
    --sampler vegas --gather 0
  run linear --builtin cornell-box --width 48 --height 48 --iterations 200 --basis linear --gather 0
  run terrain --builtin fractal-terrain --width 48 --height 32 --iterations 100 --gather 8 --spp 2
  run glossy "$examples/cornell-glossy.json" --width 48 --height 48 --iterations 100 --gather 8 --spp 2
  run doorway "$examples/doorway.json" --width 48 --height 48 --iterations 100 --gather 8 --spp 2
  run sampled "$examples/cornell-glossy.json" --width 32 --height 32 --iterations 100 --gather 8 --spp 2 \
    --direct sampled
  run minimal "$examples/minimal.json" --width 32 --height 32 --iterations 100 --gather 8 --spp 2
  run window "$examples/window.json" --width 32 --height 32 --iterations 100 --gather 8
  run target --builtin cornell-box --width 32 --height 32 --target-error 0.05 --gather 8 --spp 2
  trace() {  # NAME SCENE ARGS...: the path tracer (no field: no patch outputs)
    local name=$1
    shift
    mkdir -p "$dir/$name"
    (cd "$dir/$name" && { "$bin" solve "$@" --method pathtrace -q -o img.exr --stats stats.json --csv conv.csv \
      >out.txt 2>err.txt; echo "exit $?" >>out.txt; })
  }
  trace pathtrace --builtin cornell-box --width 32 --height 32 --spp 16
  trace pathtrace-glossy "$examples/cornell-glossy.json" --width 24 --height 24 --spp 8
  trace pathtrace-minimal "$examples/minimal.json" --width 24 --height 24 --spp 8
  mkdir -p "$dir/resume"
  (cd "$dir/resume" && {
    "$bin" solve --builtin cornell-box --width 32 --height 32 --iterations 200 --checkpoint c.ckpt \
      --checkpoint-every 100 -q -o first.exr >/dev/null 2>&1
    "$bin" solve --builtin cornell-box --width 32 --height 32 --iterations 200 --resume c.ckpt -q -o img.exr \
      --stats stats.json >out.txt 2>err.txt; echo "exit $?" >>out.txt
    rm -f c.ckpt; })  # the checkpoint holds its seconds
}

run_all "$old" "$work/old"
run_all "$new" "$work/new"
python3 - "$work/old" "$work/new" <<'PY'
import json, os, re, sys, filecmp
old, new = sys.argv[1], sys.argv[2]
def timeless(o):
    if isinstance(o, dict):
        return {k: timeless(v) for k, v in o.items() if "second" not in k}
    if isinstance(o, list):
        return [timeless(v) for v in o]
    return o
def same(a, b, name):
    if name.endswith(".json"):
        return timeless(json.load(open(a))) == timeless(json.load(open(b)))
    if name == "conv.csv":  # column 2 is seconds
        cut = lambda f: [l.split(",")[:1] + l.split(",")[2:] for l in open(f)]
        return cut(a) == cut(b)
    if name == "out.txt":
        cut = lambda f: [re.sub(r"[0-9.]+ s\b", "# s", l) for l in open(f)]
        return cut(a) == cut(b)
    return filecmp.cmp(a, b, shallow=False)
files = differ = 0
for top, _, names in os.walk(old):
    for name in names:
        a = os.path.join(top, name)
        b = os.path.join(new, os.path.relpath(a, old))
        files += 1
        if not os.path.exists(b) or not same(a, b, name):
            differ += 1
            print("differs:", os.path.relpath(a, old))
print(f"same-outputs: {files} files compared, {differ} differ")
sys.exit(1 if differ else 0)
PY
