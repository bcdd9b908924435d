#!/usr/bin/env bash
# The OpenGL z-buffer on a GPU against the exact painter (docs/benchmarks.md, "The
# z-buffer on a GPU"). For a machine with a GPU and its EGL driver, where this project
# is not built: build here with the context made through EGL,
#
#   cmake -S . -B build-egl -G Ninja -DCMAKE_BUILD_TYPE=Release -DRAYBUNDLE_GL_CONTEXT=egl \
#         -DRAYBUNDLE_WITH_MPI=OFF -DRAYBUNDLE_BUILD_TESTS=OFF
#   cmake --build build-egl --target raybundle bench_visibility
#
# carry build-egl/apps/raybundle, build-egl/bench/bench_visibility and the shared
# libraries `ldd` lists for them (OpenMesh, OpenEXR and Imath, Embree, TBB, libpng, GMP,
# MPFR; libEGL comes with the GPU's driver and glvnd) to that machine, and run there
#
#   bench/run_zbuffer_gpu.sh BIN_DIR [OUT_DIR]
#
# with BIN_DIR holding both programs. It writes OUT_DIR/zbuffer-gpu.csv (Cornell box at
# 512², 1024², 2048²) and OUT_DIR/zbuffer-gpu-121k.csv (121,324 patches at 1024²): ms
# per direction, the exact painter on one core against the zbuffer, 100 (30) directions,
# 3 rounds interleaved; the same with the directions handed over 16 at a time
# (Backend::transfer_many, as the solvers do: one submission, the CPU's part on all the
# cores) in OUT_DIR/zbuffer-gpu-batch.csv and zbuffer-gpu-121k-batch.csv (the exact
# painter still on one core: it computes a batch's directions in turn); the zbuffer's
# stage profile (RAYBUNDLE_ZBUFFER_PROFILE) on
# stderr; how far the zbuffer's solved field is from the global z-buffer's (the Cornell
# box and scenes/examples/contact.json); and whole solves with each on all the cores.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${1:?usage: bench/run_zbuffer_gpu.sh BIN_DIR [OUT_DIR]}
out=${2:-.}
mkdir -p "$out"
for p in raybundle bench_visibility; do
    [ -x "$bin/$p" ] || { echo "run_zbuffer_gpu: $bin/$p missing" >&2; exit 1; }
done
threads=$(nproc)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
export RAYBUNDLE_ZBUFFER_PROFILE=1
"$bin/raybundle" backends | grep '^zbuffer ' || { echo "run_zbuffer_gpu: this build has no zbuffer backend" >&2; exit 1; }
"$bin/bench_visibility" --backend exact-painter --backend zbuffer --scene cornell-box --resolution 512 1024 2048 \
    --directions 100 --repeat 3 --csv "$out/zbuffer-gpu.csv"
"$bin/bench_visibility" --backend exact-painter --backend zbuffer --scene cornell-box --patch-size 10 \
    --resolution 1024 --directions 30 --repeat 3 --csv "$out/zbuffer-gpu-121k.csv"
"$bin/bench_visibility" --backend exact-painter --backend zbuffer --scene cornell-box --resolution 512 1024 2048 \
    --directions 96 --repeat 3 --batch 16 --threads "$threads" --csv "$out/zbuffer-gpu-batch.csv"
"$bin/bench_visibility" --backend exact-painter --backend zbuffer --scene cornell-box --patch-size 10 \
    --resolution 1024 --directions 32 --repeat 3 --batch 16 --threads "$threads" --csv "$out/zbuffer-gpu-121k-batch.csv"
# The same seed, the same directions: the fields differ only where the matrices do.
for v in zbuffer global-zbuffer; do
    "$bin/raybundle" solve --builtin cornell-box --iterations 300 --gather 0 --visibility $v --seed 1 \
        --threads "$threads" -q -o "$work/c-$v.png" --patches "$work/c-$v.csv"
    "$bin/raybundle" solve scenes/examples/contact.json --iterations 200 --gather 0 --visibility $v --seed 1 \
        --threads "$threads" -q -o "$work/k-$v.png" --patches "$work/k-$v.csv"
done
python3 - "$work" <<'P'
import csv, sys
work = sys.argv[1]
for tag, scene in (("c", "Cornell box, 300 steps"), ("k", "contact scene, 200 steps")):
    a, b = [list(csv.reader(open(f"{work}/{tag}-{v}.csv"))) for v in ("zbuffer", "global-zbuffer")]
    num = den = 0.0
    for ra, rb in zip(a[1:], b[1:]):
        for x, y in zip(ra[1:], rb[1:]):
            try:
                x, y = float(x), float(y)
            except ValueError:
                continue
            num += abs(x - y)
            den += abs(y)
    print(f"{scene}: zbuffer against global-zbuffer, relative L1 of the patch file {num / den:.3g}")
P
for v in exact-painter zbuffer; do
    for args in "--builtin cornell-box --iterations 2000" \
                "--builtin cornell-box --patch-size 10 --iterations 200 --gather 0"; do
        start=$(date +%s.%N)
        # shellcheck disable=SC2086
        "$bin/raybundle" solve $args --visibility $v --seed 1 --threads "$threads" -q -o "$work/s.png" \
            --stats "$work/s.json"
        end=$(date +%s.%N)
        python3 - "$work/s.json" "$v" "$args" "$start" "$end" <<'P'
import json, sys
s = json.load(open(sys.argv[1]))
phases = ", ".join(f"{p['phase']} {p['seconds']:.2f}" for p in s["phases"] if p["seconds"] >= 0.01)
print(f"{sys.argv[2]}, solve {sys.argv[3]}: {float(sys.argv[5]) - float(sys.argv[4]):.2f} s ({phases})")
P
    done
done
