#!/usr/bin/env bash
# Time to error on MPI ranks (docs/ranks.md): the built-in Cornell box (3,722 patches,
# 256x256), on one rank of one thread, two ranks of one thread (mpirun -np 2) and, for
# comparison, one rank of two threads, each budget run once per configuration with
# seed 1. Wall seconds are the whole command's (mpirun's start included), measured
# here.
#   field:  --gather 0 at a ladder of iterations; error: the area-weighted relative L1
#           of the patch field against a reference of 128,000 iterations (2 threads,
#           another seed: its chains are not those of the runs).
#   image:  the default pipeline (final gather, 64 rays, guided filter) at a ladder of
#           iterations with the gather rays in proportion; error: the pipeline's own
#           estimate (render/progressive.h: two independent halves).
#   100k:   the Cornell box at --patch-size 10 (121,324 patches), 100 steps, no gather,
#           where the scene's preparation and the diffuse shot are a large part of a
#           run (each rank prepares the scene, its contact search and the diffuse shot
#           shared out between ranks); error: the field's own estimate.
# Each row also has rank 0's seconds of the scene's preparation (the stats' phase).
# PARTS="field image 100k" (the default) chooses the parts; the field part's reference
# is computed only when it runs. RAYBUNDLE=path runs another binary.
# Usage: bench/run_ranks.sh [OUT.csv]   (default docs/bench-ranks.csv; the build with
# MPI first: scripts/setup-deps.sh --tests, scripts/build.sh -DRAYBUNDLE_REQUIRE_MPI=ON)
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-docs/bench-ranks.csv}
raybundle=${RAYBUNDLE:-$PWD/build/apps/raybundle}
[ -x "$raybundle" ] || { echo "run_ranks: $raybundle missing (build first)" >&2; exit 1; }
"$raybundle" --version | grep -q "ranks *MPI" || { echo "run_ranks: $raybundle was built without MPI" >&2; exit 1; }
mpi=(mpirun -q --allow-run-as-root --oversubscribe)
work=$(mktemp -d "${TMPDIR:-/tmp}/raybundle-ranks.XXXXXX")
trap 'rm -rf "$work"' EXIT
scene=(--builtin cornell-box --seed 1 -q)

parts=" ${PARTS:-field image 100k} "
if [[ $parts == *" field "* ]]; then
  echo "run_ranks: reference field (128000 iterations, 2 threads, seed 7)" >&2
  "$raybundle" solve --builtin cornell-box --seed 7 -q --gather 0 --iterations 128000 --threads 2 --patches "$work/ref.csv"
fi

now() { date +%s.%N; }
field_error() {  # area-weighted relative L1 of a patch CSV against the reference
  python3 - "$1" "$work/ref.csv" <<'EOF'
import csv, sys
a, b = (list(csv.DictReader(open(f))) for f in sys.argv[1:3])
num = sum(float(x["area"]) * abs(float(x[k]) - float(y[k])) for x, y in zip(a, b) for k in "rgb")
den = sum(float(y["area"]) * abs(float(y[k])) for y in b for k in "rgb")
print(f"{num / den:.6f}")
EOF
}
json() { python3 -c "import json,sys; d=json.load(open(sys.argv[1])); print(eval(sys.argv[2], {}, {'d': d}))" "$@"; }

echo "pipeline,config,ranks,threads,iterations,gather_rays,wall_seconds,seconds_solve,seconds_render,error,error_kind,seconds_scene" >"$out"
run() {  # pipeline config ranks threads iterations gather_rays
  local pipeline=$1 config=$2 ranks=$3 threads=$4 iterations=$5 rays=$6 launch=()
  [ "$config" = "2 ranks" ] && launch=("${mpi[@]}" -np 2)
  [ "$config" = "1 rank" ] && launch=("${mpi[@]}" -np 1)
  local t0 t1 error kind
  t0=$(now)
  local extra=()
  [ "$pipeline" = 100k ] && extra=(--patch-size 10)
  "${launch[@]}" "$raybundle" solve "${scene[@]}" "${extra[@]}" --threads "$threads" --iterations "$iterations" \
    --gather "$rays" --patches "$work/p.csv" --stats "$work/s.json"
  t1=$(now)
  if [ "$pipeline" = field ]; then
    error=$(field_error "$work/p.csv") kind="field against the reference"
  elif [ "$pipeline" = 100k ]; then
    error=$(json "$work/s.json" "d['estimate']['field_estimated_error']") kind="field estimate"
  else
    error=$(json "$work/s.json" "d['estimate']['image_estimated_error']") kind="image estimate"
  fi
  printf '%s,"%s",%s,%s,%s,%s,%.3f,%.3f,%.3f,%s,"%s",%.3f\n' "$pipeline" "$config" "$ranks" "$threads" "$iterations" "$rays" \
    "$(awk -v a="$t0" -v b="$t1" 'BEGIN { print b - a }')" "$(json "$work/s.json" "d['seconds_solve']")" \
    "$(json "$work/s.json" "d['seconds_render']")" "$error" "$kind" \
    "$(json "$work/s.json" "[p['seconds'] for p in d['phases'] if p['phase'] == 'scene'][0]")" | tee -a "$out"
}
if [[ $parts == *" field "* ]]; then
  for iterations in 2000 8000 32000; do
    run field "1 rank" 1 1 "$iterations" 0
    run field "2 ranks" 2 1 "$iterations" 0
    run field "1 process, 2 threads" 1 2 "$iterations" 0
  done
fi
if [[ $parts == *" image "* ]]; then
  for scale in 1 4; do
    run image "1 rank" 1 1 $((1000 * scale)) $((16 * scale))
    run image "2 ranks" 2 1 $((1000 * scale)) $((16 * scale))
    run image "1 process, 2 threads" 1 2 $((1000 * scale)) $((16 * scale))
  done
fi
if [[ $parts == *" 100k "* ]]; then
  for config in "1 rank" "2 ranks" "1 process, 2 threads"; do
    case $config in "1 rank") n=1 t=1 ;; "2 ranks") n=2 t=1 ;; *) n=1 t=2 ;; esac
    run 100k "$config" "$n" "$t" 100 0
  done
fi
