#!/usr/bin/env bash
# End-to-end checks of the raybundle command line: bad input ends with one line on
# stderr, exit code 2 and no output file created or truncated; a good run writes
# every output; the same seed gives byte-identical results.
# Usage: test_cli.sh PATH/TO/raybundle
set -uo pipefail
bin=$1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work" || exit 1
passed=0
failed=0
fail() { echo "FAIL: $*"; failed=$((failed + 1)); }

camera='"camera": {"eye": [0.5, 0.5, 3], "target": [0.5, 0.5, 0]}'
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
  "$bin" "$@" -o outdir/img.exr --png outdir/img.png --stats outdir/s.json --csv outdir/c.csv \
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

expect_bad "missing scene file" "no-such.json: cannot open scene file" solve no-such.json
expect_bad "malformed JSON" "malformed.json:3:" solve malformed.json
expect_bad "unknown key" "unknown key 'patchsize'" solve unknown-key.json
expect_bad "unknown material" "objects[0].material: unknown material 'red'" solve unknown-material.json
expect_bad "NaN coordinate" "nan.obj: line 2: coordinate 'nan' is not finite" solve nan.json
expect_bad "face index out of range" "range.obj: line 4: face references vertex 9" solve range.json
expect_bad "truncated mesh" "short.off: vertices: file is truncated" solve short.json
expect_bad "albedo + specular >= 1" "albedo + specular = 1 in channel r" solve albedo.json
expect_bad "negative emission" "negative emission [0, -2, 0]" solve emission.json
expect_bad "fov_y out of range" "camera.fov_y: must be in (0, 180) degrees, got 200" solve fov.json
expect_bad "patch_size <= 0" "patch_size: must be > 0, got 0" solve patch-size.json
expect_bad "no patches" "the scene has no patches" solve empty.json
expect_bad "unknown backend" "unknown visibility backend 'zbufer' (known: exact-painter, painter" solve good.json --visibility zbufer
expect_bad "unknown built-in" "unknown built-in scene 'teapot'" solve --builtin teapot
expect_bad "scene and built-in" "exactly one of" solve good.json --builtin homogeneous-box
expect_bad "iterations 0" "--iterations" solve good.json --iterations 0
expect_bad "unknown method" "--method" solve good.json --method metropolis
expect_bad "QMC for iteration" "stochastic iteration needs independent consecutive directions" \
  solve good.json --sampler halton
expect_bad "unbiased iteration" "--unbiased applies to the walk methods" solve good.json --unbiased
expect_bad "depth for iteration" "--depth applies to the walk methods" solve good.json --depth 3
expect_bad "bidirectional flag for walks" "for walks use --method bidirectional" \
  solve good.json --method walk --bidirectional
expect_bad "sobol depth" "the sobol sampler supports depths up to 15" solve good.json --method walk --sampler sobol --depth 20
expect_bad "linear basis with another backend" "--basis linear uses the centre-sorted painter's radiance map" \
  solve good.json --basis linear --visibility raycast
expect_bad "diffuse shot in a glossy scene" "--diffuse-shot supports diffuse scenes only" solve albedo-ok.json --diffuse-shot
expect_bad "linear basis with walks" "--basis linear works with --method iteration" solve good.json --basis linear --method walk
expect_bad "negative seed" "--seed: '-1' is not a non-negative integer" solve good.json --seed -1
expect_bad "exposure nan" "--exposure: 'nan' is not a finite number" solve good.json --exposure nan
expect_bad "eps inf" "--eps-depth: 'inf' is not a finite number" solve good.json --gather 2 --eps-depth inf
# Outputs that collide or are directories (expect_bad names every output itself).
mkdir -p adir
for case in "-o same.exr --png same.exr|-o and --png name the same file" "--stats adir|--stats adir: is a directory"; do
  args=${case%%|*}
  text=${case#*|}
  # shellcheck disable=SC2086
  "$bin" solve good.json $args >out.txt 2>err.txt
  rc=$?
  if [ "$rc" -eq 2 ] && [ "$(wc -l <err.txt)" -eq 1 ] && grep -qF -- "$text" err.txt && [ ! -e same.exr ]; then
    passed=$((passed + 1))
  else
    fail "$args: exit $rc, $(cat err.txt)"
  fi
done
expect_bad "filter without gather" "--filter needs the final gather" solve good.json --filter atrous
expect_bad "unbiased QMC walks" "--unbiased needs --sampler random" solve good.json --method walk --unbiased --sampler sobol
expect_bad "spp without gather" "--spp needs the final gather" solve good.json --spp 4
expect_bad "unknown filter" "--filter" solve good.json --gather 4 --filter median
expect_bad "aov not a directory" "--aov nowhere: not a directory" solve good.json --gather 4 --aov nowhere
scene "$quad" ', "sky": {"radiance": [1, 1, 1], "model": "clear"}' > sky.json
expect_bad "unknown sky model" "sky.model: unknown sky model 'clear'" solve sky.json
# A missing output directory is found before solving, and nothing is written.
rm -f side.exr
"$bin" solve good.json -o side.exr --png nowhere/x.png >out.txt 2>err.txt
rc=$?
if [ "$rc" -eq 2 ] && [ "$(wc -l <err.txt)" -eq 1 ] && grep -qF "directory 'nowhere' does not exist" err.txt \
   && [ ! -e side.exr ]; then
  passed=$((passed + 1))
else
  fail "missing output directory: exit $rc, $(cat err.txt)"
fi

# Coplanar overlapping patches facing the same way: one warning line with the count, and
# the run goes on (the stats record the count).
scene "$quad, {\"quad\": [[0.2,0.2,0], [0.6,0.2,0], [0.6,0.6,0], [0.2,0.6,0]], \"material\": \"w\"}" > overlap.json
"$bin" solve overlap.json --iterations 20 -o overlap.exr --stats overlap-stats.json >out.txt 2>err.txt
rc=$?
if [ "$rc" -eq 0 ] && [ "$(wc -l <err.txt)" -eq 1 ] \
   && grep -qE "warning: overlap.json: [0-9]+ pairs of coplanar overlapping patches face the same way" err.txt \
   && grep -qE '"coplanar_overlaps": *[1-9]' overlap-stats.json; then
  passed=$((passed + 1))
else
  fail "coplanar overlap warning: exit $rc, $(cat err.txt)"
fi

# A backend whose library is missing at run time: one clear line, exit 1, no output.
if "$bin" backends | grep -q "^zbuffer "; then
  rm -rf outdir && mkdir outdir
  RAYBUNDLE_OSMESA_LIBRARY=/nonexistent/libOSMesa.so "$bin" solve --builtin homogeneous-box --visibility zbuffer \
    -o outdir/z.exr --stats outdir/z.json >out.txt 2>err.txt
  rc=$?
  if [ "$rc" -eq 1 ] && [ "$(wc -l <err.txt)" -eq 1 ] && grep -qF "zbuffer: cannot load OSMesa" err.txt \
     && [ -z "$(ls outdir)" ]; then
    passed=$((passed + 1))
  else
    fail "missing OSMesa: exit $rc, $(cat err.txt), outputs: $(ls outdir)"
  fi
fi

# A good run writes every output, with the documented stats and CSV headers.
if "$bin" solve --builtin homogeneous-box --iterations 200 -o h.exr --png h.png --stats h.json \
     --csv h.csv --patches h-patches.csv --ply h.ply 2>err.txt; then
  ok=1
  for f in h.exr h.png h.json h.csv h-patches.csv h.ply; do [ -s "$f" ] || { fail "good run: $f missing"; ok=0; }; done
  [ "$(head -1 h-patches.csv)" = "id,cx,cy,cz,nx,ny,nz,area,r,g,b" ] || { fail "patch CSV header"; ok=0; }
  [ "$(head -1 h.csv)" = "iteration,seconds,relative_l1_error,mean_radiance" ] || { fail "convergence CSV header"; ok=0; }
  for key in patches iterations directions resolution visibility seconds_total seconds_per_iteration mean_radiance \
             exact_radiance relative_l1_error memory_per_patch_bytes decisions first_shot sky; do
    grep -q "\"$key\"" h.json || { fail "stats lack $key"; ok=0; }
  done
  [ "$(ls | grep -c partial)" -eq 0 ] || { fail "temporary files left"; ok=0; }
  [ "$ok" -eq 1 ] && passed=$((passed + 1))
else
  fail "good run failed: $(cat err.txt)"
fi

# Walks: their stats name depth, sampler and the truncated exact value 1 - 2^-(D+1).
if "$bin" solve --builtin homogeneous-box --patch-size 0.34 --method combined --depth 3 --sampler sobol \
     --iterations 20 -o w.exr --stats w.json 2>err.txt; then
  ok=1
  for key in walks depth sampler unbiased storage; do grep -q "\"$key\"" w.json || { fail "walk stats lack $key"; ok=0; }; done
  grep -q '"exact_radiance": 0.9375' w.json || { fail "walk stats: exact_radiance is not 0.9375"; ok=0; }
  grep -q '"directions": 60' w.json || { fail "walk stats: 20 walks of 3 should make 60 directions"; ok=0; }
  [ "$ok" -eq 1 ] && passed=$((passed + 1))
else
  fail "walk run failed: $(cat err.txt)"
fi

# The final gather: image, AOVs and its stats.
mkdir -p aov
if "$bin" solve --builtin cornell-box --patch-size 100 --iterations 50 --gather 4 --spp 2 --aov aov \
     -o g.exr --stats g.json 2>err.txt; then
  ok=1
  for f in g.exr aov/direct.exr aov/indirect.exr aov/indirect-filtered.exr aov/normal.exr aov/depth.exr; do
    [ -s "$f" ] || { fail "gather run: $f missing"; ok=0; }
  done
  for key in final_gather gather_rays shadow_rays seconds_filter; do grep -q "\"$key\"" g.json || { fail "gather stats lack $key"; ok=0; }; done
  [ "$ok" -eq 1 ] && passed=$((passed + 1))
else
  fail "gather run failed: $(cat err.txt)"
fi

# Determinism through the CLI: same seed, byte-identical per-patch output.
run_seed() { "$bin" solve --builtin homogeneous-box --patch-size 0.34 --iterations 100 --seed "$1" -o "$2.exr" --patches "$2.csv" 2>/dev/null; }
run_seed 9 a
run_seed 9 b
run_seed 10 c
if cmp -s a.csv b.csv && cmp -s a.exr b.exr && ! cmp -s a.csv c.csv; then
  passed=$((passed + 1))
else
  fail "same seed did not give identical output (or another seed did)"
fi

echo "cli: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
