#!/usr/bin/env bash
# Times mo-lugre-fit against the length of its data (issue 30: a fit whose cost is set by the
# model, not by the hours): the simulated paper arm at 125 Hz (3 joints, the profile's
# simulation.friction as the truth), 30 s, 1 hour and 8 hours (eight hourly files, as a day's
# logs come), each observed by mo-observe into a binary stream; then one fit of each with the
# defaults, printing its wall and CPU time, peak memory, the counted samples of joint 1, and
# for every identifiable parameter (the fit's own flag) how many of its stated uncertainties it
# lies from the truth (largest |z| over the joints).
#   scripts/bench-fit-hours.sh [BUILD_DIR [WORK_DIR]]   (default: build, a temporary folder)
# A WORK_DIR that already holds the streams is reused (the simulation takes about a minute on
# two cores and is not timed). Wall times depend on what else runs: the CPU column is the
# better measure on a shared machine.
set -euo pipefail
build=${1:-build}
here=$(cd "$(dirname "$0")/.." && pwd)
for t in mo-sim mo-observe mo-lugre-fit; do
  [[ -x $build/bin/$t ]] || { echo "bench-fit-hours: $build/bin/$t not built (cmake --build $build --target mo-sim mo-observe mo-lugre-fit)" >&2; exit 1; }
done
bin=$(cd "$build/bin" && pwd)
if [[ -n ${2:-} ]]; then
  work=$2
  mkdir -p "$work"
else
  work=$(mktemp -d /tmp/momentum-bench-fit-hours.XXXXXX)
  trap 'rm -rf "$work"' EXIT
fi
profile=$here/share/momentum/robots/paper-arm/paper-arm.json

# seed seconds file: the semi-implicit integrator at 2 kHz, as bench-nightly.sh simulates its day.
simulate() {
  [[ -s $3 ]] && return 0
  "$bin/mo-sim" -q -p "$profile" --rate 125 --duration "$2" --seed "$1" --integrator semi-implicit \
    --internal-rate 2000 --output-format bin |
    "$bin/mo-observe" -q -p "$profile" --output-format bin -o "$3.part" && mv "$3.part" "$3"
}
echo "== the data: the simulated paper arm at 125 Hz, observed (not timed)" >&2
simulate 7 30 "$work/30s.bin" &
simulate 8 3600 "$work/1h.bin" &
wait
for h in 1 2 3 4 5 6 7 8; do
  simulate "1$h" 3600 "$work/day-$h.bin" &
  ((h % 2)) || wait
done
wait

echo "== mo-lugre-fit, defaults, $(nproc) cores, load $(cut -d' ' -f1 /proc/loadavg)"
printf '%-6s %8s %8s %9s %10s %10s  %s\n' length wall_s cpu_s peak_MB samples_j1 max_abs_z "parameter at max |z|"
run() {  # label files...
  local label=$1
  shift
  /usr/bin/time -f "%e %U %S %M" -o "$work/time" "$bin/mo-lugre-fit" -q -p "$profile" "$@" --report "$work/r.json" > /dev/null
  read -r wall user sys rss < "$work/time"
  python3 - "$work/r.json" "$profile" "$label" "$wall" "$user" "$sys" "$rss" <<'PY'
import json, re, sys
report, profile, label, wall, user, sys_, rss = sys.argv[1:]
truth = json.loads(re.sub(r"(?m)^\s*//.*$", "", open(profile).read()))["simulation"]["friction"]["joints"]
r = json.load(open(report))
worst, where = 0.0, "-"
for j in r["joints"]:
    k = j["joint"] - 1
    for name, p in j["fit"]["parameters"].items():
        if p["free"] and p["identifiable"] and p["uncertainty"] and p["uncertainty"] > 0:
            z = (p["value"] - truth[k][name]) / p["uncertainty"]
            if abs(z) > worst:
                worst, where = abs(z), f"j{k + 1} {name} {p['value']:.5g} +- {p['uncertainty']:.2g} (truth {truth[k][name]:.5g})"
print(f"{label:6s} {float(wall):8.2f} {float(user) + float(sys_):8.2f} {int(rss) / 1024:9.1f} "
      f"{r['joints'][0]['fit']['metrics']['samples']:10d} {worst:10.2f}  {where}")
PY
}
run 30s "$work/30s.bin"
run 1h "$work/1h.bin"
run 8h "$work"/day-?.bin
