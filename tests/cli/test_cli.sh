#!/usr/bin/env bash
# End-to-end checks of the raybundle command line: bad input ends with one line on
# stderr, exit code 2 and no output file created or truncated; a good run writes
# every output and nothing else; the conveniences (--version, help, formats by
# extension, -D, --width/--height/--fov, output directories, threads, the progress
# bar, --quiet, check, two_sided) do what the README says; the same seed gives
# byte-identical results.
# Usage: test_cli.sh PATH/TO/raybundle SOURCE_DIR
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

# Inputs a mutation fuzzer found crashing, hanging or eating memory (tests/scenes/
# test_mesh_file.cpp has the full set), and inputs that are not files.
printf 'ply\nformat ascii 1.0\nproperty float x\nelement vertex 3\nend_header\n' > early.ply
printf 'ply\nformat ascii 1.0\n' > endless.ply
printf 'OFF\n2147483648 1 0\n0 0 0\n' > huge.off
printf 'OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n' > two.off
mkfifo fifo.obj fifo.json
mkdir -p dir.obj
ln -sf /dev/zero zero.off
for m in early.ply endless.ply huge.off two.off fifo.obj dir.obj zero.off; do
  scene "{\"mesh\": \"$m\", \"material\": \"w\"}" > "mesh-${m%.*}.json"
done
expect_bad "PLY property before element" "early.ply: header line 3: property before any element" solve mesh-early.json
expect_bad "PLY without end_header" "endless.ply: header: no end_header line" solve mesh-endless.json
expect_bad "OFF count of 2^31" "huge.off: header: vertex count '2147483648' is not a count" solve mesh-huge.json
expect_bad "2-corner OFF face" "two.off: face 0: face has 2 corners (at least 3 needed)" solve mesh-two.json
expect_bad "FIFO as a mesh" "fifo.obj: is not a regular file" solve mesh-fifo.json
expect_bad "directory as a mesh" "dir.obj: is a directory, not a mesh file" solve mesh-dir.json
expect_bad "/dev/zero as a mesh" "zero.off: is not a regular file" solve mesh-zero.json
expect_bad "FIFO as the scene" "fifo.json: is not a regular file (a FIFO, a socket or a device), not a scene file" solve fifo.json
printf '{"objects": %s%s}\n' "$(head -c 60000 /dev/zero | tr '\0' '[')" "$(head -c 60000 /dev/zero | tr '\0' ']')" > deep.json
expect_bad "JSON nested 60,000 deep" "deep.json: objects[0][0]" solve deep.json
scene "$quad" ', "patch_size": 1, "patch_size": 2' > twice.json
expect_bad "a key given twice" "twice.json: patch_size: key given twice" solve twice.json
expect_bad "missing scene file" "no-such.json: cannot open scene file" solve no-such.json
expect_bad "--ambient with walks" "--ambient: applies to stochastic iteration with the constant basis" \
  solve good.json --method walk --ambient
expect_bad "--ambient with pathtrace" "ambient does not apply to --method pathtrace" \
  solve good.json --method pathtrace --ambient
# The ambient control variate: off by default, on with --ambient, in the stats either way.
"$bin" solve --builtin homogeneous-box --iterations 50 --gather 0 --ambient --stats amb-on.json -q &&
  "$bin" solve --builtin homogeneous-box --iterations 50 --gather 0 --stats amb-off.json -q &&
  grep -q '"ambient": "control variate' amb-on.json && grep -q '"ambient": "off' amb-off.json
check $? "--ambient/--no-ambient: the decision is not in the stats"
# Magnitudes whose products would overflow (a NaN image with exit 0 before).
scene "$quad" ', "point_lights": [{"position": [0.5, 0.5, 1], "intensity": [1e308, 1e308, 1e308]}]' > overflow.json
expect_bad "point light of 1e308" "point_lights[0].intensity: value 1e+308 is too large (at most 1e+15 in magnitude)" \
  solve overflow.json
scene '{"quad": [[0,0,0], [1e200,0,0], [1e200,1e200,0], [0,1e200,0]], "material": "w"}' > huge.json
expect_bad "coordinates of 1e200" "objects[0].quad[1]: value 1e+200 is too large" solve huge.json
expect_bad "malformed JSON" "malformed.json:3:" solve malformed.json
expect_bad "unknown key" "unknown key 'patchsize'" solve unknown-key.json
expect_bad "unknown material" "objects[0].material: unknown material 'red'" solve unknown-material.json
expect_bad "NaN coordinate" "nan.obj: line 2: coordinate 'nan' is not finite" solve nan.json
expect_bad "face index out of range" "range.obj: line 4: face references vertex 9" solve range.json
expect_bad "truncated mesh" "short.off: vertices: file is truncated" solve short.json
expect_bad "albedo + specular >= 1" "albedo + specular = 1 in channel r" solve albedo.json
expect_bad "negative emission" "negative emission [0, -2, 0]" solve emission.json
expect_bad "fov_y out of range" "camera.fov_y: must be in (0, 180) degrees, got 200" solve fov.json
expect_bad "patch_size <= 0" "patch_size: must be a positive number, got 0" solve patch-size.json
expect_bad "no patches" "the scene has no patches" solve empty.json
expect_bad "unknown backend" "unknown visibility backend 'zbufer' (known: exact-painter, painter" solve good.json --visibility zbufer
expect_bad "unknown built-in" "unknown built-in scene 'teapot'" solve --builtin teapot
expect_bad "scene and built-in" "exactly one of" solve good.json --builtin homogeneous-box
expect_bad "iterations 0" "--iterations" solve good.json --iterations 0
expect_bad "unknown method" "--method: unknown method 'metropolis' (known: iteration, walk, combined, bidirectional, pathtrace)" solve good.json --method metropolis
expect_bad "both diffuse-shot flags" "give one of --diffuse-shot and --no-diffuse-shot" solve good.json --no-diffuse-shot --diffuse-shot
expect_bad "QMC for iteration" "stochastic iteration needs independent consecutive directions" \
  solve good.json --sampler halton
expect_bad "unbiased iteration" "--unbiased: applies to the walk methods" solve good.json --unbiased
expect_bad "depth for iteration" "--depth applies to the walk methods" solve good.json --depth 3
expect_bad "one-way flag for walks" "--one-way: applies to stochastic iteration" \
  solve good.json --method walk --one-way
expect_bad "sobol depth" "--depth: must be in 1..15 with the sobol sampler, got 20" solve good.json --method walk --sampler sobol --depth 20
expect_bad "linear basis with another backend" "--visibility: the linear basis uses the centre-sorted painter's radiance map" \
  solve good.json --basis linear --visibility raycast
expect_bad "diffuse shot in a glossy scene" "--diffuse-shot: supports diffuse scenes only" solve albedo-ok.json --diffuse-shot
expect_bad "linear basis with walks" "--basis: linear works with the method 'iteration', not 'walk'" solve good.json --basis linear --method walk
expect_bad "negative seed" "--seed: '-1' is not an integer in 0..2^64-1" solve good.json --seed -1
expect_bad "seed 2^64" "--seed: '18446744073709551616' is not an integer in 0..2^64-1" solve good.json \
  --seed 18446744073709551616
for v in 0 16385 -4 1.5; do
  expect_bad "--width $v" "--width: Value $v not in range 1 to 16384" solve good.json --width "$v"
done
printf '{%s, %s, "objects": [%s], "point_lights": [{"position": [0.5, 0.5, 1], "intensity": [1, 1, 1]}]}\n' \
  "$camera" "$materials" "$quad" >lit.json
expect_bad "NaN light intensity (-D)" "point_lights[0].intensity: expected [x, y, z], got [\"nan\",1,1]" \
  solve lit.json -D "point_lights[0].intensity[0]=nan"
printf '{"camera": {"eye": [0.5, 0.5, 3], "target": [0.5, 0.5, 0], "up": [0, 0, 0]}, %s, "objects": [%s]}\n' \
  "$materials" "$quad" >up.json
expect_bad "zero camera up" "camera.up: is zero or parallel to the viewing direction" solve up.json
expect_bad "exposure nan" "--exposure: 'nan' is not a finite number" solve good.json --exposure nan
expect_bad "eps inf" "--eps-depth: 'inf' is not a finite number" solve good.json --gather 2 --eps-depth inf
# Outputs that collide or are directories (expect_bad names every output itself).
mkdir -p adir d
echo file > afile
touch ro.exr && chmod 444 ro.exr
mkfifo fifo.exr
for case in "-o same.exr -o same.exr|-o same.exr and -o same.exr name the same file" \
            "-o same.exr --stats same.exr|-o same.exr and --stats same.exr name the same file" \
            "-o ./d/same.exr -o d/../d/same.exr|-o ./d/same.exr and -o d/../d/same.exr name the same file" \
            "--gather 4 --aov d -o d/direct.exr|-o d/direct.exr and --aov d/direct.exr name the same file" \
            "--stats adir|--stats adir: is a directory" \
            "--stats /dev/null|--stats /dev/null: is a device, a FIFO or a socket, not a file" \
            "-o fifo.exr|-o fifo.exr: is a device, a FIFO or a socket" \
            "-o ro.exr|-o ro.exr: is read-only" \
            "-o afile/x.exr|-o afile/x.exr: Not a directory" \
            "--stats good.json|--stats good.json: is the scene file (it would be overwritten)"; do
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
[ -p fifo.exr ] && [ -c /dev/null ] && [ "$(cat ro.exr)" = "" ] || fail "a refused output was replaced"
expect_bad "filter without gather" "--filter needs the final gather" solve good.json --gather 0 --filter atrous
expect_bad "unbiased QMC walks" "--unbiased: needs the random sampler" solve good.json --method walk --unbiased --sampler sobol
expect_bad "spp without gather" "--spp needs the final gather" solve good.json --gather 0 --spp 4
expect_bad "unknown filter" "--filter" solve good.json --gather 4 --filter median
echo file > afile
expect_bad "aov not a directory" "--aov afile: not a directory" solve good.json --gather 4 --aov afile
expect_bad "unknown image format" "-o x.jpg: unknown image format" solve good.json -o x.jpg
expect_bad "bad define" "-D camera.width: expected key=value" solve good.json -D camera.width
expect_bad "define of an unknown key" "unknown key 'patchsize'" solve good.json -D patchsize=3
expect_bad "define of a bad value" "camera.fov_y: must be in (0, 180) degrees, got 200" solve good.json -D camera.fov_y=200
expect_bad "define of a non-number" "camera.width" solve good.json -D camera.width=wide
expect_bad "bad fov flag" "--fov" solve good.json --fov -3
expect_bad "width 0" "--width" solve good.json --width 0
scene "$quad" ', "sky": {"radiance": [1, 1, 1], "model": "clear"}' > sky.json
expect_bad "unknown sky model" "sky.model: unknown sky model 'clear'" solve sky.json
# Coplanar overlapping patches facing the same way: a warning line with the count, and
# the run goes on (the stats record the count). (Which of the two shows is arbitrary:
# the higher patch index; a second line may warn that the other faces nothing.)
scene "$quad, {\"quad\": [[0.2,0.2,0], [0.6,0.2,0], [0.6,0.6,0], [0.2,0.6,0]], \"material\": \"w\"}" > overlap.json
"$bin" solve overlap.json --iterations 20 -o overlap.exr --stats overlap-stats.json >out.txt 2>err.txt
rc=$?
if [ "$rc" -eq 0 ] && [ "$(grep -c "coplanar overlapping" err.txt)" -eq 1 ] \
   && grep -qE "warning: overlap.json: [0-9]+ pairs of coplanar overlapping patches face the same way" err.txt \
   && grep -qE '"coplanar_overlaps": *[1-9]' overlap-stats.json; then
  passed=$((passed + 1))
else
  fail "coplanar overlap warning: exit $rc, $(cat err.txt)"
fi

# A backend whose library is missing at run time: one clear line, exit 1, no output.
if "$bin" backends | grep -q "^zbuffer "; then
  rm -rf outdir && mkdir outdir
  RAYBUNDLE_OSMESA_LIBRARY=/nonexistent/libOSMesa.so "$bin" solve --builtin homogeneous-box --width 32 --height 32 --visibility zbuffer \
    -o outdir/z.exr --stats outdir/z.json >out.txt 2>err.txt
  rc=$?
  if [ "$rc" -eq 1 ] && [ "$(wc -l <err.txt)" -eq 1 ] && grep -qF "zbuffer: cannot load OSMesa" err.txt \
     && [ -z "$(ls outdir)" ]; then
    passed=$((passed + 1))
  else
    fail "missing OSMesa: exit $rc, $(cat err.txt), outputs: $(ls outdir)"
  fi
else
  skip "missing OSMesa: this build has no zbuffer backend (OSMesa not found at configure time)"
fi

# A good run writes every output, with the documented stats and CSV headers.
if "$bin" solve --builtin homogeneous-box --width 32 --height 32 --iterations 200 -o h.exr -o h.png --stats h.json \
     --csv h.csv --patches h-patches.csv --ply h.ply 2>err.txt; then
  ok=1
  for f in h.exr h.png h.json h.csv h-patches.csv h.ply; do [ -s "$f" ] || { fail "good run: $f missing"; ok=0; }; done
  [ "$(head -1 h-patches.csv)" = "id,cx,cy,cz,nx,ny,nz,area,r,g,b" ] || { fail "patch CSV header"; ok=0; }
  [ "$(head -1 h.csv)" = "iteration,seconds,relative_l1_error,mean_radiance,estimated_error,round,image_estimated_error,image_relative_l1,image_mse,image_block4_relative_l1,image_worst_block16" ] || { fail "convergence CSV header"; ok=0; }
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
if "$bin" solve --builtin homogeneous-box --width 32 --height 32 --patch-size 0.34 --no-diffuse-shot --method combined --depth 3 --sampler sobol \
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

# check STATUS MESSAGE: count a check (STATUS first: it is expanded before any $(...)
# in the message runs).

# --version and help.
"$bin" --version >v.txt 2>err.txt
check $(( $? != 0 )) "--version: $(cat v.txt err.txt)"
grep -qE "^raybundle [0-9]+\.[0-9]+\.[0-9]+$" v.txt && grep -q "^compiler" v.txt && grep -q "^backends .*exact-painter" v.txt
check $? "--version lacks version, compiler or backends: $(cat v.txt)"
"$bin" help >h.txt 2>&1 && grep -q "solve" h.txt && grep -q "check" h.txt && "$bin" help solve >hs.txt && grep -q -- "--width" hs.txt
check $? "help: $(head -3 h.txt)"
"$bin" help nosuch >/dev/null 2>err.txt
check $(( $? != 2 )) "help nosuch should exit 2"

# Nothing is written that was not asked for.
rm -rf quiet && mkdir quiet && (cd quiet && "$bin" solve ../good.json --iterations 10 >/dev/null 2>&1)
check $(( $? != 0 || $(ls -A quiet | wc -l) != 0 )) "a run without outputs wrote: $(ls quiet)"

# The format follows the extension; missing output directories are made; --width/--height.
if "$bin" solve good.json --iterations 10 --width 64 --height 32 -o fmt/a/x.png -o fmt/b/x.exr -o fmt/x.pfm \
     --stats fmt/s/s.json --csv fmt/c/c.csv --patches fmt/p/p.csv --ply fmt/y/p.ply 2>err.txt >/dev/null; then
  [ "$(head -c 8 fmt/a/x.png | od -An -tx1 | tr -d ' \n')" = "89504e470d0a1a0a" ]
  check $? "-o x.png is not a PNG"
  [ "$(head -c 4 fmt/b/x.exr | od -An -tx1 | tr -d ' \n')" = "762f3101" ]
  check $? "-o x.exr is not an EXR"
  [ "$(head -2 fmt/x.pfm | tr '\n' ' ')" = "PF 64 32 " ]
  check $? "-o x.pfm is not a 64 x 32 PFM: $(head -2 fmt/x.pfm | tr '\n' ' ')"
  grep -q '"width": 64' fmt/s/s.json && grep -q '"height": 32' fmt/s/s.json
  check $? "--width/--height not in the stats"
  for f in fmt/c/c.csv fmt/p/p.csv fmt/y/p.ply; do [ -s "$f" ] || fail "$f missing"; done
else
  fail "formats run: $(cat err.txt)"
fi
# --aov makes its directory.
"$bin" solve --builtin cornell-box --patch-size 200 --iterations 10 --width 32 --height 32 --gather 2 \
  --aov made/aov >/dev/null 2>err.txt && [ -s made/aov/direct.exr ]
check $? "--aov into a missing directory: $(cat err.txt)"

# -D and the shortcuts are validated like the file, and change what they name.
"$bin" solve --builtin cornell-box --width 32 --height 32 --iterations 5 -D patch_size=200 --stats d1.json >/dev/null 2>&1 &&
  "$bin" solve --builtin cornell-box --width 32 --height 32 --iterations 5 --stats d2.json >/dev/null 2>&1
p1=$(grep -o '"patches": [0-9]*' d1.json | grep -o '[0-9]*$')
p2=$(grep -o '"patches": [0-9]*' d2.json | grep -o '[0-9]*$')
[ -n "$p1" ] && [ -n "$p2" ] && [ "$p1" -lt "$p2" ]
check $? "-D patch_size=200 should give fewer patches ($p1) than the default ($p2)"
"$bin" solve good.json --iterations 5 --width 16 --height 16 --fov 20 -o fov20.pfm >/dev/null 2>&1 &&
  "$bin" solve good.json --iterations 5 -D camera.width=16 -D camera.height=16 -D camera.fov_y=60 -o fov60.pfm >/dev/null 2>&1 &&
  ! cmp -s fov20.pfm fov60.pfm
check $? "--fov should change the image"

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
  script -qc "stty cols 50 2>/dev/null; '$bin' solve --builtin cornell-box --patch-size 60 --iterations 4000 --diffuse-shot \
    --gather 4 --width 96 --height 96 -o bar.exr 2>&1 >/dev/null" /dev/null | tr '\r' '\n' | sed 's/[[:space:]]*$//' \
    | grep -v '^$' > bar.txt
  ok=0
  for phase in "diffuse shot" solve "final gather" filter; do grep -q "^$phase " bar.txt || { fail "progress bar lacks $phase"; ok=1; }; done
  grep -q "s left" bar.txt || { fail "progress bar lacks the time left"; ok=1; }
  long=$(awk 'length($0) >= 50' bar.txt | wc -l)
  [ "$long" -eq 0 ] || { fail "progress bar wider than 49 columns: $(awk 'length($0) >= 50' bar.txt | head -1)"; ok=1; }
  check $ok "progress bar"
else
  skip "progress bar: no script(1) to give the run a terminal (Debian: bsdutils)"
fi
script -qc "'$bin' solve --builtin cornell-box --patch-size 100 --iterations 200 --quiet -o q.exr" /dev/null > q.txt 2>&1
check $(( $(wc -c <q.txt) != 0 )) "--quiet printed: $(head -c 200 q.txt)"
"$bin" solve --builtin cornell-box --width 32 --height 32 --patch-size 100 --iterations 20 -o s.exr >sum.txt 2>/dev/null
[ "$(wc -l <sum.txt)" -eq 1 ] && grep -q "cornell-box: .* patches, iteration 20 steps in .*; wrote s.exr" sum.txt
check $? "summary line: $(cat sum.txt)"

# raybundle check: what the scene holds, and the signs of inverted winding.
"$bin" check --builtin cornell-box >chk.txt 2>err.txt
rc=$?
[ "$rc" -eq 0 ] && grep -q "^patches .*after refinement" chk.txt && grep -q "^lights .*emissive patches" chk.txt \
  && grep -q "^bounds" chk.txt && grep -q "^unseen .*0 patches" chk.txt && grep -q "face the camera" chk.txt
check $? "check cornell-box: $(cat chk.txt err.txt | head -5)"
lamp='{"quad": [[0,1,0], [1,1,0], [1,1,1], [0,1,1]], "material": "lamp"}'
floor='{"quad": [[0,0,0], [1,0,0], [1,0,1], [0,0,1]], "material": "MAT", "name": "floor"}'
twocam='"camera": {"eye": [0.5, 0.5, 3], "target": [0.5, 0.5, 0.5]}'
for mat in paint plaster; do
  printf '{%s, "materials": {"lamp": {"albedo": [0, 0, 0], "emission": [1, 1, 1]}, "paint": {"albedo": [0.5, 0.5, 0.5]}, "plaster": {"albedo": [0.5, 0.5, 0.5], "two_sided": true}}, "objects": [%s, %s]}\n' \
    "$twocam" "$lamp" "${floor/MAT/$mat}" > "floor-$mat.json"
done
"$bin" check floor-paint.json >chk.txt 2>&1
grep -q "^unseen .*[1-9][0-9]* patches" chk.txt && grep -q "floor: the camera sees its back side in 100 %" chk.txt
check $? "check of an inverted floor: $(cat chk.txt)"
"$bin" solve floor-paint.json --iterations 200 --patches fp.csv >/dev/null 2>err.txt
[ "$(wc -l <err.txt)" -eq 1 ] && grep -q "warning: floor-paint.json: floor: the camera sees its back side in 100 %" err.txt
check $? "facing warning: $(cat err.txt)"
"$bin" solve floor-plaster.json --iterations 200 --patches fs.csv >/dev/null 2>err.txt
[ ! -s err.txt ]
check $? "a two_sided floor was warned about: $(cat err.txt)"
# A panel behind the camera facing away from everything: its front faces nothing.
scene "$quad, {\"quad\": [[0,0,5], [1,0,5], [1,1,5], [0,1,5]], \"material\": \"w\", \"name\": \"panel\"}" > away.json
"$bin" check away.json >chk.txt 2>&1
grep -q "warning     panel: the front side of 100 % of its area faces nothing" chk.txt && ! grep -q "objects\[0\].*warning" chk.txt
check $? "check of a panel facing nothing: $(cat chk.txt)"
# A closed mesh turned inside out: the camera sees its back side.
printf 'v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\nf 2 3 4 1\nf 8 7 6 5\nf 5 6 2 1\nf 3 7 8 4\nf 4 8 5 1\nf 6 7 3 2\n' > inside-out.obj
printf '{"camera": {"eye": [2.5, 2, 3.5], "target": [0.5, 0.5, 0.5]}, %s, "objects": [{"mesh": "inside-out.obj", "material": "w", "name": "cube"}]}\n' "$materials" > inside-out.json
"$bin" check inside-out.json >chk.txt 2>&1
grep -q "warning     cube: the camera sees its back side in 100 % of the pixels that show it" chk.txt
check $? "check of an inside-out cube: $(cat chk.txt)"
# Floor patches (cy = 0): dark one-sided, lit two-sided (its front-facing twin).
lit() { awk -F, 'NR > 1 && $3 == 0 && $9 > m { m = $9 } END { print (m > 0.05) ? "lit" : "dark" }' "$1"; }
[ "$(lit fp.csv)" = dark ] && [ "$(lit fs.csv)" = lit ]
check $? "two_sided: one-sided floor $(lit fp.csv), two-sided $(lit fs.csv)"

# The example scenes: each checks without a warning and solves; the scene-format
# document's example is scenes/examples/minimal.json, word for word.
for example in "$src"/scenes/examples/*.json; do
  name=$(basename "$example")
  "$bin" check "$example" >chk.txt 2>&1 && ! grep -q warning chk.txt
  check $? "check $name: $(grep warning chk.txt | head -2)"
  "$bin" solve "$example" --iterations 20 --width 48 --height 32 --gather 2 -o "ex-$name.png" >sum.txt 2>err.txt \
    && [ ! -s err.txt ] && grep -qE "mean radiance 0*[.]?[0-9]*[1-9]" sum.txt && [ -s "ex-$name.png" ]
  check $? "solve $name: $(cat err.txt sum.txt)"
done
awk '/^```json$/ { on = 1; next } /^```$/ { if (on) exit } on' "$src/docs/scene-format.md" > doc-example.json
cmp -s doc-example.json "$src/scenes/examples/minimal.json"
check $? "docs/scene-format.md's example differs from scenes/examples/minimal.json"

# Determinism through the CLI: same seed, byte-identical per-patch output.
run_seed() { "$bin" solve --builtin homogeneous-box --width 32 --height 32 --patch-size 0.34 --iterations 100 --seed "$1" -o "$2.exr" --patches "$2.csv" 2>/dev/null; }
run_seed 9 a
run_seed 9 b
run_seed 10 c
if cmp -s a.csv b.csv && cmp -s a.exr b.exr && ! cmp -s a.csv c.csv; then
  passed=$((passed + 1))
else
  fail "same seed did not give identical output (or another seed did)"
fi

# The reference path tracer: an image and its record, no field; solver flags refused.
"$bin" solve --builtin homogeneous-box --method pathtrace --spp 16 --width 8 --height 8 -o pt.pfm --stats pt.json -q
check $? "--method pathtrace failed"
grep -q '"method": "pathtrace"' pt.json && grep -q '"spp": 16' pt.json
check $? "--method pathtrace: the stats lack the method or spp: $(head -c 300 pt.json)"
expect_bad "pathtrace with --gather" "--gather does not apply to --method pathtrace" solve --builtin cornell-box --method pathtrace --gather 4
# --reference: the error against an image in the summary and the stats; bad ones refused.
"$bin" solve --builtin homogeneous-box --method pathtrace --spp 4 --width 8 --height 8 -o ref8.exr -q
"$bin" solve --builtin homogeneous-box --method pathtrace --spp 4 --seed 3 --width 8 --height 8 --reference ref8.exr \
  --stats cmp.json >cmp.txt 2>&1
check $? "--reference failed: $(cat cmp.txt)"
grep -q "against the reference: relative L1 .*, 4x4 blocks .*, worst 16x16 block" cmp.txt && grep -q '"relative_l1"' cmp.json &&
  grep -q '"mse"' cmp.json && grep -q '"block4_relative_l1"' cmp.json && grep -q '"worst_block16"' cmp.json
check $? "--reference: no error in the summary or stats: $(cat cmp.txt)"
expect_bad "--reference of another size" "--reference ref8.exr: 8x8 pixels, the image is 16x16" \
  solve --builtin homogeneous-box --width 16 --height 16 --iterations 5 --reference ref8.exr
echo "not an exr" > notexr.exr
expect_bad "--reference not an EXR" "--reference notexr.exr: cannot read EXR" \
  solve --builtin homogeneous-box --width 8 --height 8 --iterations 5 --reference notexr.exr
# The final gather against the path tracer (relative L1 through --reference): two
# lamps of different colours on either side of a wall (each half lit by one colour
# only: one shadow ratio per light), and a floor under a constant sky. Measured 0.056
# and 0.023; a shared ratio or a sky read upside down gave 0.2 and more.
cat >rb.json <<'JSON'
{"camera": {"eye": [278, 700, -300], "target": [278, 0, 280], "fov_y": 50, "width": 32, "height": 32},
 "materials": {"white": {"albedo": [0.7, 0.7, 0.7]}, "black": {"albedo": [0, 0, 0], "two_sided": true},
               "red": {"albedo": [0, 0, 0], "emission": [20, 0, 0]}, "blue": {"albedo": [0, 0, 0], "emission": [0, 0, 20]}},
 "objects": [{"quad": [[0,0,0], [0,0,559], [556,0,559], [556,0,0]], "material": "white", "name": "floor"},
             {"quad": [[50,400,227], [180,400,227], [180,400,332], [50,400,332]], "material": "red", "name": "red"},
             {"quad": [[376,400,227], [506,400,227], [506,400,332], [376,400,332]], "material": "blue", "name": "blue"},
             {"quad": [[278,0,-200], [278,0,800], [278,390,800], [278,390,-200]], "material": "black", "name": "wall"}],
 "patch_size": 100}
JSON
cat >sky.json <<'JSON'
{"camera": {"eye": [0, 100, -500], "target": [0, 0, 0], "fov_y": 60, "width": 16, "height": 16},
 "materials": {"white": {"albedo": [0.5, 0.5, 0.5]}},
 "objects": [{"quad": [[-200,0,-200], [-200,0,200], [200,0,200], [200,0,-200]], "material": "white", "name": "floor"}],
 "sky": {"radiance": [1, 1, 1], "up": [0, 1, 0], "model": "constant"}, "patch_size": 100}
JSON
for sc in rb:0.12 sky:0.08; do
  name=${sc%%:*} limit=${sc##*:}
  "$bin" solve $name.json --method pathtrace --spp 256 -o $name-ref.exr -q 2>/dev/null &&
    "$bin" solve $name.json --iterations 200 --reference $name-ref.exr --stats $name-cmp.json -q 2>/dev/null
  err=$(grep -A8 '"reference"' $name-cmp.json 2>/dev/null | grep -o '"relative_l1": [0-9.e-]*' | awk '{print $2}')
  awk -v e="${err:-1}" -v l="$limit" 'BEGIN { exit !(e < l) }'
  check $? "$name: final gather against the path tracer: relative L1 ${err:-none}, expected below $limit"
done
# Final gather: both direct-light methods, glossy rays, and their need for --gather.
for d in analytic sampled; do
  "$bin" solve --builtin cornell-box --iterations 50 --gather 4 --direct $d --glossy-rays 2 --width 16 --height 16 \
    -o d-$d.pfm --stats d-$d.json -q
  check $? "--direct $d failed"
  grep -q "\"direct\": \"$d\"" d-$d.json
  check $? "--direct $d: not in the stats"
done
"$bin" solve --builtin cornell-box --iterations 50 --gather 4 --spp 4 --emission-samples 0 --width 16 --height 16 \
  --stats em0.json -q && grep -q '"emission_samples": 0' em0.json
check $? "--emission-samples 0: failed or not in the stats"
expect_bad "--emission-samples without --gather" "--emission-samples needs the final gather" \
  solve --builtin cornell-box --gather 0 --emission-samples 8
expect_bad "--emission-samples -1" "--emission-samples" solve --builtin cornell-box --emission-samples -1
expect_bad "--direct without --gather" "--direct needs the final gather" solve --builtin cornell-box --gather 0 --direct sampled
expect_bad "--glossy-rays without --gather" "--glossy-rays needs the final gather" solve --builtin cornell-box --gather 0 --glossy-rays 3
expect_bad "--direct unknown" "--direct" solve --builtin cornell-box --gather 4 --direct exact

# The error estimate on every run, and rounds for a target error or a time budget.
json_number() { grep -o "\"$1\": [0-9.e+-]*" "$2" | head -1 | awk '{print $2}'; }
# --filter-radius: 0 (the default) chooses it from the image and the rays per pass, a
# number sets it; --direct-samples; both in the stats, and refused out of range.
"$bin" solve --builtin cornell-box --patch-size 100 --iterations 50 --width 64 --height 64 --gather 8 --spp 2 \
  --stats fr-auto.json -q &&
  "$bin" solve --builtin cornell-box --patch-size 100 --iterations 50 --width 64 --height 64 --gather 8 --spp 2 \
    --filter-radius 5 --direct-samples 3 --stats fr-5.json -q
check $? "--filter-radius / --direct-samples runs failed"
r_auto=$(json_number filter_radius fr-auto.json)
[ "$(json_number filter_radius fr-5.json)" = 5 ] && [ "$(json_number direct_samples fr-5.json)" = 3 ] &&
  [ -n "$r_auto" ] && [ "$r_auto" -ge 1 ]
check $? "--filter-radius 5 --direct-samples 3 not in the stats, or the automatic radius not >= 1 ($r_auto)"
expect_bad "--filter-radius out of range" "--filter-radius" solve good.json --gather 4 --filter-radius 2000
expect_bad "--direct-samples out of range" "--direct-samples" solve good.json --gather 4 --direct-samples -1
"$bin" solve --builtin homogeneous-box --width 16 --height 16 --iterations 100 --gather 8 --spp 4 --stats est.json \
  --csv est.csv >est.txt 2>&1
check $? "estimate run failed: $(cat est.txt)"
grep -q "estimated error [0-9.]* % (1 round)" est.txt
check $? "summary line lacks the estimated error: $(cat est.txt)"
grep -q '"stopped": "one round: the budget as given"' est.json && grep -q '"field_estimated_error"' est.json
check $? "stats lack the estimate: $(head -c 400 est.json)"
awk -F, '$6 == 1 && $7 != "" { found = 1 } END { exit !found }' est.csv
check $? "convergence CSV has no row for the round with the image's estimate: $(tail -2 est.csv)"
awk -F, 'NR > 1 && $6 == "" && $5 != "" { found = 1 } END { exit !found }' est.csv
check $? "convergence CSV has no solve rows with the field's estimate: $(head -3 est.csv)"
"$bin" solve --builtin homogeneous-box --width 16 --height 16 --iterations 100 --gather 8 --spp 4 --target-error 0.003 \
  --stats target.json >target.txt 2>&1
check $? "--target-error failed: $(cat target.txt)"
e=$(json_number image_estimated_error target.json)
grep -q '"stopped": "the estimate reached the target"' target.json && awk -v e="${e:-1}" 'BEGIN { exit !(e <= 0.003) }' &&
  [ "$(grep -c '"scale"' target.json)" -ge 3 ]
check $? "--target-error 0.003: estimate ${e:-none}, or not reached in rounds: $(grep -A2 stopped target.json)"
"$bin" solve --builtin homogeneous-box --width 8 --height 8 --iterations 20 --gather 4 --spp 1 --time-budget 1 \
  --stats budget.json -q
check $? "--time-budget failed"
grep -q '"stopped": "the time budget"' budget.json && [ "$(grep -c '"scale"' budget.json)" -ge 3 ]
check $? "--time-budget 1: not stopped by the budget after several rounds: $(grep -A2 stopped budget.json)"
"$bin" solve --builtin homogeneous-box --method pathtrace --spp 8 --width 8 --height 8 --target-error 0.01 \
  --stats pt-target.json --csv pt-target.csv -q
check $? "pathtrace with --target-error failed"
grep -q '"stopped": "the estimate reached the target"' pt-target.json && [ "$(wc -l <pt-target.csv)" -ge 3 ]
check $? "pathtrace --target-error: not reached in rounds, or no CSV rows: $(grep stopped pt-target.json)"
for v in 0 -0.1 1.5 nan inf abc; do
  expect_bad "--target-error $v" "--target-error" solve --builtin homogeneous-box --target-error "$v"
done
for v in 0 -1 inf nan; do
  expect_bad "--time-budget $v" "--time-budget" solve --builtin homogeneous-box --time-budget "$v"
done
# A budget the scene's preparation takes whole: one round all the same, said in a
# warning; the run counts from its start (the stats' seconds within 1.15 S + 0.5).
"$bin" solve --builtin homogeneous-box --width 8 --height 8 --iterations 20 --gather 4 --time-budget 0.000001 \
  -o tiny-budget.exr --stats tiny-budget.json -q 2>tiny-budget.txt
check $? "--time-budget 1e-6 failed: $(cat tiny-budget.txt)"
grep -q "preparing the scene took .* nothing is left for the image; one first round runs" tiny-budget.txt &&
  [ -s tiny-budget.exr ] && [ "$(grep -c '"scale"' tiny-budget.json)" -eq 2 ]
check $? "--time-budget 1e-6: no warning, no image or not one round: $(cat tiny-budget.txt)"
# The budget kept: the command's wall time within 1.15 S + 0.5 s.
t0=$(date +%s.%N)
"$bin" solve --builtin homogeneous-box --width 16 --height 16 --iterations 20 --gather 4 --time-budget 2 \
  -o kept.exr -q
t=$(awk -v a="$t0" -v b="$(date +%s.%N)" 'BEGIN { print b - a }')
awk -v t="$t" 'BEGIN { exit !(t <= 1.15 * 2 + 0.5) }'
check $? "--time-budget 2: the command took $t s"
# The field as a control variate: on, in the stats; a probability, else refused.
"$bin" solve --builtin homogeneous-box --width 8 --height 8 --iterations 20 --gather 16 --correction 0.5 \
  --stats corrected.json -q
check $? "--correction 0.5 failed"
grep -q '"correction": 0.5' corrected.json
check $? "--correction 0.5: not in the stats' final_gather"
for v in -0.1 1.5 nan abc; do
  expect_bad "--correction $v" "--correction" solve --builtin homogeneous-box --correction "$v"
done
expect_bad "--csv-every with pathtrace" "--csv-every does not apply to --method pathtrace" \
  solve --builtin homogeneous-box --method pathtrace --csv-every 5

# Checkpoints and signals (apps/checkpoint.h, apps/signals.h): a run killed with
# SIGKILL once its first checkpoint is written, then resumed, writes byte-identical
# outputs to an uninterrupted run; SIGINT writes the outputs of the steps done, marked
# partial, exits 130 and leaves a checkpoint that resumes to the same result again.
ck_base=(solve --builtin cornell-box --gather 0 --width 32 --height 32 --iterations 20000 -q)
ck=("${ck_base[@]}" --patch-size 150 --seed 5)
"$bin" "${ck[@]}" -o ck-full.exr --patches ck-full.csv
check $? "checkpoint: the uninterrupted run failed"
# Starts a run in the background, waits for its first checkpoint, sends the signal;
# the run's exit code in $rc.
interrupt() {
  local sig=$1 file=$2
  shift 2
  # A background job of a script starts with SIGINT ignored, which raybundle respects
  # (as under nohup): give it the default back.
  env --default-signal=INT "$bin" "${ck[@]}" --checkpoint "$file" --checkpoint-every 1000 "$@" 2>signal-err.txt &
  local pid=$!
  for _ in $(seq 1 1200); do [ -f "$file" ] && break; sleep 0.05; done
  kill "-$sig" "$pid"
  wait "$pid"
  rc=$?
}
interrupt KILL ck-kill.bin -o ck-kill.exr
[ "$rc" -eq 137 ] && [ ! -e ck-kill.exr ]
check $? "checkpoint: the run was not killed part-way (exit $rc), or wrote its image"
"$bin" "${ck[@]}" --resume ck-kill.bin -o ck-kill.exr --patches ck-kill.csv --stats ck-kill.json
check $? "--resume after SIGKILL failed"
cmp -s ck-full.exr ck-kill.exr && cmp -s ck-full.csv ck-kill.csv && grep -q '"resumed"' ck-kill.json
check $? "killed and resumed: outputs differ from the uninterrupted run's"
interrupt INT ck-int.bin -o ck-int.exr --stats ck-int.json
[ "$rc" -eq 130 ] && [ -s ck-int.exr ] && grep -q '"partial": true' ck-int.json &&
  grep -q '"interrupted_by": "SIGINT"' ck-int.json && grep -q "stopped after" signal-err.txt &&
  [ "$(ls -a | grep -c -e '^\.raybundle-' -e 'partial-')" -eq 0 ]
check $? "SIGINT: exit $rc, or no partial image and stats, or temporaries left: $(cat signal-err.txt)"
"$bin" "${ck[@]}" --resume ck-int.bin --checkpoint ck-int.bin -o ck-int.exr --patches ck-int.csv --threads 1
check $? "--resume after SIGINT failed"
cmp -s ck-full.exr ck-int.exr && cmp -s ck-full.csv ck-int.csv
check $? "interrupted by SIGINT and resumed (on one thread): outputs differ from the uninterrupted run's"
interrupt TERM ck-term.bin -o ck-term.exr --stats ck-term.json
[ "$rc" -eq 143 ] && [ -s ck-term.exr ] && grep -q '"interrupted_by": "SIGTERM"' ck-term.json
check $? "SIGTERM: exit $rc (143 expected), or no partial image: $(cat signal-err.txt)"
# A signal the run was started ignoring stays ignored (nohup: SIGHUP).
nohup "$bin" "${ck[@]}" -o ck-hup.exr >/dev/null 2>&1 &
pid=$!
sleep 0.5
kill -HUP "$pid"
wait "$pid"
rc=$?
[ "$rc" -eq 0 ] && cmp -s ck-full.exr ck-hup.exr
check $? "SIGHUP under nohup: exit $rc, or the run did not complete"
# The same scene given by another path resumes: ./s.json is s.json.
scene "$quad" > same.json
"$bin" solve same.json --gather 0 --iterations 100 --checkpoint same.bin --checkpoint-every 20 -q &&
  "$bin" solve ./same.json --gather 0 --iterations 100 --resume same.bin -q
check $? "--resume with the scene named ./same.json refused"
# The same run by other spellings: -D's assignments in another order, numbers spelt
# otherwise (02000, 0.50).
"$bin" solve same.json --gather 0 --iterations 2000 -D camera.width=16 -D camera.height=8 -D patch_size=0.5 \
  --checkpoint spelt.bin --checkpoint-every 400 -q &&
  "$bin" solve same.json --gather 0 --iterations 02000 -D patch_size=0.50 -D camera.height=8 -D camera.width=16 \
    --resume spelt.bin -q 2>err.txt
check $? "--resume with -D in another order and numbers spelt otherwise refused: $(cat err.txt)"
expect_bad "--resume with a -D value changed" "the scene differs" solve same.json --gather 0 --iterations 2000 -D camera.width=16 \
  -D camera.height=9 -D patch_size=0.5 --resume spelt.bin
head -c 2000 ck-kill.bin >ck-cut.bin
expect_bad "--resume of a cut checkpoint" "--resume ck-cut.bin: its checksum does not match" "${ck[@]}" --resume ck-cut.bin
expect_bad "--resume of an image" "--resume ck-full.exr: not a raybundle checkpoint" "${ck[@]}" --resume ck-full.exr
expect_bad "--resume of a missing file" "--resume missing.bin" "${ck[@]}" --resume missing.bin
expect_bad "--resume with another seed" "--seed was 5, now 6" "${ck_base[@]}" --patch-size 150 --seed 6 --resume ck-kill.bin
expect_bad "--resume with another option" "--ambient true is given now, not then" "${ck[@]}" --ambient --resume ck-kill.bin
scene "$quad" > edited.json
"$bin" solve edited.json --gather 0 --iterations 100 --checkpoint edited.bin --checkpoint-every 20 -q
sed -i 's/0.5, 0.5, 0.5/0.5, 0.5, 0.6/' edited.json
expect_bad "--resume of an edited scene" "the scene differs" solve edited.json --gather 0 --iterations 100 --resume edited.bin
expect_bad "--checkpoint with a target" "--checkpoint works for runs of one round: not with --target-error" \
  "${ck[@]}" --checkpoint c.bin --target-error 0.01
"$bin" solve --builtin homogeneous-box --method pathtrace --resume ck-kill.bin -o pt.exr 2>err.txt
[ $? -eq 2 ] && grep -q -- "--resume does not apply to --method pathtrace" err.txt && [ ! -e pt.exr ]
check $? "--resume with pathtrace: $(cat err.txt)"
# Hand-made checkpoints with their checksums recomputed (render/checkpoint.cpp: magic,
# byte order, the JSON header, the chains, FNV-1a of it all): a header value of the
# wrong type or out of range is refused by name, with exit 2 and one line.
forge() {  # IN OUT PYTHON-EXPRESSION-ON-h (the header, a dict)
  python3 - "$1" "$2" "$3" <<'PY'
import json, struct, sys
data = open(sys.argv[1], "rb").read()[:-8]
magic_end = data.index(b"\n") + 1 + 4
n = struct.unpack("<Q", data[magic_end:magic_end + 8])[0]
h = json.loads(data[magic_end + 8:magic_end + 8 + n])
exec(sys.argv[3])
header = json.dumps(h).encode()
out = data[:magic_end] + struct.pack("<Q", len(header)) + header + data[magic_end + 8 + n:]
f = 0xcbf29ce484222325
for b in out:
    f = ((f ^ b) * 0x100000001b3) & 0xFFFFFFFFFFFFFFFF
open(sys.argv[2], "wb").write(out + struct.pack("<Q", f))
PY
}
forge ck-kill.bin ck-same.bin "pass"
"$bin" "${ck[@]}" --resume ck-same.bin -o ck-same.exr --patches ck-same.csv 2>err.txt && cmp -s ck-same.csv ck-full.csv
check $? "--resume of a checkpoint rewritten as it was: $(cat err.txt)"
forge ck-kill.bin ck-type.bin "h['identity'] = 5"
expect_bad "--resume of an identity of the wrong type" "ck-type.bin: its header is damaged (identity: not an object)" \
  "${ck[@]}" --resume ck-type.bin
forge ck-kill.bin ck-steps.bin "h['steps_done'] = 400.5"
expect_bad "--resume of a fractional step count" "ck-steps.bin: its header is damaged (steps_done" "${ck[@]}" --resume ck-steps.bin
forge ck-kill.bin ck-seconds.bin "h['seconds'] = -1"
expect_bad "--resume of negative seconds" "ck-seconds.bin: its header is damaged (seconds" "${ck[@]}" --resume ck-seconds.bin
forge ck-kill.bin ck-rows.bin "h['rows'] = {}"
expect_bad "--resume of rows that are not a list" "ck-rows.bin: its header is damaged (rows" "${ck[@]}" --resume ck-rows.bin
# A checkpoint larger than half this machine's memory: refused at once, not read (a
# sparse file of 60 % of the memory, its magic line right).
printf 'raybundle checkpoint 2\n' >huge.bin
truncate -s $(($(awk '/MemTotal/ {print $2}' /proc/meminfo) * 1024 * 6 / 10)) huge.bin
expect_bad "--resume of a checkpoint larger than half the memory" "more than half of this machine's memory" \
  "${ck[@]}" --resume huge.bin
rm -f huge.bin
expect_bad "--checkpoint-every alone" "--checkpoint-every needs --checkpoint FILE" "${ck[@]}" --checkpoint-every 10
for v in 0 -3 1.5 abc 0s -2s s; do
  expect_bad "--checkpoint-every $v" "--checkpoint-every" "${ck[@]}" --checkpoint c.bin --checkpoint-every "$v"
done
expect_bad "--checkpoint onto a device" "--checkpoint /dev/null: is a device" "${ck[@]}" --checkpoint /dev/null
expect_bad "--checkpoint onto the scene file" "--checkpoint good.json: is the scene file" \
  solve good.json --checkpoint good.json

# The memory guard: a run that cannot fit is refused before any work (16384^2 pixels,
# 16384^2 global z-buffer maps on 1024 threads: some 16 TB on any machine).
expect_bad "memory guard" "need about" solve --builtin homogeneous-box --width 16384 --height 16384 \
  --visibility global-zbuffer --resolution 16384 --threads 1024

# Inputs are never overwritten (issue 30): a mesh the scene reads, a hard link to the
# scene file; names too long for the file system with a temporary's additions; a -D
# index past any integer. Each refused before any work, one line, exit 2.
mkdir -p ex && cp -r "$src/scenes/examples/minimal.json" "$src/scenes/examples/meshes" ex/
cp ex/meshes/block.obj block-before.obj
"$bin" solve ex/minimal.json --iterations 5 --gather 0 --patches ex/meshes/block.obj -q 2>err.txt
rc=$?
[ "$rc" -eq 2 ] && [ "$(wc -l <err.txt)" -eq 1 ] && grep -q "is a mesh of the scene" err.txt && cmp -s ex/meshes/block.obj block-before.obj
check $? "--patches naming a mesh the scene reads: exit $rc, $(cat err.txt)"
ln ex/minimal.json linked.json 2>/dev/null && {
  "$bin" solve ex/minimal.json --iterations 5 --gather 0 --stats linked.json -q 2>err.txt
  rc=$?
  [ "$rc" -eq 2 ] && grep -q "is the scene file" err.txt && cmp -s linked.json "$src/scenes/examples/minimal.json"
  check $? "--stats naming a hard link of the scene file: exit $rc, $(cat err.txt)"
}
expect_bad "a file name with a newline" 'no\nsuch.json' solve $'no\nsuch.json'
expect_bad "a built-in name with an escape sequence" '\x1b[31mred' solve --builtin $'\e[31mred'
long=$(printf 'x%.0s' $(seq 1 230)).exr
expect_bad "an output name too long with the temporary's additions" "bytes" solve --builtin homogeneous-box --iterations 5 -o "$long"
expect_bad "a --checkpoint name too long with the temporary's additions" "--checkpoint" \
  solve --builtin homogeneous-box --iterations 5 --checkpoint "$(printf 'c%.0s' $(seq 1 250)).bin"
deep=$(printf 'd%.0s' $(seq 1 200))
deep="$deep/$deep/$deep/$deep/$deep/$deep/$deep/$deep/$deep/$deep/$deep/$deep/$deep/$deep/$deep/$deep/$deep/$deep/$deep/$deep/$deep/x.exr"  # 4,226 bytes
expect_bad "an output path too long with the temporary's additions" "a path of" solve --builtin homogeneous-box \
  --iterations 5 -o "$deep"
expect_bad "a -D index past any integer" "malformed index" solve good.json --iterations 5 \
  -D 'camera.eye[99999999999999999999]=1'

# An OBJ with its MTL as it comes (McGuire's Cornell box): a scene alone, its objects
# named by their materials, the light's Ke its emission.
"$bin" check "$src/scenes/examples/CornellBox-Original.obj" >out.txt 2>err.txt
rc=$?
[ "$rc" -eq 0 ] && grep -q "(CornellBox-Original.obj: leftWall)" out.txt && grep -q "(CornellBox-Original.obj: light)" out.txt &&
  grep -q "light (emissive)" out.txt
check $? "check CornellBox-Original.obj: exit $rc, $(cat err.txt) $(head -c 600 out.txt)"
"$bin" solve "$src/scenes/examples/CornellBox-Original.obj" --iterations 200 --gather 0 -D camera.width=32 \
  -D camera.height=32 -q -o obj-box.png 2>err.txt && [ -s obj-box.png ]
check $? "solve CornellBox-Original.obj: $(cat err.txt)"

echo "cli: $passed passed, $failed failed, $skipped skipped"
[ "$failed" -eq 0 ]
