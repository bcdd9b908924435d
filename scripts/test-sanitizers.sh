#!/usr/bin/env bash
# The whole test suite under AddressSanitizer and UndefinedBehaviorSanitizer, in a
# build of its own (./build-sanitize; CI runs it after scripts/test.sh). Any sanitizer
# report fails the test that triggered it: UBSan does not recover, ASan and LSan stop
# at the first error. Two exceptions, in Mesa and CGAL, not in ours: leaks inside
# libOSMesa (tests/sanitizers/lsan.supp), and CGAL's arrangement iterators, compiled
# without UBSan's vptr check (visibility/CMakeLists.txt). The long statistical runs of
# the high-albedo estimators ("no drift ...", "high albedo by default ...": 10^5 and
# 2*10^4 steps of code the shorter stress tests run as well) and the samplers'
# comparison on the partition scene ("partition": 37 runs of the CLI, whose Metropolis
# code the unit tests run as well) and the quasi-random walks against random ones ("qmc":
# 90 runs of the CLI; the samplers' unit tests run here) and the signals aimed at the
# output commit ("commit": 65 runs of the CLI; the commit's fork tests of
# tests/render/test_output_set.cpp run here) and the glTF validator's check of the
# example assets and a baked .glb ("glb": Node.js and three CLI solves; the glTF reader
# and writer run here in the [gltf] unit tests) are left to the normal build,
# to keep CI within 30 minutes on 2 cores. So is "rounds: the steps' share follows where
# the noise is": it measures what rounds fit in a 3 s time budget, and under the
# sanitizers' slowdown too few fit for its probe (field share 0.57 where it asserts
# < 0.5, on the 2-core development machine); the normal build asserts it. So is the
# glossy half of "final gather against the path tracer" (2048 path-traced samples per
# pixel of glossy paths, and two final gathers: 8 minutes under the sanitizers, near the
# per-test limit; its diffuse half runs here, and the glossy example box goes through the
# glossy gather in cli-outputs). Extra arguments go to ctest (e.g. -R cli).
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=${RAYBUNDLE_JOBS:-2}
# Without MPI: Open MPI's own allocations would fill LeakSanitizer's report, and this
# build checks that a raybundle without MPI refuses to run as copies under mpirun.
cmake -S . -B build-sanitize -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DRAYBUNDLE_SANITIZE=ON -DRAYBUNDLE_WITH_MPI=OFF \
  -DRAYBUNDLE_BUILD_BENCH=OFF -DRAYBUNDLE_REQUIRE_OPENCV=ON -DRAYBUNDLE_REQUIRE_GSL=ON
cmake --build build-sanitize -j "$jobs"
export ASAN_OPTIONS="detect_leaks=1:strict_string_checks=1:check_initialization_order=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
export LSAN_OPTIONS="suppressions=$PWD/tests/sanitizers/lsan.supp:print_suppressions=0"
ctest --test-dir build-sanitize --output-on-failure -j "$jobs" -E "^no drift|^high albedo by default|^partition$|^qmc$|^commit$|^glb$|^rounds: the steps. share|^final gather against the path tracer: the glossy" "$@"
