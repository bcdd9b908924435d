#!/usr/bin/env bash
# raybundle as a library (apps/example_run.cpp): the same image as the command line
# with the same settings, byte for byte (RunConfig's defaults are the command line's),
# and bad input in one line with exit 2.
# Usage: test_example.sh PATH/TO/raybundle_example PATH/TO/raybundle SOURCE_DIR
set -u
example=$1 bin=$2 src=$3
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work" || exit 1
failed=0
fail() { echo "FAIL: $*"; failed=1; }
"$example" builtin:cornell-box lib.png camera.width=64 camera.height=48 >out.txt 2>err.txt ||
  fail "the example: exit $?: $(cat err.txt)"
grep -q "^cornell-box: 500 steps, mean radiance [0-9.]*, estimated error [0-9.]* %$" out.txt ||
  fail "the example's line: $(cat out.txt)"
"$bin" solve --builtin cornell-box --iterations 500 -D camera.width=64 -D camera.height=48 -o cli.png -q ||
  fail "the command line: exit $?"
cmp -s lib.png cli.png || fail "the library's image differs from the command line's"
"$example" "$src/scenes/examples/contact.json" lib2.png camera.width=48 camera.height=32 >/dev/null 2>err.txt ||
  fail "the example on a scene file: $(cat err.txt)"
"$example" nowhere.json bad.png >/dev/null 2>err.txt
rc=$?
[ "$rc" -eq 2 ] && [ "$(wc -l <err.txt)" -eq 1 ] && grep -q "nowhere.json" err.txt && [ ! -e bad.png ] ||
  fail "a missing scene: exit $rc, $(cat err.txt)"
# Its output is checked as the command line checks its own: not one of the inputs, and
# a PNG by its name; the scene file is left as it was.
cp "$src/scenes/examples/contact.json" scene.json
cp scene.json before.json
"$example" scene.json scene.json >/dev/null 2>err.txt
rc=$?
[ "$rc" -eq 2 ] && [ "$(wc -l <err.txt)" -eq 1 ] && grep -q "scene.json" err.txt && cmp -s scene.json before.json ||
  fail "the scene file as the output: exit $rc, $(cat err.txt)"
"$example" builtin:cornell-box out.jpg >/dev/null 2>err.txt
rc=$?
[ "$rc" -eq 2 ] && grep -q "out.jpg: this example writes PNG only" err.txt && [ ! -e out.jpg ] ||
  fail "a .jpg output: exit $rc, $(cat err.txt)"
[ "$failed" -eq 0 ] && echo "library-example: passed"
exit "$failed"
