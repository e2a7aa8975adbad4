#!/usr/bin/env bash
# Speed of mo-sim end to end: simulated seconds per wall-clock (and per CPU) second for the
# paper's arm (3 joints, LuGre of Table 1, 4 collisions per minute) and the Panda (7 joints,
# frictionless: tests/data/panda.json has no simulation section), RK4 and semi-implicit at the
# default 10 kHz internal rate, 1 kHz binary output to /dev/null. Also the peak memory of a
# short and a 10x longer run (it must not grow: output is streamed).
#   scripts/bench-sim.sh [BUILD_DIR] [SECONDS]
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
seconds=${2:-120}
bin=$(cd "$build/bin" && pwd)
arm=share/momentum/robots/paper-arm/paper-arm.json
panda=tests/data/panda.json

run() {  # label profile extra-args...
  local label=$1 profile=$2
  shift 2
  local out
  out=$( { /usr/bin/time -f '%e %U %S %M' "$bin/mo-sim" -q -p "$profile" --duration "$seconds" \
             --output-format bin "$@" > /dev/null; } 2>&1 | tail -1)
  awk -v l="$label" -v s="$seconds" -v o="$out" 'BEGIN { split(o, f, " ");
    printf "%-34s %7.1f sim s per wall s  %7.1f per CPU s  (%.2f s wall, %d MB peak)\n",
           l, s / f[1], s / (f[2] + f[3]), f[1], f[4] / 1024 }'
}

collisions=$((seconds / 15))
echo "mo-sim, $seconds s simulated at 1 kHz output, 10 kHz internal"
run "paper arm, rk4" "$arm" --collisions "$collisions"
run "paper arm, semi-implicit" "$arm" --collisions "$collisions" --integrator semi-implicit
run "paper arm, rk4, 125 Hz output" "$arm" --collisions "$collisions" --rate 125
run "panda (7 joints), rk4" "$panda" --collisions "$collisions"
run "panda (7 joints), semi-implicit" "$panda" --collisions "$collisions" --integrator semi-implicit
seconds=$((seconds / 10))
run "paper arm, rk4, 1/10 of the length" "$arm"
