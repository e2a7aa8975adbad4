#!/usr/bin/env bash
# Throughput of mo-observe on a 1,000,000-row binary stream for the UR5 (6 joints) and the
# Panda (7): the reference motions of tests/data tiled end to end (t keeps increasing), columns
# t, q<j>, dq<j>, tau_m<j>. Reports rows/s and joint-samples/s (rows x joints), best of 3, for
# the first-order observer, the second order, and the second order with LuGre compensation.
#   scripts/bench-observe.sh [BUILD_DIR] [ROWS] [--callgrind]
# With --callgrind, also profiles 200,000 UR5 rows under valgrind --tool=callgrind (order 1
# without friction, with and without the signal check, and order 2 with LuGre) and prints the
# instructions per row of the parts: the momentum pass (four rows at once where the CPU has
# AVX2: model/momentum_batch.hpp), the filters, the signal check, the reader with its
# time-order policy.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
rows=${2:-1000000}
profile_run=${3:-}
bin=$(cd "$build/bin" && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# Binary stream (mo-log(5)) written directly: header, then float64 rows.
make_stream() {  # robot joints rows out
  python3 - "$1" "$2" "$3" "$4" <<'EOF'
import array, struct, sys
robot, n, rows, out = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
lines = [l for l in open(f"tests/data/{robot}.traj.csv") if not l.startswith("#")]
header = lines[0].strip().split(",")
names = ["t"] + [f"{p}{j}" for p in ("q", "dq", "tau_m") for j in range(1, n + 1)]
index = [header.index(c) for c in names[1:]]
motion = [[float(f[i]) for i in index] for f in (l.split(",") for l in lines[1:])]
with open(out, "wb") as f:
    f.write(b"\x89MOLOG\r\n" + struct.pack("<III", 1, len(names), 0))
    for name in names:
        f.write(struct.pack("<I", len(name)) + name.encode())
    block = array.array("d")
    for k in range(rows):
        block.append(k * 0.001)
        block.extend(motion[k % len(motion)])
        if len(block) > 1 << 20:
            block.tofile(f)
            block = array.array("d")
    block.tofile(f)
EOF
}

# A profile with the observer and LuGre friction for every joint (the paper's joint-1 values).
make_profile() {  # robot-profile joints out
  python3 - "$1" "$2" "$3" <<'EOF'
import json, os, re, sys
src, n, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
text = re.sub(r"//[^\n]*", "", open(src).read())
profile = json.loads(text)
profile["urdf"] = os.path.abspath(os.path.join(os.path.dirname(src), profile["urdf"]))
profile["friction"] = {"model": "lugre", "joints": [
    {"sigma0": 98467.9088, "sigma1": 314.0483, "sigma2": 6.4865, "tau_c": 7.8322,
     "tau_s": 4.0033, "w_s": 0.0978}] * n}
json.dump(profile, open(out, "w"))
EOF
}

# Best of 3 by CPU time (user + sys; the machine may be shared), wall time alongside. Its user
# and system parts are printed too: on a VM the kernel's copy of the input from the page cache
# (system time) has been seen to vary tenfold from minute to minute, the program's own work not.
best_of_3() {  # label rows joints command...
  local label=$1 n=$2 joints=$3 best="" wall="" user="" sys=""
  shift 3
  for _ in 1 2 3; do
    local times
    times=$( { TIMEFORMAT='%R %U %S'; time "$@" > /dev/null; } 2>&1 | tail -1)
    read -r w u s <<< "$times"
    local cpu
    cpu=$(awk -v u="$u" -v s="$s" 'BEGIN { print u + s }')
    if [[ -z $best ]] || awk -v a="$cpu" -v b="$best" 'BEGIN { exit !(a < b) }'; then best=$cpu; wall=$w; user=$u; sys=$s; fi
  done
  awk -v l="$label" -v s="$best" -v w="$wall" -v r="$n" -v j="$joints" -v u="$user" -v k="$sys" \
    'BEGIN { printf "%-34s %10.0f rows/s %11.0f joint-samples/s  (cpu %.3f s = user %.3f + sys %.3f, wall %.3f s)\n", l, r / s, r * j / s, s, u, k, w }'
}

for spec in ur5:6 panda:7; do
  robot=${spec%:*}
  joints=${spec#*:}
  make_stream "$robot" "$joints" "$rows" "$tmp/$robot.bin"
  make_profile "tests/data/$robot.json" "$joints" "$tmp/$robot-friction.json"
  echo "$robot: $rows rows x $((1 + 3 * joints)) columns, $(stat -c %s "$tmp/$robot.bin") bytes binary"
  best_of_3 "  mo-cat bin -> bin (I/O floor)" "$rows" "$joints" "$bin/mo-cat" -q "$tmp/$robot.bin"
  best_of_3 "  order 1" "$rows" "$joints" "$bin/mo-observe" -q -p "tests/data/$robot.json" "$tmp/$robot.bin"
  best_of_3 "  order 1, no signal check" "$rows" "$joints" "$bin/mo-observe" -q -p "tests/data/$robot.json" --no-signal-check "$tmp/$robot.bin"
  best_of_3 "  order 2 (K1 50, K2 5)" "$rows" "$joints" "$bin/mo-observe" -q -p "tests/data/$robot.json" --order 2 --k2 5 "$tmp/$robot.bin"
  best_of_3 "  order 2 + LuGre (r, tau_f, mu)" "$rows" "$joints" "$bin/mo-observe" -q -p "$tmp/$robot-friction.json" --order 2 --k2 5 "$tmp/$robot.bin"
done

if [[ $profile_run == --callgrind ]]; then
  # Instructions per row, inclusive, by part: callgrind counts them reproducibly on a shared
  # machine. 200,000 UR5 rows, binary in and out; the signal check on (the default).
  profile_rows=200000
  make_stream ur5 6 "$profile_rows" "$tmp/small.bin"
  profile() {  # label, then mo-observe's options
    local label=$1
    shift
    valgrind --tool=callgrind --callgrind-out-file="$tmp/callgrind.out" \
      "$bin/mo-observe" -q "$@" "$tmp/small.bin" > /dev/null 2> "$tmp/valgrind.log"
    echo "callgrind, $profile_rows UR5 rows, $label: instructions per row, inclusive"
    callgrind_annotate --inclusive=yes "$tmp/callgrind.out" 2>/dev/null | awk -v rows="$profile_rows" '
      /PROGRAM TOTALS/ { gsub(",", "", $1); printf "  %-58s %7.0f\n", "whole program", $1 / rows }
      /:momentum::observer::SignalCheck::(plainly_passes|learn|disagree|velocity_jumps|beyond_limits|velocity_on_trend)\(/ {
        # The signal check: the sum of its entry points (they do not call each other), each
        # by its largest line, which is its inclusive cost: its code is partly inlined from
        # other files (lanes.hpp, statistics.hpp), and its AVX2 clone is a function of its own.
        n = $1; gsub(",", "", n)
        match($0, /SignalCheck::[a-z_]+\(/)
        fn = substr($0, RSTART + 13, RLENGTH - 14)
        if (n + 0 > check_of[fn] + 0) check_of[fn] = n
        next
      }
      /\[.*mo-observe\]$/ || /libm/ {
        n = $1; gsub(",", "", n)
        name = ""
        if ($0 ~ /StreamObserver::run\(/ && $0 !~ /lambda/) name = "StreamObserver::run (everything per row)"
        else if ($0 ~ /MomentumObserver::step/) name = "MomentumObserver::step (filters; dynamics not computed ahead)"
        else if ($0 ~ /momentum_pass<|MomentumBatchPass::(avx2|baseline)\(/) {
          # The momentum pass: one row at a time, or four at once (MomentumBatch); the sum of
          # the two, each by its largest line.
          fn = ($0 ~ /MomentumBatchPass/) ? "batch" : "single"
          if (n + 0 > pass_of[fn] + 0) pass_of[fn] = n
          next
        }
        else if ($0 ~ /ResidualObserver::step/) name = "  ResidualObserver::step (filters + friction)"
        else if ($0 ~ /__sincos/) name = "  libm sincos (in the momentum pass)"
        else if ($0 ~ /__expm1/) name = "  libm expm1 (LuGre)"
        else if ($0 ~ /__exp_fma|__exp1|__ieee754_exp/) name = "  libm exp (LuGre Stribeck level)"
        else if ($0 ~ /Reader::next\(/) name = "stream::Reader::next (reader + time order)"
        else if ($0 ~ /Writer::row/) name = "stream::Writer::row"
        if (name != "" && !(name in seen)) { seen[name] = 1; printf "  %-58s %7.0f\n", name, n / rows }
      }
      END {
        for (fn in pass_of) pass += pass_of[fn]
        printf "  %-58s %7.0f\n", "momentum pass (p, beta; one row or four at once)", pass / rows
        for (fn in check_of) check += check_of[fn]
        printf "  %-58s %7.0f\n", "SignalCheck (one pass, learn, full tests)", check / rows
      }'
  }
  profile "order 1, no friction" -p tests/data/ur5.json
  profile "order 1, no friction, no signal check" -p tests/data/ur5.json --no-signal-check
  profile "order 2 + LuGre" -p "$tmp/ur5-friction.json" --order 2 --k2 5
fi
