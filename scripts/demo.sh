#!/usr/bin/env bash
# Sets everything up and runs the paper's experiment in simulation (Zhang et al. 2020) on the
# built-in 3-joint arm:
#   1. identify LuGre friction from one minute of the paper's trajectory at 125 Hz
#      (mo-lugre-fit, through the profile's second-order observer, as the paper);
#   2. at 125 Hz and at 1 kHz: calibrate thresholds on one hour of collision-free motion
#      (mo-calibrate), count false alarms on another collision-free hour, then 50 random
#      collisions on links 2 and 3: observe, detect, score. The hour of false alarms and the
#      collisions carry sensor glitches as real controllers' logs do (mo-sim --glitches: abrupt
#      stops, velocity spikes, encoder jumps; one a minute), which mo-observe's signal check
#      must tell from contacts
#      (mo-eval) and plot (mo-plot). Detection uses the first-order observer (K1 = 50 1/s): the
#      second order's high-pass (K2) leaves a tail after each contact that keeps events open.
# Results go to demo-out/ (override with DEMO_OUT); each calibration hour takes a few minutes.
# It builds only the tools it runs (in build/, override with DEMO_BUILD), each with only the
# library stages it uses, and the three of the first step before the other four, so the first
# result comes minutes after the packages are installed; scripts/test.sh builds the rest
# (tests, benchmarks, the other tools) in the same folder, reusing these objects.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
build=$(realpath -m "${DEMO_BUILD:-build}")
setup_done=0
# Builds the named tools and the library stages they use; the first call also sets up.
build_tools() {
  [[ ${DEMO_SKIP_SETUP:-0} != 1 ]] || return 0
  echo "== building $* in $build/"
  local targets=() t
  for t in "$@"; do targets+=(--target "$t"); done
  if ((setup_done)); then
    cmake --build "$build" -j"$(nproc)" "${targets[@]}" > /dev/null
  else
    "$root/scripts/setup.sh" "${targets[@]}" "$build" > /dev/null
    setup_done=1
  fi
}
build_tools mo-sim mo-observe mo-lugre-fit
export PATH=$build/bin:$PATH
arm=$root/share/momentum/robots/paper-arm/paper-arm.json
out=${DEMO_OUT:-demo-out}
mkdir -p "$out"
cd "$out"

echo "== friction identification (60 s of the paper's trajectory at 125 Hz)"
mo-sim -p "$arm" --trajectory paper --rate 125 --duration 60 --seed 1 |
  mo-observe -p "$arm" > identification.csv
mo-lugre-fit -p "$arm" -o fitted.json --report fit-report.json identification.csv 2> fit-report.txt
grep -E "^joint|^  (sigma|tau|w_s)|^  rms" fit-report.txt || true

build_tools mo-calibrate mo-detect mo-eval mo-plot
for rate in 125 1000; do
  echo "== $rate Hz: thresholds from one hour of collision-free motion"
  set +e
  mo-sim -p "$arm" --trajectory paper --rate "$rate" --duration 3600 --seed 2 --output-format bin |
    mo-observe -p fitted.json --order 1 --k1 50 |
    mo-calibrate -p fitted.json --skip 0.5 -o "calibrated-$rate.json" > "calibration-$rate.txt" 2>&1
  statuses=("${PIPESTATUS[@]}")
  set -e
  if [[ ${statuses[*]} != "0 0 0" ]]; then
    cat "calibration-$rate.txt" >&2
    echo "demo: calibration failed (exit statuses of mo-sim, mo-observe, mo-calibrate: ${statuses[*]})" >&2
    exit 1
  fi
  grep -E "^(signal|mu |r )" "calibration-$rate.txt" || true

  echo "== $rate Hz: false alarms on another hour of collision-free motion"
  set +e
  mo-sim -p "$arm" --trajectory paper --rate "$rate" --duration 3600 --seed 4 --output-format bin \
    --glitches 60 --truth "free-truth-$rate.csv" | mo-observe -p fitted.json --order 1 --k1 50 |
    mo-detect -p "calibrated-$rate.json" --skip 0.5 > "free-events-$rate.csv"
  statuses=("${PIPESTATUS[@]}")
  set -e
  # mo-detect's 1 means events (false alarms here), not a failure.
  if [[ ${statuses[0]} != 0 || ${statuses[1]} != 0 || ${statuses[2]} -gt 1 ]]; then
    echo "demo: false-alarm check failed (exit statuses of mo-sim, mo-observe, mo-detect: ${statuses[*]})" >&2
    exit 1
  fi
  mo-eval --truth "free-truth-$rate.csv" "free-events-$rate.csv" | grep -E "^false alarms"

  echo "== $rate Hz: 50 random collisions"
  mo-sim -p "$arm" --trajectory paper --rate "$rate" --collisions 50 --glitches 10 --truth "truth-$rate.csv" --seed 3 |
    mo-observe -p fitted.json --order 1 --k1 50 > "observed-$rate.csv"
  status=0
  mo-detect -p "calibrated-$rate.json" --skip 0.5 "observed-$rate.csv" > "events-$rate.csv" || status=$?
  ((status <= 1)) || { echo "mo-detect failed" >&2; exit 1; }
  # --min-torque 1: a contact that moves no joint by 1 Nm (its force through or along the joint
  # axes) is the arm's blind spot, not the detector's; it is still scored, and counted apart.
  mo-eval --truth "truth-$rate.csv" --min-torque 1 "events-$rate.csv"
  mo-plot -o "residuals-$rate.png" -p "calibrated-$rate.json" --events "events-$rate.csv" \
    --truth "truth-$rate.csv" --from 5 --to 30 "observed-$rate.csv"
done
echo "== written to $PWD"
