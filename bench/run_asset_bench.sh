#!/usr/bin/env bash
# An asset as it comes (by default scenes/examples/CornellBox-Original.obj with its
# MTL; MODEL= a glTF file) against Blender Cycles importing the same files
# (bench/cycles/import_obj.py): does raybundle read the asset as Blender does, and how
# near is its image?
#
# Both render 256 x 256 from the same camera, written out here: for the OBJ the one
# raybundle frames it with, for a glTF file its own (EYE, TARGET, FOV: the asset's
# camera node, see docs/bench-assets-gltf.md). Cycles renders the reference twice,
# REF_SPP samples each with seeds 2 and 3: the two references' difference is their own
# noise, and no claim is made below three times it. raybundle runs each budget of
# BUDGETS (the whole command timed). For each image against reference A: relative L1,
# MSE, the relative L1 of 4x4-pixel block means and the worst 16x16 block
# (build/bench/image_error). Writes docs/bench-assets.md (OUT_NAME=).
#
# Usage: [REF_SPP=8192] [BUDGET_SECONDS="8 32 128"] [MODEL=F EYE="x y z" TARGET="x y z" FOV=deg OUT_NAME=F.md]
#        bench/run_asset_bench.sh [--threads N] [--no-build] [--out DIR]
# Installs blender and python3-numpy with apt-get when missing (sudo when not root).
set -euo pipefail
cd "$(dirname "$0")/.."

MODEL=${MODEL:-scenes/examples/CornellBox-Original.obj}
# The framing raybundle's loader computes for the OBJ (scenes/loader.h: +z side, 40°).
read -r -a EYE <<<"${EYE:--0.01 0.995 3.76495}"
read -r -a TARGET <<<"${TARGET:--0.01 0.995 -0.025}"
FOV=${FOV:-40}
OUT_NAME=${OUT_NAME:-bench-assets.md}
SIZE=256
REF_SPP=${REF_SPP:-8192}
read -r -a BUDGET_SECONDS <<<"${BUDGET_SECONDS:-8 32 128}"
BUDGETS=()
for s in "${BUDGET_SECONDS[@]}"; do BUDGETS+=("--time-budget $s"); done

threads=2 build=1 out=docs
while [ $# -gt 0 ]; do
  case $1 in
    --threads) threads=$2; shift 2 ;;
    --no-build) build=0; shift ;;
    --out) out=$2; shift 2 ;;
    *) echo "usage: bench/run_asset_bench.sh [--threads N] [--no-build] [--out DIR]" >&2; exit 2 ;;
  esac
done
# Blender, and numpy for its glTF importer and exporter (Debian's blender does not
# depend on it).
if ! command -v blender >/dev/null || ! dpkg-query -W -f='${Status}' python3-numpy 2>/dev/null | grep -q "ok installed"; then
  if [ "$(id -u)" -eq 0 ]; then apt-get install -y --no-install-recommends blender python3-numpy
  else sudo apt-get install -y --no-install-recommends blender python3-numpy; fi
fi
[ "$build" -eq 1 ] && ./scripts/build.sh >/dev/null
mkdir -p "$out"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
vec() { echo "[$1,$2,$3]"; }
camera=(-D "camera.eye=$(vec "${EYE[@]}")" -D "camera.target=$(vec "${TARGET[@]}")" -D camera.width=$SIZE
        -D camera.height=$SIZE -D camera.fov_y=$FOV -D "camera.up=[0,1,0]")

cycles() {  # cycles SEED OUT.exr
  local start=$SECONDS
  blender -b --factory-startup --python-exit-code 1 --python bench/cycles/import_obj.py -- --obj "$MODEL" \
    --output "$2" --spp $REF_SPP --eye "${EYE[@]}" --target "${TARGET[@]}" --fov-y "$FOV" --size $SIZE -t "$threads" \
    --seed "$1" >"$work/cycles-$1.log" 2>&1 || { cat "$work/cycles-$1.log"; exit 1; }
  echo $((SECONDS - start))
}
error() { build/bench/image_error "$1" "$2" | awk '{ v[$1] = $2 } END {
  printf "%.4f | %.3g | %.4f | %+.3f", 100 * v["relative_l1"], v["mse"], 100 * v["block4_l1"], 100 * v["worst_block16"] }'; }

ref_a=$work/ref-a.exr ref_b=$work/ref-b.exr
seconds_a=$(cycles 2 "$ref_a")
seconds_b=$(cycles 3 "$ref_b")
{
  echo "# An asset against Blender Cycles: $(basename "$MODEL")"
  echo
  echo "\`REF_SPP=$REF_SPP BUDGET_SECONDS=\"${BUDGET_SECONDS[*]}\" bench/run_asset_bench.sh --threads $threads\` on $(nproc) cores ($(date -u +%Y-%m-%d)); $(blender -b \
--factory-startup --python-expr 'import bpy; print("BLENDER", bpy.app.version_string)' 2>/dev/null | awk '/^BLENDER/ { print "Blender " $2 }'); $(build/apps/raybundle --version | head -1)."
  echo
  echo "$MODEL as it is, ${SIZE}², camera eye $(vec "${EYE[@]}") target $(vec "${TARGET[@]}") (${FOV}°)."
  echo "Cycles imports the same files (bench/cycles/import_obj.py: Blender's OBJ or glTF importer, its colours"
  echo "kept, Lambert diffuse, one-sided emission). References: $REF_SPP spp, seeds 2 and 3 ($seconds_a s and $seconds_b s)."
  echo
  echo "| image | seconds | relative L1 (%) | MSE | 4x4 block L1 (%) | worst 16x16 block (%) |"
  echo "| --- | --- | --- | --- | --- | --- |"
  echo "| Cycles reference B (its noise) | $seconds_b | $(error "$ref_b" "$ref_a") |"
  for budget in "${BUDGETS[@]}"; do
    img=$work/rb.exr
    start=$(date +%s.%N)
    # shellcheck disable=SC2086
    build/apps/raybundle solve "$MODEL" "${camera[@]}" $budget --threads "$threads" -q -o "$img"
    secs=$(awk -v a="$start" -v b="$(date +%s.%N)" 'BEGIN { print b - a }')
    echo "| raybundle $budget | $(printf %.1f "$secs") | $(error "$img" "$ref_a") |"
  done
} >"$out/$OUT_NAME"
cat "$out/$OUT_NAME"
