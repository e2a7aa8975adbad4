#!/usr/bin/env bash
# Sets everything up and runs every test: once in a normal build (GCC) with warnings as errors,
# once under AddressSanitizer and UndefinedBehaviorSanitizer (clang), then the fuzz targets (a
# fixed number of inputs with a fixed seed, so the verdict is reproducible).
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc)
phase() { echo "test.sh: $1 done at ${SECONDS}s" >&2; }

# Line tables only (-g1): full debug info of the Eigen and Ceres templates costs a third of the
# compile time, and CI needs file:line in backtraces, not variables.
scripts/setup.sh build -DMOMENTUM_WERROR=ON -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -g1 -DNDEBUG"
phase "set-up and normal build"
ctest --test-dir build -j"$jobs" --output-on-failure
phase "normal tests"

# The sanitizer build uses clang: it compiles this code base's Eigen and Ceres templates about
# twice as fast as GCC under instrumentation (properties_test.cpp: 36 s against 68 s), which
# keeps CI well inside its budget, and it puts a second compiler's diagnostics on every change.
# Warnings are errors here too. The tests labelled slow (whole simulated days, minutes each) ran
# above and are left out under the sanitizers' 3-10x cost, and so are the unit tests of the
# numerical stages (model, fit, dynfit, sim: a third of the build), which the tools' cases
# still run through. -O1 -g1, as the AddressSanitizer documentation suggests.
scripts/setup.sh build-sanitize -DCMAKE_CXX_COMPILER=clang++-14 -DMOMENTUM_SANITIZE=ON -DMOMENTUM_WERROR=ON \
  -DMOMENTUM_BUILD_BENCHMARKS=OFF -DMOMENTUM_UNIT_TEST_STAGES="core;stream;cli;can;friction;observer;detect;eval" \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG"
phase "sanitizer build"
ASAN_OPTIONS=detect_leaks=1 LSAN_OPTIONS=suppressions=$PWD/tests/lsan.supp:print_suppressions=0 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --test-dir build-sanitize -j"$jobs" --output-on-failure -LE slow
phase "sanitizer tests"

tests/fuzz/run.sh
phase "fuzzing"
