#!/usr/bin/env bash
# Time against error: raybundle against Blender Cycles (CPU path tracing) on the same
# scenes, both measured against a high-sample Cycles reference (docs/bench-cycles.md).
#
# For every scene: export it as raybundle loads it (build/bench/export_scene), render
# the Cycles reference once (REF_SPP samples per pixel; kept in bench/reference/ and
# reused when present; its command and time are written beside it), then in one run
# with the same thread count: Cycles at each of CYCLES_SPP samples per pixel (the
# render call timed inside Blender) and raybundle with each argument set of
# RAYBUNDLE_BUDGETS (the whole command-line run timed), each image's relative L1 error,
# MSE, relative L1 of 4x4-pixel means and worst 16x16 block against the reference
# (build/bench/image_error), and raybundle's own estimate of its error (its stats'
# image_estimated_error). Every reference is rendered twice, with two seeds: the two
# differ by sqrt(2) times one's noise, so that pair gives the noise of the reference
# the errors are taken against (per pixel, over 4x4 blocks, the worst 16x16 block),
# and no time to an error below three times that noise is claimed (the table says
# "below 3x the reference's noise" instead). Writes docs/bench-cycles.csv,
# docs/bench-cycles.png and docs/bench-cycles.md.
#
# Usage: bench/run_cycles_bench.sh [--quick] [--threads N] [--no-build] [--out DIR]
#                                   [--references-only] [--only NAME,...]
#   --quick      a smoke test in minutes: 16 and 64 spp, the first two raybundle budgets,
#                a 256-spp reference, everything (references too) in a temporary
#                directory unless --out is given; docs/ and bench/reference/ untouched
#   --threads N  threads for both renderers, timed and reference runs (default 2)
#   --no-build   use the existing build/ (default: scripts/build.sh first)
#   --out DIR    where the CSV, plot, table and images go (default: docs/, and the
#                images in a temporary directory)
#   --references-only  render the missing references, then stop (they take long: start
#                them early, time the rest later on a quiet machine)
#   --only NAMES only these scenes of SCENES (comma-separated names)
# Installs blender and gnuplot-nox with apt-get when missing (sudo when not root).
set -euo pipefail
cd "$(dirname "$0")/.."

# --- what is measured (tune here) -------------------------------------------------
# The scenes: a name, then the scene arguments both renderers get (raybundle's CLI and
# export_scene take the same ones). 256 x 256 pixels for all.
SCENES=(
  "cornell-box|--builtin cornell-box -D camera.width=256 -D camera.height=256"
  "doorway|scenes/examples/doorway.json -D camera.width=256 -D camera.height=256"
  "window|scenes/examples/window.json -D camera.width=256 -D camera.height=256"
  "contact|scenes/examples/contact.json -D camera.width=256 -D camera.height=256"
)
# raybundle's budgets, cheapest first: `raybundle solve SCENE BUDGET --threads N`. Time
# budgets: the run sizes its rounds and shares the time between the solve and the
# final gather itself (render/progressive.h); the seconds measured are the whole run's.
RAYBUNDLE_BUDGETS=(
  "--time-budget 1"
  "--time-budget 2"
  "--time-budget 4"
  "--time-budget 8"
  "--time-budget 16"
  "--time-budget 32"
  "--time-budget 64"
)
# Cycles samples per pixel for the timed runs, and for the reference.
CYCLES_SPP=(16 64 256 1024 4096)
REF_SPP=16384
# The timed runs' seed, and the reference's: another seed, so that the reference does
# not share the timed Cycles runs' samples (with one seed, Cycles' progressive pattern
# makes an N-spp image the first N samples of the reference, and its error too small).
# The second reference, of its own seed, measures the first one's noise.
SEED=1
REF_SEED=2
REF_SEED_2=3
# ------------------------------------------------------------------------------------

command_line="bench/run_cycles_bench.sh${*:+ $*}"
threads=2 quick=0 build=1 out="" refs_only=0 only=""
while [ $# -gt 0 ]; do
  case "$1" in
    --quick) quick=1 ;;
    --threads) threads=$2; shift ;;
    --no-build) build=0 ;;
    --out) out=$2; shift ;;
    --references-only) refs_only=1 ;;
    --only) only=$2; shift ;;
    *) echo "run_cycles_bench: unknown option '$1'" >&2; exit 2 ;;
  esac
  shift
done
if [ -n "$only" ]; then
  kept=()
  for entry in "${SCENES[@]}"; do
    case ",$only," in *",${entry%%|*},"*) kept+=("$entry") ;; esac
  done
  [ ${#kept[@]} -gt 0 ] || { echo "run_cycles_bench: --only $only: no such scene" >&2; exit 2; }
  SCENES=("${kept[@]}")
fi
work=$(mktemp -d "${TMPDIR:-/tmp}/raybundle-cycles.XXXXXX")
refdir=bench/reference
if [ "$quick" = 1 ]; then
  CYCLES_SPP=(16 64)
  RAYBUNDLE_BUDGETS=("${RAYBUNDLE_BUDGETS[@]:0:2}")
  REF_SPP=256
  refdir=$work/reference
  out=${out:-$work}
fi
out=${out:-docs}
mkdir -p "$out" "$refdir" "$work/images"
echo "run_cycles_bench: images in $work/images, results in $out, references in $refdir"

# --- dependencies and build -------------------------------------------------------
missing=()
command -v blender >/dev/null || missing+=(blender)
command -v gnuplot >/dev/null || missing+=(gnuplot-nox)
if [ ${#missing[@]} -gt 0 ]; then
  sudo_cmd=(); [ "$(id -u)" -ne 0 ] && sudo_cmd=(sudo)
  export DEBIAN_FRONTEND=noninteractive
  "${sudo_cmd[@]}" apt-get update -qq
  "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
[ "$build" = 1 ] && bash scripts/build.sh
raybundle=build/apps/raybundle
export_scene=build/bench/export_scene
image_error=build/bench/image_error
for tool in "$raybundle" "$export_scene" "$image_error"; do
  [ -x "$tool" ] || { echo "run_cycles_bench: $tool missing (build first)" >&2; exit 1; }
done
blender_version=$(blender -b --factory-startup --python-expr 'import bpy; print("BLENDER", bpy.app.version_string)' 2>/dev/null |
  awk '$1 == "BLENDER" { print $2 }')

# Renders SCENE_JSON with Cycles: cycles_render JSON OUT.exr SPP SEED TIMING.json [--half]
cycles_render() {
  local json=$1 exr=$2 spp=$3 seed=$4 timing=$5
  shift 5
  blender -b --factory-startup --python-exit-code 1 --python bench/cycles/import_scene.py -- \
    --scene "$json" --output "$exr" --spp "$spp" -t "$threads" --seed "$seed" --timing "$timing" "$@" \
    >"${exr%.exr}.log" 2>&1 || { echo "run_cycles_bench: Cycles failed, see ${exr%.exr}.log" >&2; tail -5 "${exr%.exr}.log" >&2; exit 1; }
  [ -s "$exr" ] || { echo "run_cycles_bench: Cycles wrote no $exr" >&2; exit 1; }
}
seconds_of() { sed -n 's/.*"seconds_render": \([0-9.eE+-]*\).*/\1/p' "$1"; }
# A reference and its notes: reference_render NAME SCENE_ARGS OUT.exr SEED
reference_render() {
  local name=$1 scene_args=$2 ref=$3 seed=$4 base
  base=$(basename "${ref%.exr}")
  echo "reference $ref: Cycles at $REF_SPP spp, seed $seed, $threads threads (long)"
  cycles_render "$work/$name.json" "$work/images/$base-reference.exr" "$REF_SPP" "$seed" "$work/$base-reference.json" --half
  cp "$work/images/$base-reference.exr" "$ref"
  {
    echo "scene: $name ($scene_args)"
    echo "command: blender -b --factory-startup --python bench/cycles/import_scene.py -- --scene $name.json --output $base.exr --spp $REF_SPP -t $threads --seed $seed --half"
    echo "scene.json: build/bench/export_scene $scene_args -o $name.json"
    echo "seconds_render: $(seconds_of "$work/$base-reference.json")"
    echo "blender: $blender_version"
    echo "date: $(date -u +%Y-%m-%dT%H:%MZ)"
    echo "machine: $(nproc) cores, $(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -1)"
  } >"${ref%.exr}.txt"
  echo "  $(seconds_of "$work/$base-reference.json") s"
}
error_of() {  # prints "relative_l1,mse,block4_l1,worst_block16"
  "$image_error" "$1" "$2" | awk '$1 == "relative_l1" { r = $2 } $1 == "mse" { m = $2 } $1 == "block4_l1" { b = $2 }
    $1 == "worst_block16" { w = $2 } END { print r "," m "," b "," w }'
}

# --- references ---------------------------------------------------------------------
for entry in "${SCENES[@]}"; do
  name=${entry%%|*}
  read -r -a args <<<"${entry#*|}"
  "$export_scene" "${args[@]}" -o "$work/$name.json"
  for pair in "$name.exr|$REF_SEED" "$name-seed$REF_SEED_2.exr|$REF_SEED_2"; do
    ref=$refdir/${pair%|*}
    if [ -s "$ref" ]; then
      echo "reference $ref: present, kept"
    else
      reference_render "$name" "${entry#*|}" "$ref" "${pair#*|}"
    fi
  done
done

# The references' own noise: two renders of independent seeds differ by sqrt(2) times
# the noise of one (independent errors add in quadrature), per pixel and over 4x4
# blocks alike; the worst 16x16 block of their difference, as it is. Prints
# "l1,block4_l1,worst_block16" of the first reference.
reference_noise() {
  "$image_error" "$refdir/$1-seed$REF_SEED_2.exr" "$refdir/$1.exr" | awk '$1 == "relative_l1" { r = $2 }
    $1 == "block4_l1" { b = $2 } $1 == "worst_block16" { w = $2 } END { printf "%.6g,%.6g,%.6g\n", r / sqrt(2), b / sqrt(2), w }'
}
declare -A noise
for entry in "${SCENES[@]}"; do
  name=${entry%%|*}
  noise[$name]=$(reference_noise "$name")
  echo "reference $name: noise (relative L1 per pixel, of 4x4 blocks; worst 16x16 block apart) ${noise[$name]}"
done

[ "$refs_only" = 1 ] && { echo "run_cycles_bench: references done"; exit 0; }

# --- timed runs ---------------------------------------------------------------------
csv=$out/bench-cycles.csv
load_before=$(cut -d' ' -f1-3 /proc/loadavg)
echo "scene,renderer,setting,seconds,relative_l1,mse,block4_l1,worst_block16,estimated,reference_noise_l1,reference_noise_block4_l1" >"$csv.partial"
for entry in "${SCENES[@]}"; do
  name=${entry%%|*}
  read -r -a args <<<"${entry#*|}"
  ref=$refdir/$name.exr
  for spp in "${CYCLES_SPP[@]}"; do
    img=$work/images/$name-cycles-$spp.exr
    cycles_render "$work/$name.json" "$img" "$spp" "$SEED" "$work/$name-cycles-$spp.json"
    row="$name,cycles,$spp spp,$(seconds_of "$work/$name-cycles-$spp.json"),$(error_of "$img" "$ref"),,${noise[$name]%,*}"
    echo "$row" | tee -a "$csv.partial"
  done
  k=0
  for budget in "${RAYBUNDLE_BUDGETS[@]}"; do
    k=$((k + 1))
    img=$work/images/$name-raybundle-$k.exr
    read -r -a b <<<"$budget"
    t0=$(date +%s.%N)
    "$raybundle" solve "${args[@]}" "${b[@]}" --threads "$threads" --seed "$SEED" -q -o "$img" --stats "$work/stats.json"
    t1=$(date +%s.%N)
    estimated=$(sed -n 's/.*"image_estimated_error": \([0-9.eE+-]*\).*/\1/p' "$work/stats.json" | head -1)
    row="$name,raybundle,$budget,$(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.3f", b - a }'),$(error_of "$img" "$ref"),$estimated,${noise[$name]%,*}"
    echo "$row" | tee -a "$csv.partial"
  done
done
mv "$csv.partial" "$csv"
load_after=$(cut -d' ' -f1-3 /proc/loadavg)

# --- plot ---------------------------------------------------------------------------
png=$out/bench-cycles.png
names=""
for entry in "${SCENES[@]}"; do names="$names ${entry%%|*}"; done
gnuplot <<GP
set datafile separator ","
set terminal pngcairo size 1500,900 font ",10"
set output "$png"
set multiplot layout 2,${#SCENES[@]} title "raybundle against Cycles (CPU, $threads threads, 256^2): error against a Cycles $REF_SPP-spp reference"
set logscale xy
set grid
set key bottom left
set xlabel "seconds"
do for [s in "$names"] {
  set title s
  set ylabel "relative L1"
  plot "< awk -F, -v s=".s." '\$1==s && \$2==\"cycles\"' $csv" using 4:5 with linespoints lw 2 pt 7 title "Cycles (${CYCLES_SPP[*]} spp)", \
       "< awk -F, -v s=".s." '\$1==s && \$2==\"raybundle\"' $csv" using 4:5 with linespoints lw 2 pt 5 title "raybundle (${#RAYBUNDLE_BUDGETS[@]} budgets)"
}
do for [s in "$names"] {
  set title s
  set ylabel "MSE"
  plot "< awk -F, -v s=".s." '\$1==s && \$2==\"cycles\"' $csv" using 4:6 with linespoints lw 2 pt 7 title "Cycles", \
       "< awk -F, -v s=".s." '\$1==s && \$2==\"raybundle\"' $csv" using 4:6 with linespoints lw 2 pt 5 title "raybundle"
}
unset multiplot
GP

# --- time to an error: per pixel (2 %, 1 %, 0.5 %) and of 4x4 blocks ---------------
# Per scene and renderer, the points in order of time; the first pair of consecutive
# points whose errors bracket the target gives the time by log-log interpolation. A
# target met by the first (fastest) point is reported as "<= its time"; one never met,
# as "not reached"; one below three times the reference's noise (of that error), not
# at all: an error that small is the reference's as much as the image's.
time_to() {  # scene renderer target [error column, its noise column: 5 and 10, or 7 and 11]
  awk -F, -v s="$1" -v r="$2" -v e="$3" -v c="${4:-5}" -v nc="${5:-10}" '
    $1 == s && $2 == r { n++; t[n] = $4; err[n] = $c; noise = $nc }
    END {
      if (noise != "" && e < 3 * noise) { printf "below 3× the reference'"'"'s noise of %.2f %%", 100 * noise; exit }
      for (i = 1; i <= n; i++) for (j = i + 1; j <= n; j++)
        if (t[j] < t[i]) { x = t[i]; t[i] = t[j]; t[j] = x; x = err[i]; err[i] = err[j]; err[j] = x }
      for (i = 1; i <= n; i++) {
        if (err[i] > e) continue
        if (i == 1) { printf "<= %.3g s", t[1]; exit }
        f = (log(e) - log(err[i - 1])) / (log(err[i]) - log(err[i - 1]))
        printf "%.3g s", exp(log(t[i - 1]) + f * (log(t[i]) - log(t[i - 1]))); exit
      }
      printf "not reached (best %.2f %%)", 100 * min_err()
    }
    function min_err(   m, i) { m = err[1]; for (i = 2; i <= n; i++) if (err[i] < m) m = err[i]; return m }' "$csv"
}

md=$out/bench-cycles.md
cpu=$(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -1)
mem=$(awk '$1 == "MemTotal:" { printf "%.0f GiB", $2 / 1048576 }' /proc/meminfo)
{
  echo "# raybundle against Blender Cycles: time to error"
  echo
  echo "Written by \`$command_line\` on $(date -u +%Y-%m-%d)"
  echo "($(nproc) cores, $cpu, $mem; Blender $blender_version; $threads threads for both renderers)."
  echo "Load average (1, 5, 15 min) before the timed runs: $load_before; after: $load_after"
  echo "(above $threads, other work shared the cores and the seconds are inflated)."
  echo "Method and caveats: [benchmarks.md](benchmarks.md#against-blender-cycles)."
  echo
  echo "Error: relative L1 (Σ|a − b| / Σ|b| over pixels and channels) and MSE of each"
  echo "256² image against a Cycles reference of $REF_SPP samples per pixel."
  echo "Cycles: seconds of the render call (\`bpy.ops.render.render\`, timed inside Blender:"
  echo "scene sync, BVH and sampling; not Blender's start-up or the file write). raybundle:"
  echo "seconds of the whole command-line run (scene load, solve, final gather, EXR write)."
  echo
  echo "## Time to an error"
  echo
  echo "Log-log interpolation between the measured points; \"<=\" when the fastest point is"
  echo "already below the target."
  echo
  echo "| scene | renderer | 2 % | 1 % | 0.5 % | 4×4 blocks: 1 % | 0.5 % | 0.25 % |"
  echo "| --- | --- | --- | --- | --- | --- | --- | --- |"
  for entry in "${SCENES[@]}"; do
    name=${entry%%|*}
    for r in cycles raybundle; do
      echo "| $name | $r | $(time_to "$name" $r 0.02) | $(time_to "$name" $r 0.01) | $(time_to "$name" $r 0.005) |" \
        "$(time_to "$name" $r 0.01 7 11) | $(time_to "$name" $r 0.005 7 11) | $(time_to "$name" $r 0.0025 7 11) |"
    done
  done
  echo
  echo "The references' own noise, from two renders of seeds $REF_SEED and $REF_SEED_2 (their"
  echo "difference over √2; the worst 16×16 block of their difference as it is). No time"
  echo "to an error below three times it is given."
  echo
  echo "| scene | per pixel | 4×4 blocks | worst 16×16 block of the difference |"
  echo "| --- | --- | --- | --- |"
  for entry in "${SCENES[@]}"; do
    name=${entry%%|*}
    echo "${noise[$name]}" | awk -F, -v s="$name" '{ printf "| %s | %.3f %% | %.3f %% | %+.2f %% |\n", s, 100 * $1, 100 * $2, 100 * $3 }'
  done
  echo
  echo "![relative L1 and MSE against seconds](bench-cycles.png)"
  echo
  echo "## Measured points ([bench-cycles.csv](bench-cycles.csv))"
  echo
  echo "Beside the error per pixel: the relative L1 of 4×4-pixel means (which keeps a"
  echo "bias and averages grain), the worst 16×16 block's relative error, and for raybundle"
  echo "its own estimate of its relative L1 error (the stats' \`image_estimated_error\`)."
  echo
  echo "| scene | renderer | setting | seconds | relative L1 | MSE | 4×4 blocks | worst 16×16 | estimated |"
  echo "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"
  tail -n +2 "$csv" | awk -F, '{ printf "| %s | %s | `%s` | %.3g | %.4f | %.3g | %.4f | %+.3f | %s |\n", $1, $2, $3, $4, $5, $6, $7, $8,
    $9 == "" ? "" : sprintf("%.4f", $9) }'
  echo
  echo "## Scenes and references"
  echo
  for entry in "${SCENES[@]}"; do
    name=${entry%%|*}
    echo "- \`$name\`: \`${entry#*|}\`; references:"
    for txt in "$refdir/$name.txt" "$refdir/$name-seed$REF_SEED_2.txt"; do
      echo "  - $txt: $(sed -n 's/^command: .*--spp \([0-9]*\).*--seed \([0-9]*\).*/\1 spp, seed \2/p' "$txt"),"
      echo "    $(awk '$1 == "seconds_render:" { printf "%.0f", $2 }' "$txt") s of Cycles on $(sed -n 's/^date: //p' "$txt")"
    done
  done
  echo
  echo "raybundle budgets (\`raybundle solve SCENE BUDGET --threads $threads --seed $SEED\`):"
  echo
  for budget in "${RAYBUNDLE_BUDGETS[@]}"; do echo "- \`$budget\`"; done
} >"$md"
echo "run_cycles_bench: wrote $csv, $png, $md"
