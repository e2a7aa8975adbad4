#!/usr/bin/env bash
# Sets everything up and runs every test: once in a normal build with warnings as errors, once
# under AddressSanitizer and UndefinedBehaviorSanitizer, then the fuzz targets briefly.
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc)

scripts/setup.sh build -DMOMENTUM_WERROR=ON
ctest --test-dir build -j"$jobs" --output-on-failure

# No -Werror here: GCC 12 reports false -Wmaybe-uninitialized inside Eigen and libstdc++ when
# instrumented; the normal build above holds the warning line. The tests labelled slow (whole
# simulated days, minutes each) ran above and are left out under the sanitizers' 3-10x cost.
scripts/setup.sh build-sanitize -DMOMENTUM_SANITIZE=ON -DMOMENTUM_BUILD_BENCHMARKS=OFF
ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --test-dir build-sanitize -j"$jobs" --output-on-failure -LE slow

tests/fuzz/run.sh 20
