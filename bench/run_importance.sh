#!/usr/bin/env bash
# Importance sampling of global walks (004 sections 7-8; docs/importance-sampling.md):
# the image error against walks and against seconds (004 Fig. 24) for random, Sobol,
# VEGAS and Metropolis walks (the perturbation swept), plain walks of D = 3, on two
# scenes:
#   partition    bench/scenes/partition.json: the camera's room is lit only through a
#                20 cm square hole in a 1 m thick wall, from the next room's walls (the
#                lamp's light cannot reach the hole straight): light the camera sees
#                only indirectly, through a narrow cone of directions;
#   cornell-box  the built-in Cornell box at 128^2: light everywhere.
# The image is the patch image (--gather 0); its error the relative L1 against a
# reference of the same method and depth (random walks, 200,000 for the partition and
# 20,000 for the box, other seeds), averaged over 6 seeds. The reference's own error
# (about 1/sqrt(its walks / the runs' walks) of a random run's) is in every row.
# Usage: bench/run_importance.sh [OUT.csv]   (default docs/bench-importance.csv;
# build/apps/raybundle first; then docs/make-plots.sh draws docs/bench-importance.png)
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-docs/bench-importance.csv}
raybundle=$PWD/build/apps/raybundle
[ -x "$raybundle" ] || { echo "run_importance: $raybundle missing (build first)" >&2; exit 1; }
work=$(mktemp -d "${TMPDIR:-/tmp}/raybundle-importance.XXXXXX")
trap 'rm -rf "$work"' EXIT
json() { python3 -c "import json,sys; d=json.load(open(sys.argv[1])); print(eval(sys.argv[2], {}, {'d': d}))" "$@"; }

declare -A scene_args=(
  [partition]="bench/scenes/partition.json"
  [cornell-box]="--builtin cornell-box -D camera.width=128 -D camera.height=128"
)
declare -A reference_walks=([partition]=200000 [cornell-box]=20000)
walk=(--method walk --depth 3 --gather 0 --threads 2 -q)

echo "scene,sampler,mutation_size,walks,seed,directions,seconds_solve,relative_l1,acceptance_rate,exposure,refinements" >"$out"
for scene in partition cornell-box; do
  # shellcheck disable=SC2206
  args=(${scene_args[$scene]})
  echo "run_importance: $scene: reference (${reference_walks[$scene]} random walks)" >&2
  "$raybundle" solve "${args[@]}" "${walk[@]}" --sampler random --iterations "${reference_walks[$scene]}" --seed 4242 \
    -o "$work/$scene-ref.exr"
  for walks in 250 1000 4000; do
    for config in random sobol vegas metropolis:0.03 metropolis:0.1 metropolis:0.3; do
      sampler=${config%%:*} delta=""
      extra=()
      if [ "$sampler" = metropolis ]; then delta=${config#*:}; extra=(--mutation-size "$delta"); fi
      for seed in 1 2 3 4 5 6; do
        "$raybundle" solve "${args[@]}" "${walk[@]}" --sampler "$sampler" "${extra[@]}" --iterations "$walks" \
          --seed "$seed" --reference "$work/$scene-ref.exr" --stats "$work/s.json"
        printf '%s,%s,%s,%s,%s,%s,%s,%s,%s,%s,%s\n' "$scene" "$sampler" "$delta" "$walks" "$seed" \
          "$(json "$work/s.json" "d['directions']")" "$(json "$work/s.json" "d['seconds_solve']")" "$(json "$work/s.json" "d['reference']['relative_l1']")" \
          "$(json "$work/s.json" "d.get('metropolis', {}).get('acceptance_rate', '')")" \
          "$(json "$work/s.json" "d.get('metropolis', {}).get('exposure', '')")" \
          "$(json "$work/s.json" "d.get('vegas', {}).get('refinements', '')")" | tee -a "$out"
      done
    done
  done
done

# The means over the seeds, for the figure and docs/importance-sampling.md.
python3 - "$out" "${out%.csv}-mean.csv" <<'PY'
import csv, math, sys
from collections import defaultdict
groups = defaultdict(list)
for r in csv.DictReader(open(sys.argv[1])):
    groups[(r["scene"], r["sampler"] + (" " + r["mutation_size"] if r["mutation_size"] else ""), int(r["walks"]))].append(r)
with open(sys.argv[2], "w") as f:
    f.write("scene,config,walks,directions,seconds_solve,relative_l1,relative_l1_se,seeds\n")
    for (scene, config, walks), rows in sorted(groups.items()):
        e = [float(r["relative_l1"]) for r in rows]
        m = sum(e) / len(e)
        se = math.sqrt(sum((x - m) ** 2 for x in e) / (len(e) - 1) / len(e))
        d = sum(float(r["directions"]) for r in rows) / len(rows)
        t = sum(float(r["seconds_solve"]) for r in rows) / len(rows)
        f.write(f"{scene},{config},{walks},{d:.0f},{t:.4f},{m:.5f},{se:.5f},{len(rows)}\n")
PY
echo "run_importance: wrote $out and ${out%.csv}-mean.csv (docs/make-plots.sh draws the figure)" >&2
