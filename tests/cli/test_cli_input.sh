#!/usr/bin/env bash
# End-to-end checks of bad input: one line on stderr naming the file, the object
# and the value, exit code 2, and no output file created or truncated (inputs a
# fuzzer found, outputs that collide, a backend whose library is missing, inputs
# never overwritten).
# Usage: test_cli_input.sh PATH/TO/raybundle SOURCE_DIR
# shellcheck source=tests/cli/cli_common.sh
source "$(dirname "${BASH_SOURCE[0]}")/cli_common.sh"

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
expect_bad "a key given twice in a -D value" \
  'good.json: directional_lights[0].direction: key given twice (from -D directional_lights=[{"direction": [0, -1, 0], "direction"' \
  solve good.json -D 'directional_lights=[{"direction": [0, -1, 0], "direction": [0, 1, 0], "irradiance": [1, 1, 1]}]' 
expect_bad "--ambient with walks" "--ambient: applies to stochastic iteration with the constant basis" \
  solve good.json --method walk --ambient
expect_bad "--ambient with pathtrace" "ambient does not apply to --method pathtrace" \
  solve good.json --method pathtrace --ambient
# The ambient control variate: off by default, on with --ambient, in the stats either way.
"$bin" solve --builtin homogeneous-box --iterations 50 --gather 0 --ambient --stats amb-on.json -q &&
  "$bin" solve --builtin homogeneous-box --iterations 50 --gather 0 --stats amb-off.json -q &&
  grep -q '"ambient": "on: each diffuse patch' amb-on.json && grep -q '"ambient": "off' amb-off.json
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
expect_bad "scene and built-in" "exactly one of SCENE.json or --builtin NAME (given: good.json and --builtin homogeneous-box)" \
  solve good.json --builtin homogeneous-box
# -D and -o take one value a use: a scene after them is the scene, not a second value.
"$bin" check -D patch_size=1 good.json >out.txt 2>err.txt
check $? "check -D before the scene: $(cat err.txt)"
rm -f first.png
"$bin" solve -o first.png good.json --iterations 10 --gather 0 -q 2>err.txt && [ -s first.png ]
check $? "solve -o before the scene: $(cat err.txt)"
# Arguments no option takes: the first named, an unknown option with the nearest one.
expect_bad "a misspelt option" "raybundle solve: unknown option --iteration (did you mean --iterations?)" \
  solve good.json --iteration 100
expect_bad "a misspelt option with its value" "unknown option --gathr=4 (did you mean --gather?)" solve good.json --gathr=4
expect_bad "two scenes" "raybundle solve: unexpected argument 'good2.json'" solve good.json good2.json
expect_bad "an option before the command" "--threads: options go after the command (raybundle solve ... --threads ...)" \
  --threads 1 solve good.json
expect_bad "an option given twice" "raybundle solve: --gather given 2 times (0, 1): give it once" \
  solve good.json --gather 0 --gather 1
expect_bad "an option given twice, once with =" "raybundle solve: --patch-size given 2 times (1, 2): give it once" \
  solve good.json --patch-size 1 --patch-size=2
expect_bad "an unknown command" "unknown command 'version' (commands: solve, check" version
expect_bad "an unknown command's help" "unknown command 'render' (commands: solve, check" render --help
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
for v in 0 16385 -4; do
  expect_bad "--width $v" "--width: Value $v not in range 1 to 16384" solve good.json --width "$v"
done
for v in 1.5 100.5 wide; do
  expect_bad "--width $v" "--width: '$v' is not an integer" solve good.json --width "$v"
done
expect_bad "--iterations 1e3" "--iterations: '1e3' is not an integer" solve good.json --iterations 1e3
printf '{%s, %s, "objects": [%s], "point_lights": [{"position": [0.5, 0.5, 1], "intensity": [1, 1, 1]}]}\n' \
  "$camera" "$materials" "$quad" >lit.json
expect_bad "NaN light intensity (-D)" "point_lights[0].intensity: expected [x, y, z], got [\"nan\",1,1] (from -D" \
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
# /proc: its permissions refuse a user; root passes them, and a file made there fails.
if [ "$(id -u)" -eq 0 ]; then proc_refusal="cannot create a file in /proc"; else proc_refusal="cannot write in /proc"; fi
for case in "-o same.exr -o same.exr|-o same.exr and -o same.exr name the same file" \
            "-o same.exr --stats same.exr|-o same.exr and --stats same.exr name the same file" \
            "-o ./d/same.exr -o d/../d/same.exr|-o ./d/same.exr and -o d/../d/same.exr name the same file" \
            "--gather 4 --aov d -o d/direct.exr|-o d/direct.exr and --aov d/direct.exr name the same file" \
            "--stats adir|--stats adir: is a directory" \
            "--stats /dev/null|--stats /dev/null: is a device, a FIFO or a socket, not a file" \
            "-o fifo.exr|-o fifo.exr: is a device, a FIFO or a socket" \
            "-o ro.exr|-o ro.exr: is read-only" \
            "-o afile/x.exr|-o afile/x.exr: Not a directory" \
            "-o /proc/raybundle-x.exr|-o /proc/raybundle-x.exr: $proc_refusal" \
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
expect_bad "unknown image format" "-o x.jpg: unknown image format 'jpg' (known: .exr, .png, .pfm; or .glb, a baked asset)" \
  solve good.json -o x.jpg
expect_bad "an output naming a folder" "-o out/: names a folder, not a file (e.g. out/image.exr)" solve good.json -o out/
expect_bad "bad define" "-D camera.width: expected key=value" solve good.json -D camera.width
expect_bad "define of an unknown key" "unknown key 'patchsize'" solve good.json -D patchsize=3
expect_bad "define of an unknown key named" "(from -D patchsize=3)" solve good.json -D patchsize=3
expect_bad "define of a bad value" "camera.fov_y: must be in (0, 180) degrees, got 200 (from -D camera.fov_y=200)" \
  solve good.json -D camera.fov_y=200
expect_bad "define of a non-number" "camera.width" solve good.json -D camera.width=wide
expect_bad "define of a non-number named" "(from -D camera.width=wide)" solve good.json -D camera.width=wide
expect_bad "define of a number no double holds" "camera.eye: number overflow parsing '1e400' (from -D camera.eye=[0,1e400,0])" \
  solve good.json -D "camera.eye=[0,1e400,0]"
expect_bad "bad fov flag" "--fov" solve good.json --fov -3
expect_bad "width 0" "--width" solve good.json --width 0
scene "$quad" ', "sky": {"radiance": [1, 1, 1], "model": "clear"}' > sky.json
expect_bad "unknown sky model" "sky.model: unknown sky model 'clear'" solve sky.json
# Coplanar overlapping patches facing the same way: a warning line with the count, and
# the run goes on (the stats record the count). (Which of the two shows is arbitrary:
# the higher patch index; a second line may warn that the other faces nothing.)
scene "$quad, {\"quad\": [[0.2,0.2,0], [0.6,0.2,0], [0.6,0.6,0], [0.2,0.6,0]], \"material\": \"w\", \"name\": \"rug\"}" > overlap.json
"$bin" solve overlap.json --iterations 20 -o overlap.exr --stats overlap-stats.json >out.txt 2>err.txt
rc=$?
if [ "$rc" -eq 0 ] && [ "$(grep -c "coplanar overlapping" err.txt)" -eq 1 ] \
   && grep -qE "warning: overlap.json: [0-9]+ pairs of coplanar overlapping patches face the same way \(e.g. 'rug' \(patch [0-9]+\) and 'objects\[0\] \(quad\)' \(patch [0-9]+\)\)" err.txt \
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

finish cli-input
