#!/usr/bin/env bash
# Builds the libFuzzer targets (candump text, DBC) with clang and runs each from the captures and
# DBC files of tests/data/can plus the inputs that once failed (tests/fuzz/regressions/<target>).
#   tests/fuzz/run.sh [RUNS]      RUNS inputs per target (default 100000) with a fixed seed, so
#                                 that CI is reproducible: the same tree gives the same verdict
#   FUZZ_SECONDS=600 tests/fuzz/run.sh    explore for that long instead, with a random seed
# Exits non-zero when a fuzzer finds a crash, a leak or undefined behaviour; the reproducer is
# left in the work directory and its path printed (add it to tests/fuzz/regressions/<target>/).
set -euo pipefail
runs=${1:-100000}
if [[ -n "${FUZZ_SECONDS:-}" ]]; then
  budget=(-max_total_time="$FUZZ_SECONDS")
  what="for ${FUZZ_SECONDS}s"
else
  budget=(-runs="$runs" -seed=1)
  what="$runs inputs, seed 1"
fi
src=$(cd "$(dirname "$0")/../.." && pwd)
work=${FUZZ_WORK:-$(mktemp -d /tmp/momentum-fuzz.XXXXXX)}
cxx=${FUZZ_CXX:-$(command -v clang++-14 || command -v clang++ || true)}
if [[ -z "$cxx" ]]; then
  echo "fuzz: no clang++ found (apt-get install clang-14)" >&2
  exit 1
fi
mkdir -p "$work"
flags=(-std=c++20 -g -O1 -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=undefined -I"$src/lib/include")
sources=("$src"/lib/src/can/*.cpp "$src/lib/src/stream/error.cpp")
status=0
# Both targets build at once (a minute of instrumented compiling otherwise spent one core at a time).
echo "fuzz: building candump, dbc"
pids=()
for target in candump dbc; do
  "$cxx" "${flags[@]}" "$src/tests/fuzz/${target}_fuzz.cpp" "${sources[@]}" -o "$work/fuzz_$target" &
  pids+=($!)
done
for pid in "${pids[@]}"; do wait "$pid" || { echo "fuzz: a target did not build" >&2; exit 1; }; done
for target in candump dbc; do
  corpus="$work/corpus_$target"
  mkdir -p "$corpus"
  if [[ $target == candump ]]; then
    cp "$src"/tests/data/can/*.log "$src"/tests/data/can/formats/*.log "$src"/tests/data/can/formats/*.txt "$corpus"/
  else
    cp "$src"/tests/data/can/*.dbc "$src"/tests/data/can/formats/*.dbc "$corpus"/
  fi
  if [[ -d "$src/tests/fuzz/regressions/$target" ]]; then
    cp "$src/tests/fuzz/regressions/$target"/* "$corpus"/
  fi
  echo "fuzz: running $target ($what)"
  if ! (cd "$work" && ASAN_OPTIONS=detect_leaks=1 "./fuzz_$target" "${budget[@]}" -max_len=4096 \
        -print_final_stats=1 -artifact_prefix="$work/${target}-" "$corpus" > "$work/$target.log" 2>&1); then
    echo "fuzz: $target FAILED; see $work/$target.log and $work/${target}-*" >&2
    tail -30 "$work/$target.log" >&2
    status=1
  else
    grep -E "stat::number_of_executed_units|Done" "$work/$target.log" | sed "s/^/fuzz: $target: /" || true
  fi
done
exit $status
