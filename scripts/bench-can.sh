#!/usr/bin/env bash
# Times mo-can2csv on a large synthetic candump -L capture of a 6-joint CANopen arm at 1 kHz
# (SYNC + 2 TPDOs per joint = 13 frames per cycle), in the row-per-cycle mode and with --long.
#   scripts/bench-can.sh [BUILD_DIR] [CYCLES]      (defaults: build, 200000 cycles = 2.6 M frames)
# Prints frames per second (wall clock, one core) for each mode.
set -euo pipefail
build=${1:-build}
cycles=${2:-200000}
tool="$build/bin/mo-can2csv"
[[ -x $tool ]] || { echo "bench-can: $tool not built (cmake --build $build --target mo-can2csv)" >&2; exit 1; }
work=$(mktemp -d /tmp/momentum-bench-can.XXXXXX)
trap 'rm -rf "$work"' EXIT

python3 - "$work" "$cycles" <<'PY'
import struct, sys, math
work, cycles = sys.argv[1], int(sys.argv[2])
with open(f"{work}/arm.dbc", "w") as dbc:
    for j in range(1, 7):
        dbc.write(f"BO_ {0x180 + j} Joint{j}_TPDO1: 8 Drive{j}\n"
                  f" SG_ q{j} : 0|32@1- (1E-006,0) [-10|10] \"rad\" Host\n"
                  f" SG_ dq{j} : 32|32@1- (1E-005,0) [-10|10] \"rad/s\" Host\n"
                  f"BO_ {0x280 + j} Joint{j}_TPDO2: 4 Drive{j}\n"
                  f" SG_ i{j} : 0|16@1- (0.001,0) [-30|30] \"A\" Host\n"
                  f" SG_ tau_m{j} : 23|16@0- (0.01,0) [-300|300] \"Nm\" Host\n")
with open(f"{work}/run.log", "w") as log:
    t0 = 1700000000 * 1000000
    out = []
    for k in range(cycles):
        t = t0 + 1000 * k
        out.append("(%d.%06d) can0 080#\n" % divmod(t, 1000000))
        for j in range(1, 7):
            q = int(1e6 * math.sin(0.001 * k + j)) & 0xFFFFFFFF
            out.append("(%d.%06d) can0 %03X#%08X%08X\n" % (*divmod(t + 50 * j, 1000000), 0x180 + j, q, (q * 7) & 0xFFFFFFFF))
            out.append("(%d.%06d) can0 %03X#%04X%04X\n" % (*divmod(t + 50 * j + 25, 1000000), 0x280 + j, k & 0xFFFF, j))
        if len(out) > 100000:
            log.write("".join(out))
            out = []
    log.write("".join(out))
PY

frames=$((cycles * 13))
size=$(du -m "$work/run.log" | cut -f1)
echo "bench-can: $frames frames, ${size} MB of candump -L text"
run() {
  local label=$1; shift
  local start end
  start=$(date +%s.%N)
  "$tool" --dbc "$work/arm.dbc" "$@" "$work/run.log" > /dev/null
  end=$(date +%s.%N)
  python3 -c "import sys; s=$end-$start; print(f'bench-can: {sys.argv[1]:<22} {s:7.3f} s  {$frames/s/1e6:6.2f} M frames/s')" "$label"
}
run "rows per cycle (csv)" --stats
run "rows per cycle (bin)" --output-format bin
run "--long (csv)" --long
