#!/usr/bin/env bash
# Sets everything up and runs every test: once in a normal build (warnings are errors), once
# under AddressSanitizer and UndefinedBehaviorSanitizer, then the fuzz targets briefly.
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc)

scripts/setup.sh build -DMOMENTUM_WERROR=ON
ctest --test-dir build -j"$jobs" --output-on-failure

scripts/setup.sh build-sanitize -DMOMENTUM_WERROR=ON -DMOMENTUM_SANITIZE=ON \
  -DMOMENTUM_BUILD_BENCHMARKS=OFF
ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --test-dir build-sanitize -j"$jobs" --output-on-failure

tests/fuzz/run.sh 20
