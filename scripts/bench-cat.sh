#!/usr/bin/env bash
# Throughput of mo-cat on a 1,000,000-row, 19-column stream (t, q1-6, dq1-6, i1-6):
# CSV -> binary, binary -> CSV, binary -> binary, in MB/s (of input) and rows/s.
#   scripts/bench-cat.sh [BUILD_DIR] [ROWS]
set -euo pipefail
build=${1:-build}
rows=${2:-1000000}
bin=$(cd "$build/bin" && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

awk -v n="$rows" 'BEGIN {
  srand(1); printf "t"; for (j = 1; j <= 6; j++) printf ",q%d", j;
  for (j = 1; j <= 6; j++) printf ",dq%d", j; for (j = 1; j <= 6; j++) printf ",i%d", j; print "";
  for (r = 0; r < n; r++) { t = r * 0.001; printf "%.3f", t;
    for (j = 1; j <= 6; j++) printf ",%.17g", sin(t * j) + rand() * 1e-3;
    for (j = 1; j <= 6; j++) printf ",%.17g", j * cos(t * j);
    for (j = 1; j <= 6; j++) printf ",%.6f", rand() * 4 - 2;
    print "" } }' > "$tmp/in.csv"
"$bin/mo-cat" -q --output-format bin "$tmp/in.csv" > "$tmp/in.bin"

run() {  # label input output-format
  local label=$1 input=$2 format=$3 best=""
  for _ in 1 2 3; do
    local start end
    start=$(date +%s.%N)
    "$bin/mo-cat" -q --output-format "$format" "$input" > "$tmp/out"
    end=$(date +%s.%N)
    best=$(echo "$start $end $best" | awk '{d = $2 - $1; if ($3 == "" || d < $3) print d; else print $3}')
  done
  local bytes
  bytes=$(stat -c %s "$input")
  awk -v l="$label" -v s="$best" -v b="$bytes" -v r="$rows" \
    'BEGIN { printf "%-14s %8.1f MB/s %12.0f rows/s  (%.3f s, best of 3)\n", l, b / s / 1e6, r / s, s }'
}
echo "mo-cat, $rows rows x 19 columns ($(stat -c %s "$tmp/in.csv") bytes CSV, $(stat -c %s "$tmp/in.bin") bytes binary)"
run "csv -> bin" "$tmp/in.csv" bin
run "bin -> csv" "$tmp/in.bin" csv
run "bin -> bin" "$tmp/in.bin" bin
