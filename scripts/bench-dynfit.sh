#!/usr/bin/env bash
# Times mo-dynfit on one hour of 1 kHz data (3.6 million rows) of the simulated paper arm whose
# URDF is wrong (tests/data/dynfit: true.json simulates, nominal.json is fitted): wall and CPU
# time and peak memory of the fit, from a binary stream file (so the simulator is not timed),
# and the held-out RMS before/after it reports.
#   scripts/bench-dynfit.sh [BUILD_DIR] [SECONDS]      (defaults: build, 3600)
# Wall times depend on what else runs: the CPU column is the better measure on a shared machine.
set -euo pipefail
build=${1:-build}
seconds=${2:-3600}
here=$(cd "$(dirname "$0")/.." && pwd)
for t in bin/mo-sim bin/mo-dynfit; do
  [[ -x $build/$t ]] || { echo "bench-dynfit: $build/$t not built (cmake --build $build --target mo-sim mo-dynfit)" >&2; exit 1; }
done
work=$(mktemp -d /tmp/momentum-bench-dynfit.XXXXXX)
trap 'rm -rf "$work"' EXIT
data=$here/tests/data/dynfit
echo "== simulating $seconds s at 1 kHz (not timed)"
"$build/bin/mo-sim" -q -p "$data/true.json" --trajectory multisine --duration "$seconds" --seed 11 \
  --output-format bin -o "$work/log.bin"
echo "== mo-dynfit, $(nproc) cores, load $(cut -d' ' -f1 /proc/loadavg)"
/usr/bin/time -f "%e %U %S %M" -o "$work/time" \
  "$build/bin/mo-dynfit" -q -p "$data/nominal.json" --torque-held "$work/log.bin" --report "$work/r.json"
read -r wall user sys rss < "$work/time"
python3 - "$work/r.json" "$wall" "$user" "$sys" "$rss" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
wall, user, sys_, rss = map(float, sys.argv[2:])
rows = r["data"]["samples_fitted"] + r["data"]["samples_held_out"]
print(f"fit time: wall {wall:.1f} s, cpu {user + sys_:.1f} s, peak memory {rss / 1024:.1f} MB")
print(f"rows counted: {rows} ({r['data']['seconds_fitted']:.0f} s fitted, {r['data']['seconds_held_out']:.0f} s held out); "
      f"{(user + sys_) / max(rows, 1) * 1e6:.2f} us cpu per counted row")
print(f"rank {r['rank']} of {r['columns']}, condition number {r['condition_number']:.3g}")
for j, (b, a) in enumerate(zip(r["rms_before"], r["rms_after"])):
    print(f"joint {j + 1}: held-out RMS {b:.4f} -> {a:.4f} Nm")
PY
