#!/usr/bin/env bash
# The test suite under AddressSanitizer and UndefinedBehaviorSanitizer, in a build of
# its own (./build-sanitize; CI runs it after scripts/test.sh). Any sanitizer report
# fails the test that triggered it: UBSan does not recover, ASan and LSan stop at the
# first error. Two exceptions, in Mesa and CGAL, not in ours: leaks inside libOSMesa
# (tests/sanitizers/lsan.supp), and CGAL's arrangement iterators, compiled without
# UBSan's vptr check (visibility/CMakeLists.txt). The tests that only repeat for longer
# what shorter ones run here (long statistical runs, command-line loops, every backend
# through a whole solve) are left to the normal build: tests/sanitizers/skip.txt lists
# them, each with its reason. Built at -O1 with line tables only (-g1: file and line in
# every report): a cold build takes half the time of -O2 -g (docs/benchmarks.md).
# Extra arguments go to ctest (e.g. -R cli).
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=${RAYBUNDLE_JOBS:-2}
# Without MPI: Open MPI's own allocations would fill LeakSanitizer's report, and this
# build checks that a raybundle without MPI refuses to run as copies under mpirun.
cmake -S . -B build-sanitize -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g1 -DNDEBUG" \
  -DRAYBUNDLE_SANITIZE=ON -DRAYBUNDLE_WITH_MPI=OFF \
  -DRAYBUNDLE_BUILD_BENCH=OFF -DRAYBUNDLE_REQUIRE_OPENCV=ON -DRAYBUNDLE_REQUIRE_GSL=ON
cmake --build build-sanitize -j "$jobs"
export ASAN_OPTIONS="detect_leaks=1:strict_string_checks=1:check_initialization_order=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
export LSAN_OPTIONS="suppressions=$PWD/tests/sanitizers/lsan.supp:print_suppressions=0"
skip=$(grep -v -e '^#' -e '^$' tests/sanitizers/skip.txt | paste -sd '|')
# Tests whose leak check at exit crashes LeakSanitizer itself run with detect_leaks=0
# (tests/sanitizers/no-leak-check.txt says which and why), after the others; the
# arguments given apply to the others only.
no_leak_check=$(grep -v -e '^#' -e '^$' tests/sanitizers/no-leak-check.txt | paste -sd '|')
ctest --test-dir build-sanitize --output-on-failure -j "$jobs" -E "$skip|$no_leak_check" "$@"
ASAN_OPTIONS=${ASAN_OPTIONS/detect_leaks=1/detect_leaks=0} \
  ctest --test-dir build-sanitize --output-on-failure -j "$jobs" -R "$no_leak_check"
