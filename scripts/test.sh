#!/usr/bin/env bash
# Sets everything up and runs every test in a normal build (GCC) with warnings as errors, then
# every test that is not labelled slow under AddressSanitizer and UndefinedBehaviorSanitizer
# (clang; MOMENTUM_FULL_SANITIZE=0: only the unit tests of the input-facing stages), then the
# fuzz targets (a fixed number of inputs with a fixed seed, so the verdict is reproducible).
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

# The Python package (python/, README "Python"): pip installs it into a virtual environment
# against the library this build has just compiled (cmake --install copies it to a scratch
# prefix; nothing is compiled again but the binding), then its pytest suite compares it with
# the tools of build/bin.
rm -rf build/python-prefix
cmake --install build --prefix build/python-prefix >/dev/null
scripts/python-setup.sh build/python-venv
MOMENTUM_PREFIX=$PWD/build/python-prefix build/python-venv/bin/pip install -q --disable-pip-version-check \
  --no-build-isolation --config-settings=cmake.define.MOMENTUM_WERROR=ON ./python
MOMENTUM_BIN=$PWD/build/bin build/python-venv/bin/python -m pytest -q -rs -p no:cacheprovider python/tests
phase "python package"

# The sanitizer build uses clang: it compiles this code base's Eigen and Ceres templates about
# twice as fast as GCC under instrumentation (properties_test.cpp: 36 s against 68 s), and it
# puts a second compiler's diagnostics on every change. Warnings are errors here too.
# Under AddressSanitizer and UndefinedBehaviorSanitizer: the unit tests of the stages below and
# every test that is not labelled slow or heavy, against the sanitized tools: the golden
# command-line cases (their test runs build-sanitize/bin), the hostile-input test, the
# corruption test, the real UR10e set, the man pages. The tests labelled slow (whole simulated
# days and campaigns, minutes each even unsanitized) and heavy (seconds of fitting or
# simulation each unsanitized, ten times that here) ran above in the normal build only; the
# fleet test alone took 10 of stop 24's 25 sanitized minutes, and CI is to stay under 40.
# -O1 -g1, as the AddressSanitizer documentation suggests.
# MOMENTUM_FULL_SANITIZE=0: only the stages that parse outside input and their unit tests, for
# a quick local run.
if [[ ${MOMENTUM_FULL_SANITIZE:-1} == 1 ]]; then
  # The unit tests of the stages that read outside input or judge it (core to detect, and the
  # drivers that run them over streams); those
  # of the numerical stages (friction, friction_fit, contact, sim, eval, inertia: 470 of the 900 CPU
  # seconds the sanitized unit tests take to compile) are left to the normal build, and their
  # code runs sanitized through the tools in the golden cases and the hostile test.
  sanitize_stages="core;stream;cli;can;model;observer;detect;calibrate;drivers"
  sanitize_targets=()
  sanitize_tests=(-LE 'slow|heavy')
  # The unit tests that took over half a second in the normal run above (its cost file) are
  # left out too: 30 of 430 unit tests, 105 of their 116 s, and 100 to 170 times that under the
  # sanitizers (simulated trajectories and fits through Eigen at -O1: Run.SameSeed... 3 s
  # unsanitized, 9 minutes sanitized). Their stages' other unit tests run the same code.
  costly=$(awk '$1 !~ /\// && $3 > 0.5 { gsub(/[.]/, "[.]", $1); printf "%s^%s$", sep, $1; sep = "|" }' \
    build/Testing/Temporary/CTestCostData.txt)
  [[ -z $costly ]] || sanitize_tests+=(-E "$costly")
else
  sanitize_stages="core;stream;cli;can"
  sanitize_targets=(--target test_core --target test_stream --target test_cli --target test_can)
  sanitize_tests=(-L unit)
fi
scripts/setup.sh "${sanitize_targets[@]}" build-sanitize -DCMAKE_CXX_COMPILER=clang++-14 -DMOMENTUM_SANITIZE=ON \
  -DMOMENTUM_WERROR=ON -DMOMENTUM_BUILD_BENCHMARKS=OFF -DMOMENTUM_UNIT_TEST_STAGES="$sanitize_stages" \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG"
phase "sanitizer build"
ASAN_OPTIONS=detect_leaks=1 LSAN_OPTIONS=suppressions=$PWD/tests/lsan.supp:print_suppressions=0 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --test-dir build-sanitize -j"$jobs" --output-on-failure "${sanitize_tests[@]}"
phase "sanitizer tests"

# 4000 inputs per target (each target's corpus and past failures first): at 20000 the three
# stream targets took 390 of CI's 2234 s (stop 31), and CI is to stay under 40 minutes; a longer
# exploration is a local run (FUZZ_SECONDS=600 tests/fuzz/run.sh).
tests/fuzz/run.sh "${MOMENTUM_FUZZ_RUNS:-4000}"
phase "fuzzing"
