#!/usr/bin/env bash
# The textured asset against Blender Cycles (docs/bench-assets-textured.md):
# scenes/examples/gltf/textured-room.glb at 128 x 128 from its own camera, one thread
# per timed image. ASSET=painted-room: the vertex-coloured asset instead
# (scenes/examples/gltf/painted-room.glb, docs/bench-assets-painted.md; it has no OBJ
# version: those rows are left out).
#
# Cycles renders the file as Blender imports it (bench/cycles/import_obj.py) twice at
# REF_SPP samples, seeds 2 and 3: reference A, and reference B, whose difference from A
# is the references' own noise. The two references render side by side, one thread
# each; every timed image after them renders alone. Then Cycles at a ladder of sample
# counts (seed 1), raybundle at its defaults and at each --time-budget of BUDGETS, its
# path tracer (PT_SPP samples, 2 threads), the OBJ + MTL + PNG version at raybundle's
# defaults, and that OBJ with its texture coordinates removed (every texture read as
# its mean colour, as before raybundle read texels). The OBJ images are compared with
# reference A too: Blender imports the OBJ and the glTF file to the same image.
#
# Per image: seconds (the whole command), and against reference A relative L1, the
# relative L1 of 4x4-pixel block means, the worst 16x16 block (build/bench/image_error)
# and the image's mean. Prints the table in Markdown and writes it to OUT.md.
#
# Usage: [ASSET=textured-room|painted-room] [REF_SPP=8192] [PT_SPP=2048] [CYCLES_SPP="64 256 1024"]
#        [BUDGETS="20 60"] bench/run_textured_bench.sh [OUT.md]
# (default: a table file in a temporary folder, printed; build/ first: scripts/build.sh;
# Blender and python3-numpy: bench/run_asset_bench.sh installs them).
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-}
REF_SPP=${REF_SPP:-8192}
PT_SPP=${PT_SPP:-2048}
read -r -a CYCLES_SPP <<<"${CYCLES_SPP:-64 256 1024}"
read -r -a BUDGETS <<<"${BUDGETS:-20 60}"
ASSET=${ASSET:-textured-room}
glb=scenes/examples/gltf/$ASSET.glb
obj=scenes/examples/textured-room/textured-room.obj
# The asset's camera node (raybundle reads it from the file; Cycles is given it).
case $ASSET in
  textured-room) view=(--eye -0.3 1.45 1.9 --target 0.2 0.8 -1.0 --fov-y 70 --size 128) ;;
  painted-room) view=(--eye 0 1.3 1.9 --target 0 0.45 -0.5 --fov-y 60 --size 128) ;;
  *) echo "run_textured_bench: ASSET=$ASSET: textured-room or painted-room" >&2; exit 2 ;;
esac
raybundle=build/apps/raybundle
for f in "$raybundle" build/bench/image_error; do
  [ -x "$f" ] || { echo "run_textured_bench: $f missing (scripts/build.sh first)" >&2; exit 1; }
done
command -v blender >/dev/null || { echo "run_textured_bench: blender missing (bench/run_asset_bench.sh installs it)" >&2; exit 1; }
work=$(mktemp -d "${TMPDIR:-/tmp}/raybundle-textured.XXXXXX")
trap 'rm -rf "$work"' EXIT
[ -n "$out" ] || out=$work/table.md

cycles() {  # cycles SEED SPP OUT.exr: prints the seconds
  local start
  start=$(date +%s.%N)
  blender -b --factory-startup -t 1 --python-exit-code 1 --python bench/cycles/import_obj.py -- --obj "$glb" \
    --output "$3" --spp "$2" "${view[@]}" -t 1 --seed "$1" >"$work/cycles-$1-$2.log" 2>&1 ||
    { cat "$work/cycles-$1-$2.log" >&2; return 1; }
  awk -v a="$start" -v b="$(date +%s.%N)" 'BEGIN { printf "%.1f", b - a }'
}
timed() {  # timed OUT.exr COMMAND...: runs it, prints the seconds
  local img=$1 start
  shift
  start=$(date +%s.%N)
  "$@" -q -o "$img"
  awk -v a="$start" -v b="$(date +%s.%N)" 'BEGIN { printf "%.1f", b - a }'
}
row() {  # row NAME SECONDS IMAGE
  build/bench/image_error "$3" "$ref_a" | awk -v name="$1" -v t="$2" '{ v[$1] = $2 } END {
    printf "| %s | %s | %.2f | %.2f | %+.2f | %.5f |\n", name, t, 100 * v["relative_l1"], 100 * v["block4_l1"],
           100 * v["worst_block16"], v["mean"] }'
}

ref_a=$work/ref-a.exr ref_b=$work/ref-b.exr
cycles 2 "$REF_SPP" "$ref_a" >"$work/seconds-a" &
job_a=$!
cycles 3 "$REF_SPP" "$ref_b" >"$work/seconds-b" &
job_b=$!
wait "$job_a"
wait "$job_b"

# The OBJ with its vt lines removed: its faces keep their vertices (f v/vt -> f v).
means=$work/means
mkdir -p "$means"
cp scenes/examples/textured-room/*.mtl scenes/examples/textured-room/*.png "$means/"
sed -e '/^vt /d' -e 's#\([0-9][0-9]*\)/[0-9]*/\([0-9][0-9]*\)#\1//\2#g' -e 's#\([0-9][0-9]*\)/[0-9][0-9]*\( \|$\)#\1\2#g' \
  "$obj" >"$means/textured-room.obj"
obj_camera=(-D "camera.eye=[-0.3,1.45,1.9]" -D "camera.target=[0.2,0.8,-1.0]" -D camera.fov_y=70)

{
  echo "| image | seconds | relative L1 (%) | 4x4 block L1 (%) | worst 16x16 block (%) | image mean |"
  echo "| --- | --- | --- | --- | --- | --- |"
  echo "| Cycles reference A ($REF_SPP spp, seed 2; side by side with B) | $(cat "$work/seconds-a") | 0 | 0 | 0 | $(build/bench/image_error "$ref_a" "$ref_a" | awk '$1 == "mean" { printf "%.5f", $2 }') |"
  row "Cycles reference B ($REF_SPP spp, seed 3: the references' noise)" "$(cat "$work/seconds-b")" "$ref_b"
  for spp in "${CYCLES_SPP[@]}"; do
    t=$(cycles 1 "$spp" "$work/cycles-$spp.exr")
    row "Cycles $spp spp" "$t" "$work/cycles-$spp.exr"
  done
  t=$(timed "$work/rb.exr" "$raybundle" solve "$glb" --width 128 --height 128 --threads 1)
  row "raybundle, defaults" "$t" "$work/rb.exr"
  for budget in "${BUDGETS[@]}"; do
    t=$(timed "$work/rb-$budget.exr" "$raybundle" solve "$glb" --width 128 --height 128 --threads 1 --time-budget $budget)
    row "raybundle --time-budget $budget" "$t" "$work/rb-$budget.exr"
  done
  t=$(timed "$work/pt.exr" "$raybundle" solve "$glb" --width 128 --height 128 --threads 2 --method pathtrace --spp "$PT_SPP")
  row "raybundle path tracer, $PT_SPP spp (2 threads)" "$t" "$work/pt.exr"
  if [ "$ASSET" = textured-room ]; then
    t=$(timed "$work/obj.exr" "$raybundle" solve "$obj" "${obj_camera[@]}" --width 128 --height 128 --threads 1)
    row "the OBJ version, defaults" "$t" "$work/obj.exr"
    t=$(timed "$work/means.exr" "$raybundle" solve "$means/textured-room.obj" "${obj_camera[@]}" --width 128 \
          --height 128 --threads 1 2>/dev/null)
    row "textures read as their mean colour (the OBJ without its \`vt\`)" "$t" "$work/means.exr"
  fi
} | tee "$out"
