#!/usr/bin/env bash
# Sets everything up and runs every test: once in a normal build with warnings as errors, once
# under AddressSanitizer and UndefinedBehaviorSanitizer, then the fuzz targets (a fixed number of
# inputs with a fixed seed, so the verdict is reproducible).
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

# No -Werror here: GCC 12 reports false -Wmaybe-uninitialized inside Eigen and libstdc++ when
# instrumented; the normal build above holds the warning line. The tests labelled slow (whole
# simulated days, minutes each) ran above and are left out under the sanitizers' 3-10x cost.
# -O1 -g1, as the AddressSanitizer documentation suggests: instrumented code at -O2 -g compiles
# three times slower here (GCC's variable tracking gives up and retries).
scripts/setup.sh build-sanitize -DMOMENTUM_SANITIZE=ON -DMOMENTUM_BUILD_BENCHMARKS=OFF \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG"
phase "sanitizer build"
ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --test-dir build-sanitize -j"$jobs" --output-on-failure -LE slow
phase "sanitizer tests"

tests/fuzz/run.sh
phase "fuzzing"
