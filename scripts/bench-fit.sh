#!/usr/bin/env bash
# Times friction identification at the paper's settings (man mo-lugre-fit, PERFORMANCE):
#   1. bench_fit (bench/fit_bench.cpp): one joint and the three joints, the paper's full GA
#      against the default short GA + Ceres polish, with evaluations and final costs;
#   2. mo-lugre-fit end to end on 1251 samples (10 s at 125 Hz) of the simulated paper arm:
#      wall and CPU time of the default, of the default without the static comparison, and
#      of --paper --no-polish, with each run's total cost.
#   scripts/bench-fit.sh [BUILD_DIR]          (default: build)
# Wall times depend on what else runs: the CPU column is the better measure on a shared machine.
set -euo pipefail
build=${1:-build}
here=$(cd "$(dirname "$0")/.." && pwd)
for t in bench/bench_fit bin/mo-sim bin/mo-observe bin/mo-lugre-fit; do
  [[ -x $build/$t ]] || { echo "bench-fit: $build/$t not built (cmake --build $build --target bench_fit mo-sim mo-observe mo-lugre-fit)" >&2; exit 1; }
done
work=$(mktemp -d /tmp/momentum-bench-fit.XXXXXX)
trap 'rm -rf "$work"' EXIT
profile=$here/share/momentum/robots/paper-arm/paper-arm.json

echo "== bench_fit"
"$build/bench/bench_fit" --benchmark_counters_tabular=true 2>/dev/null | grep -E "^(BM_|Benchmark|-)" || true

echo "== mo-lugre-fit, 1251 samples per joint, 3 joints, $(nproc) cores, load $(cut -d' ' -f1 /proc/loadavg)"
"$build/bin/mo-sim" -q -p "$profile" --rate 125 --duration 12 |
  "$build/bin/mo-observe" -q -p "$profile" > "$work/obs.csv"
run() {
  local label=$1; shift
  /usr/bin/time -f "%e %U %S" -o "$work/time" \
    "$build/bin/mo-lugre-fit" -q -p "$profile" "$work/obs.csv" --window 1:11 --min-speed 0 --report "$work/r.json" "$@"
  read -r wall user sys < "$work/time"
  python3 - "$work/r.json" "$label" "$wall" "$user" "$sys" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
cost = sum(j["fit"]["metrics"]["cost"] for j in r["joints"])
evals = sum(j["fit"]["evaluations"] + (j["static"]["evaluations"] if j["static"] else 0) for j in r["joints"])
label, wall, user, sys_ = sys.argv[2:6]
print(f"{label:34s} wall {float(wall):6.2f} s  cpu {float(user) + float(sys_):6.2f} s  "
      f"evaluations {evals:7d}  cost {cost:.6g} Nm^2")
PY
}
run "default (GA + polish + stribeck)"
run "default with --no-static" --no-static
run "paper GA alone (--paper --no-polish)" --paper --no-polish --no-static
