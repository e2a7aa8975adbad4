#!/usr/bin/env bash
# Sets everything up and runs the paper's experiment in simulation (Zhang et al. 2020) on the
# built-in 3-joint arm, at the paper's 125 Hz:
#   1. identify LuGre friction from one minute of the paper's trajectory (mo-lugre-fit);
#   2. calibrate thresholds on one hour of collision-free motion (mo-calibrate);
#   3. 50 random collisions on links 2 and 3: observe, detect, score (mo-eval), plot (mo-plot).
# Results go to demo-out/ (override with DEMO_OUT); the calibration hour takes a few minutes.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh build >/dev/null
export PATH=$PWD/build/bin:$PATH
arm=$PWD/share/momentum/robots/paper-arm/paper-arm.json
out=${DEMO_OUT:-demo-out}
mkdir -p "$out"
cd "$out"

echo "== 1. friction identification (60 s of the paper's trajectory at 125 Hz)"
mo-sim -p "$arm" --trajectory paper --rate 125 --duration 60 --seed 1 |
  mo-observe -p "$arm" > identification.csv
mo-lugre-fit -p "$arm" -o fitted.json --report fit-report.json identification.csv 2> fit-report.txt
grep -E "^joint|tau_c|tau_s|w_s|sigma2|rms" fit-report.txt | grep -v "static" | head -24

echo "== 2. thresholds from one hour of collision-free motion"
mo-sim -p "$arm" --trajectory paper --rate 125 --duration 3600 --seed 2 --output-format bin |
  mo-observe -p fitted.json | mo-calibrate -p fitted.json -o calibrated.json 2> calibration.txt ||
  { cat calibration.txt >&2; exit 1; }
grep -E "^(signal|mu |r )" calibration.txt

echo "== 3. 50 random collisions at 125 Hz"
status=0
mo-sim -p "$arm" --trajectory paper --rate 125 --collisions 50 --truth truth.csv --seed 3 |
  mo-observe -p fitted.json | tee observed.csv | mo-detect -p calibrated.json > events.csv || status=$?
if ((status > 1)); then
  echo "mo-detect failed" >&2
  exit 1
fi
mo-eval --truth truth.csv events.csv
mo-plot -o residuals.png -p calibrated.json --events events.csv --truth truth.csv --from 0 --to 40 observed.csv
echo "== written to $PWD: fitted.json calibrated.json events.csv truth.csv residuals.png"
