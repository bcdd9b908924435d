#!/usr/bin/env bash
# glTF in and out (issue 28): the three example assets of scenes/examples/gltf/ pass
# the Khronos glTF validator and solve; `-o lit.glb` writes a baked asset that passes
# it with 0 errors, whose vertex colours are the radiance --ply writes (COLOR_0 after
# the exposure, _RADIANCE as it is); a malformed glTF ends in one line, exit 2, and
# writes nothing.
# Usage: test_glb.sh PATH/TO/raybundle SOURCE_DIR
# The validator is npm's gltf-validator, which scripts/setup-deps.sh --tests installs
# in SOURCE_DIR/.deps/node; without it (or node) this test fails.
set -uo pipefail
bin=$1
src=$2
validator=$src/.deps/node/node_modules
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work" || exit 1
failed=0
fail() { echo "FAIL: $*"; failed=$((failed + 1)); }

if ! command -v node >/dev/null || [ ! -d "$validator/gltf-validator" ]; then
  echo "FAIL: node or npm's gltf-validator is missing (run scripts/setup-deps.sh --tests)"
  exit 1
fi

# The example assets, as Blender's exporter wrote them, are valid glTF.
node "$src/tests/cli/validate_gltf.js" "$validator" "$src"/scenes/examples/gltf/*.glb "$src"/scenes/examples/gltf/*.gltf \
  || fail "an example asset does not validate"

# Each solves and renders (small and short: what is checked is that they load and run).
for asset in cornell-box.glb lamp-room.gltf suzanne.glb textured-room.glb painted-room.glb; do
  if ! "$bin" solve "$src/scenes/examples/gltf/$asset" --patch-size 0.25 --iterations 100 --width 48 --height 48 \
       -o "${asset%%.*}.png" -q 2>err.txt; then
    fail "$asset does not solve: $(cat err.txt)"
  fi
  [ -s "${asset%%.*}.png" ] || fail "$asset: no image"
done

# The baked asset: valid (0 errors, 0 warnings), its vertices the PLY's, its colours
# the PLY's radiance.
if "$bin" solve "$src/scenes/examples/gltf/cornell-box.glb" --patch-size 0.2 --iterations 200 --width 32 --height 32 \
     --exposure -1 -o lit.glb --ply lit.ply -q 2>err.txt; then
  node "$src/tests/cli/validate_gltf.js" "$validator" lit.glb || fail "the baked lit.glb does not validate"
  python3 - <<'PY' || fail "the baked colours are not the PLY's radiance"
import json, struct, sys
glb = open("lit.glb", "rb").read()
n_json = struct.unpack_from("<I", glb, 12)[0]
doc = json.loads(glb[20:20 + n_json])
bin_start = 20 + n_json + 8
exposure = doc["asset"]["extras"]["exposure"]
attrs = doc["meshes"][0]["primitives"][0]["attributes"]
def floats(name):
    acc = doc["accessors"][attrs[name]]
    view = doc["bufferViews"][acc["bufferView"]]
    start = bin_start + view.get("byteOffset", 0) + acc.get("byteOffset", 0)
    return struct.unpack_from("<%df" % (3 * acc["count"]), glb, start)
colour, radiance = floats("COLOR_0"), floats("_RADIANCE")
ply = open("lit.ply", "rb").read()
header_end = ply.index(b"end_header\n") + len(b"end_header\n")
header = ply[:header_end].decode()
vertices = int(header.split("element vertex ")[1].split()[0])
faces = int(header.split("element face ")[1].split()[0])
if 3 * faces != len(radiance) // 3:
    sys.exit("%d PLY faces, %d glb vertices" % (faces, len(radiance) // 3))
positions = floats("POSITION")
ply_positions = struct.unpack_from("<%df" % (3 * vertices), ply, header_end)
if positions != ply_positions:
    sys.exit("POSITION differs from the PLY's vertices")
offset = header_end + 12 * vertices
worst = 0.0
for f in range(faces):
    # uchar 3, 3 ints, 3 uchar colours, 3 float radiance
    r = struct.unpack_from("<3f", ply, offset + 1 + 12 + 3)
    offset += 1 + 12 + 3 + 12
    for k in range(3):
        for c in range(3):
            v = 3 * (3 * f + k) + c
            if radiance[v] != r[c]:
                sys.exit("patch %d: _RADIANCE %r, PLY %r" % (f, radiance[v], r[c]))
            want = min(1.0, 2.0 ** exposure * r[c])
            worst = max(worst, abs(colour[v] - want))
if worst > 1e-6 * 2.0 ** exposure:
    sys.exit("COLOR_0 differs from min(1, 2^exposure L) by %g" % worst)
print("baked: %d patches, POSITION and _RADIANCE equal to the PLY's, COLOR_0 = min(1, 2^%g L) within %g"
      % (faces, exposure, worst))
PY
else
  fail "the baked asset run failed: $(cat err.txt)"
fi

# A malformed glTF: one line, exit 2, nothing written.
printf '{"asset": {"version": "2.0"}, "buffers": [{"byteLength": 8, "uri": "gone.bin"}]}' >broken.gltf
"$bin" solve broken.gltf -o broken.png 2>err.txt
rc=$?
[ "$rc" -eq 2 ] || fail "malformed glTF: exit $rc, not 2"
[ "$(wc -l <err.txt)" -eq 1 ] || fail "malformed glTF: not one line: $(cat err.txt)"
grep -q "broken.gltf" err.txt || fail "malformed glTF: the file is not named: $(cat err.txt)"
[ ! -e broken.png ] || fail "malformed glTF: an image was written"
# The path tracer has no field to bake.
"$bin" solve "$src/scenes/examples/gltf/cornell-box.glb" --method pathtrace -o x.glb 2>err.txt
[ $? -eq 2 ] && grep -q "radiance field" err.txt || fail "-o x.glb with pathtrace: $(cat err.txt)"

if [ "$failed" -gt 0 ]; then
  echo "$failed failed"
  exit 1
fi
echo "all passed"
