#!/usr/bin/env bash
# End-to-end checks of good runs: every output and nothing else, the documented
# stats and CSV headers, --version and help, formats by extension, -D and the
# shortcuts, raybundle check, the example scenes and an OBJ with its MTL, the same
# seed giving byte-identical results, the path tracer and --reference.
# Usage: test_cli_outputs.sh PATH/TO/raybundle SOURCE_DIR
# shellcheck source=tests/cli/cli_common.sh
source "$(dirname "${BASH_SOURCE[0]}")/cli_common.sh"

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
if "$bin" solve --builtin cornell-box --patch-size 100 --iterations 50 --gather 4 --spp 2 --width 32 --height 32 --aov aov \
     -o g.exr --stats g.json 2>err.txt; then
  ok=1
  for f in g.exr aov/direct.exr aov/indirect.exr aov/indirect-filtered.exr aov/bias.exr aov/normal.exr aov/depth.exr; do
    [ -s "$f" ] || { fail "gather run: $f missing"; ok=0; }
  done
  for key in final_gather gather_rays shadow_rays seconds_filter; do grep -q "\"$key\"" g.json || { fail "gather stats lack $key"; ok=0; }; done
  [ "$ok" -eq 1 ] && passed=$((passed + 1))
else
  fail "gather run failed: $(cat err.txt)"
fi


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
grep -q "^unseen .*[1-9][0-9]* patches" chk.txt && grep -q "floor: the camera sees its back side in 100 %" chk.txt &&
  ! grep -q "outside the scene's bounds" chk.txt  # an open scene: its winding, not the camera's place
check $? "check of an inverted floor: $(cat chk.txt)"
"$bin" solve floor-paint.json --iterations 200 --gather 0 --patches fp.csv >/dev/null 2>err.txt
[ "$(wc -l <err.txt)" -eq 1 ] && grep -q "warning: floor-paint.json: floor: the camera sees its back side in 100 %" err.txt
check $? "facing warning: $(cat err.txt)"
"$bin" solve floor-plaster.json --iterations 200 --gather 0 --patches fs.csv >/dev/null 2>err.txt
[ ! -s err.txt ]
check $? "a two_sided floor was warned about: $(cat err.txt)"
# A panel behind the camera facing away from everything: its front faces nothing.
scene "$quad, {\"quad\": [[0,0,5], [1,0,5], [1,1,5], [0,1,5]], \"material\": \"w\", \"name\": \"panel\"}" > away.json
"$bin" check away.json >chk.txt 2>&1
grep -q "warning     panel: the front side of 100 % of its area faces nothing" chk.txt && ! grep -q "objects\[0\].*warning" chk.txt
check $? "check of a panel facing nothing: $(cat chk.txt)"
# A floor that faces only a point light (the camera sees it edge-on) faces something.
printf '{"camera": {"eye": [0.5, 0, 3], "target": [0.5, 0, 0]}, "materials": {"w": {"albedo": [0.5, 0.5, 0.5]}}, "objects": [{"quad": [[0,0,0], [0,0,1], [1,0,1], [1,0,0]], "material": "w", "name": "floor"}], "point_lights": [{"position": [0.5, 1, 0.5], "intensity": [1, 1, 1]}]}\n' > lamp-floor.json
"$bin" check lamp-floor.json >chk.txt 2>&1
! grep -q "faces nothing" chk.txt && grep -q "^unseen      0 patches" chk.txt
check $? "check of a floor under a point light: $(cat chk.txt)"
# A sun: check shows it and how much it reaches, the solve's stats say the first shot
# took it; under a roof that keeps it out it reaches nothing, which both warn about.
printf '{"camera": {"eye": [0.5, 2, 3], "target": [0.5, 0, 0.5]}, "materials": {"w": {"albedo": [0.5, 0.5, 0.5]}}, "objects": [{"quad": [[0,0,0], [0,0,1], [1,0,1], [1,0,0]], "material": "w", "name": "floor"}], "directional_lights": [{"direction": [0.2, -1, 0.1], "irradiance": [2, 2, 2]}]}\n' > sun-floor.json
"$bin" check sun-floor.json >chk.txt 2>&1 &&
  grep -q "^lights .*0 point lights, 1 directional" chk.txt && grep -q "directional_lights\[0\]: along .*reaches [1-9][0-9]* of" chk.txt &&
  ! grep -q "faces nothing\|reaches no patch\|no light" chk.txt
check $? "check of a floor under a sun: $(cat chk.txt)"
"$bin" solve sun-floor.json --iterations 20 --width 16 --height 16 --stats sun.json -o sun.pfm >/dev/null 2>err.txt &&
  [ ! -s err.txt ] && grep -q '"first_shot": "1 directional light(s), [0-9]* shadow rays' sun.json
check $? "solve of a floor under a sun: $(cat err.txt; grep first_shot sun.json)"
sed -e 's/"name": "floor"}/&, {"quad": [[-1,1,-1], [2,1,-1], [2,1,2], [-1,1,2]], "material": "w", "name": "roof"}/' \
  -e 's/"eye": \[0.5, 2, 3\]/"eye": [0.5, 0.6, 3]/' sun-floor.json > roof.json
sun='directional_lights=[{"direction": [0, -1, 0], "irradiance": [5, 5, 5]}]'
"$bin" check roof.json -D "$sun" >chk.txt 2>&1 &&
  grep -q "^warning     directional_lights\[0\] (travelling along (0, -1, 0)) reaches no patch: every patch facing it is in shadow" chk.txt
check $? "check of a sun over a roof: $(cat chk.txt)"
"$bin" solve roof.json -D "$sun" --iterations 20 --gather 0 -o roof.pfm >/dev/null 2>err.txt &&
  [ "$(wc -l <err.txt)" -eq 1 ] && grep -q "warning: roof.json: directional_lights\[0\] .* reaches no patch" err.txt
check $? "solve of a sun over a roof: $(cat err.txt)"
# A sun travelling up faces no surface's front: said so, not blamed on walls.
"$bin" check sun-floor.json -D 'directional_lights[0].direction=[0, 1, 0]' >chk.txt 2>&1 &&
  grep -q "^warning     directional_lights\[0\] (travelling along (0, 1, 0)) faces no patch's front" chk.txt
check $? "check of a sun from below: $(cat chk.txt)"
# Nothing lights a scene: the black image it gets is said in one warning, by check too.
# A light whose emission is all zero is no light; a zero point light or a black sky
# neither.
printf '{%s, "materials": {"m": {"albedo": [0.5, 0.5, 0.5], "emission": [0, 0, 0]}}, "objects": [%s], "point_lights": [{"position": [0.5, 0.5, 1], "intensity": [0, 0, 0]}], "sky": {"radiance": [0, 0, 0]}}\n' \
  "$camera" "${quad/\"w\"/\"m\"}" > dark.json
"$bin" solve dark.json --iterations 20 --gather 0 -o dark.png >/dev/null 2>err.txt
rc=$?
[ "$rc" -eq 0 ] && [ "$(wc -l <err.txt)" -eq 1 ] && grep -q "warning: dark.json: no light (no emissive patch, point or directional light or sky above zero): the image is black" err.txt
check $? "a scene without light: exit $rc, $(cat err.txt)"
"$bin" check dark.json >chk.txt 2>&1
grep -q "^warning     no light" chk.txt
check $? "check of a scene without light: $(cat chk.txt)"
"$bin" check good.json >chk.txt 2>&1
! grep -q "no light" chk.txt
check $? "a lit scene said to have no light: $(cat chk.txt)"
# A block's bottom lying on the floor faces it from within the contact distance: hidden,
# not inverted (covered, no warning). Lifted 0.1 above the floor, the same bottom sees
# the floor: neither covered nor unseen. (The patches as modelled: refined, the far
# parts of this open floor would see nothing, and count as unseen.)
# (The wall is the light: a light's front lying on a surface is warned about, below.)
lit_materials='"materials": {"w": {"albedo": [0.5, 0.5, 0.5]}, "lamp": {"albedo": [0, 0, 0], "emission": [1, 1, 1]}}'
bottom_at() {  # bottom_at Y: a floor, a wall of the block, and its bottom at height Y
  printf '{"camera": {"eye": [0.5, 1.5, 3], "target": [0.5, 0.3, 0.5]}, "patch_size": "none", %s, "objects": [' "$lit_materials"
  printf '{"quad": [[-1,0,-1], [-1,0,2], [2,0,2], [2,0,-1]], "material": "w", "name": "floor"}, '
  printf '{"quad": [[0,%s,0], [1,%s,0], [1,%s,1], [0,%s,1]], "material": "w", "name": "bottom"}, ' "$1" "$1" "$1" "$1"
  printf '{"quad": [[0,0,1], [1,0,1], [1,1,1], [0,1,1]], "material": "lamp", "name": "wall"}]}\n'
}
bottom_at 0 > on-floor.json
bottom_at 0.1 > above-floor.json
"$bin" check on-floor.json >chk.txt 2>&1
grep -qE "^covered +[1-9][0-9]* patches lie face to face on another surface" chk.txt && grep -q "bottom .*front covered: 100 %" chk.txt &&
  ! grep -q "^warning" chk.txt
check $? "check of a block's bottom on a floor: $(cat chk.txt)"
"$bin" check above-floor.json >chk.txt 2>&1
! grep -q "^covered" chk.txt && ! grep -q "^warning" chk.txt && grep -q "^unseen      0 patches" chk.txt
check $? "check of a bottom 0.1 above a floor: $(cat chk.txt)"
# A closed mesh turned inside out: the camera sees its back side.
printf 'v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\nf 2 3 4 1\nf 8 7 6 5\nf 5 6 2 1\nf 3 7 8 4\nf 4 8 5 1\nf 6 7 3 2\n' > inside-out.obj
printf '{"camera": {"eye": [2.5, 2, 3.5], "target": [0.5, 0.5, 0.5]}, %s, "objects": [{"mesh": "inside-out.obj", "material": "w", "name": "cube"}]}\n' "$materials" > inside-out.json
"$bin" check inside-out.json >chk.txt 2>&1
# A closed shell facing in, seen from outside, is also a room framed from outside: the
# warning says both.
grep -q "warning     cube: the camera sees its back side in 100 % of the pixels that show it (the camera is outside the scene's bounds: a room closed on all sides is seen from outside; -D camera.eye=\[0.5,0.5,0.5\] -D camera.target=\[0.5,0.5,0\] puts it inside" chk.txt &&
  # Following it: the camera inside sees the cube's faces from the front.
  "$bin" check inside-out.json -D "camera.eye=[0.5,0.5,0.5]" -D "camera.target=[0.5,0.5,0]" >chk2.txt 2>&1 &&
  ! grep -q "back side" chk2.txt
check $? "check of an inside-out cube: $(cat chk.txt)"
# The same cube on a wide floor, a lamp above it: closed around the scene's centre too,
# but no room (the floor lies outside it): the warning does not send the eye inside.
printf '{"camera": {"eye": [0.5, 3, 6], "target": [0.5, 0.5, 0.5]}, %s, "objects": [{"mesh": "inside-out.obj", "material": "w", "name": "cube"}, %s, %s]}\n' \
  "$lit_materials" '{"quad": [[-2.5,0,-2.5], [-2.5,0,3.5], [3.5,0,3.5], [3.5,0,-2.5]], "material": "w", "name": "floor"}' \
  '{"quad": [[0,1.5,0], [1,1.5,0], [1,1.5,1], [0,1.5,1]], "material": "lamp", "name": "lamp"}' > ball-on-floor.json
"$bin" check ball-on-floor.json >chk.txt 2>&1
grep -q "warning     cube: the camera sees its back side in 100 % of the pixels that show it (inverted winding?" chk.txt &&
  ! grep -q "room closed on all sides" chk.txt
check $? "check of an inside-out cube on a floor: $(cat chk.txt)"
# The camera inside a closed cube (facing out): it sees the cube's back, and the image is
# black; the warning says where the eye is, not that the winding is wrong.
printf 'v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\nf 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n' > cube.obj
printf '{"camera": {"eye": [0.4, 0.5, 0.6], "target": [0.5, 0.5, 0]}, %s, "objects": [{"mesh": "cube.obj", "material": "w", "name": "cube"}, %s]}\n' \
  "$lit_materials" '{"quad": [[-1,2,-1], [2,2,-1], [2,2,2], [-1,2,2]], "material": "lamp", "name": "lamp"}' > eye-in-cube.json
"$bin" check eye-in-cube.json >chk.txt 2>&1
grep -q "warning     cube: the camera's eye is inside it: all it shows from there is its back side" chk.txt &&
  ! grep -q "cube: the camera sees its back side" chk.txt &&
  "$bin" solve eye-in-cube.json --iterations 20 --width 16 --height 16 -o eye-in-cube.png >sum.txt 2>err.txt &&
  grep -q "the image is black (no lit surface in view)" sum.txt && ! grep -q "estimated error" sum.txt
check $? "the camera inside a cube: $(cat chk.txt sum.txt err.txt | grep -E 'warning|black|error')"
# A lamp just under a ceiling facing up: its light goes into the ceiling.
printf '{"camera": {"eye": [0.5, 0.5, 3], "target": [0.5, 0.5, 0]}, %s, "objects": [%s, %s, %s]}\n' "$lit_materials" \
  '{"quad": [[0,0,0], [0,0,1], [1,0,1], [1,0,0]], "material": "w", "name": "floor"}' \
  '{"quad": [[0,1,0], [1,1,0], [1,1,1], [0,1,1]], "material": "w", "name": "ceiling"}' \
  '{"quad": [[0.4,0.9999,0.6], [0.6,0.9999,0.6], [0.6,0.9999,0.4], [0.4,0.9999,0.4]], "material": "lamp", "name": "panel"}' > lamp-up.json
"$bin" check lamp-up.json >chk.txt 2>&1
grep -q "warning     panel: the emitting front of 100 % of its area lies against 'ceiling', so its light cannot leave" chk.txt
check $? "a lamp facing into the ceiling: $(cat chk.txt | grep -E 'warning|covered')"
# Two-sided, its other side shines down: no warning.
sed 's/"lamp": {"albedo": \[0, 0, 0\], "emission": \[1, 1, 1\]}/"lamp": {"albedo": [0, 0, 0], "emission": [1, 1, 1], "two_sided": true}/' lamp-up.json > lamp-both.json
"$bin" check lamp-both.json >chk.txt 2>&1
grep -q '"two_sided": true' lamp-both.json && ! grep -q "emitting front" chk.txt
check $? "a two-sided lamp under the ceiling was warned about: $(cat chk.txt | grep -E 'warning')"
# Facing down, just above the ceiling (behind its back): its light meets the back; just
# below it, as lamps are placed: no warning.
sed 's/\[\[0.4,0.9999,0.6\], \[0.6,0.9999,0.6\], \[0.6,0.9999,0.4\], \[0.4,0.9999,0.4\]\]/[[0.4,1.0001,0.4], [0.6,1.0001,0.4], [0.6,1.0001,0.6], [0.4,1.0001,0.6]]/' \
  lamp-up.json > lamp-above.json
sed 's/1.0001/0.9999/g' lamp-above.json > lamp-below.json
"$bin" check lamp-above.json >chk.txt 2>&1
grep -q "warning     panel: the emitting front of 100 % of its area lies just behind 'ceiling', facing its back" chk.txt &&
  "$bin" check lamp-below.json >chk2.txt 2>&1 && ! grep -q "emitting front" chk2.txt && grep -q "1.0001" lamp-above.json
check $? "a lamp above the ceiling: $(cat chk.txt chk2.txt | grep -E 'warning')"
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

# --refine G: the run refines by the solution; the stats say so, and the per-patch
# outputs are the refined scene's patches. Bad values and the path tracer are refused.
if "$bin" solve --builtin cornell-box --refine 0.5 --width 16 --height 16 --gather 0 --iterations 20 -o rf.exr \
     --stats rf.json --patches rf-patches.csv -q 2>err.txt; then
  patches=$(python3 -c "import json; print(json.load(open('rf.json'))['patches'])")
  before=$(python3 -c "import json; print(json.load(open('rf.json'))['refinement']['patches_before'])")
  rows=$(($(wc -l < rf-patches.csv) - 1))
  grep -q '"refinement": "by the solution' rf.json && [ "$rows" -eq "$patches" ] && [ "$patches" -gt "$before" ]
  check $? "--refine 0.5: decision, or $rows CSV rows for $patches patches (before: $before)"
else
  fail "--refine 0.5 failed: $(cat err.txt)"
fi
expect_bad "--refine with pathtrace" "--refine does not apply to --method pathtrace" solve --builtin cornell-box --method pathtrace --refine 1
expect_bad "--refine auto" "--refine" solve --builtin cornell-box --refine auto
expect_bad "--refine 0" "--refine" solve --builtin cornell-box --refine 0
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

# An OBJ with its MTL as it comes (McGuire's Cornell box): a scene alone, its objects
# named by their materials, the light's Ke its emission.
"$bin" check "$src/scenes/examples/CornellBox-Original.obj" >out.txt 2>err.txt
rc=$?
[ "$rc" -eq 0 ] && grep -q "^  CornellBox-Original.obj: leftWall " out.txt && grep -q "^  CornellBox-Original.obj: light " out.txt &&
  grep -q "light (emissive)" out.txt &&
  # Each box repeats one face ("bottom face"): the copy is dropped, with a warning.
  [ "$(grep -c "Box: 2 triangles given twice (the same corners, the same way round): the copies dropped" out.txt)" -eq 2 ] &&
  ! grep -q "separate triangles\|overlap" out.txt
check $? "check CornellBox-Original.obj: exit $rc, $(cat err.txt) $(head -c 600 out.txt)"
"$bin" solve "$src/scenes/examples/CornellBox-Original.obj" --iterations 200 --gather 0 -D camera.width=32 \
  -D camera.height=32 -q -o obj-box.png 2>err.txt && [ -s obj-box.png ]
check $? "solve CornellBox-Original.obj: $(cat err.txt)"

# A textured OBJ as Blender writes it (map_Kd beside the MTL, vt per corner), seen from
# under its ceiling: read without a warning, its textures named by check, and the
# floor's checker in the image (a dark and a light square differ by more than twice).
"$bin" check "$src/scenes/examples/textured-room/textured-room.obj" -D 'camera.eye=[0,2.4,0]' \
  -D 'camera.target=[0,0,0]' -D 'camera.up=[0,0,-1]' >out.txt 2>err.txt
rc=$?
[ "$rc" -eq 0 ] && grep -q "(texture checker.png)" out.txt && grep -q "(texture cube.png)" out.txt && ! grep -q "warning" out.txt err.txt
check $? "check textured-room.obj: exit $rc, $(cat err.txt) $(head -c 600 out.txt)"
"$bin" solve "$src/scenes/examples/textured-room/textured-room.obj" --iterations 200 --gather 4 \
  -D 'camera.eye=[0,2.4,0]' -D 'camera.target=[0,0,0]' -D 'camera.up=[0,0,-1]' -D camera.fov_y=40 \
  -D camera.width=64 -D camera.height=64 -q -o floor.pfm 2>err.txt && [ -s floor.pfm ]
check $? "solve textured-room.obj: $(cat err.txt)"
python3 - <<'PY'
import struct, sys
data = open("floor.pfm", "rb").read()
parts = data.split(b"\n", 3)
w, h = map(int, parts[1].split())
pixels = struct.unpack("<%df" % (3 * w * h), parts[3][:12 * w * h])
grey = sorted(sum(pixels[3 * i:3 * i + 3]) for i in range(w * h))
dark, light = grey[len(grey) // 10], grey[9 * len(grey) // 10]
sys.exit(0 if light > 2 * dark > 0 else 1)
PY
check $? "textured-room.obj: the floor's checker is not in the image"

finish cli-outputs
