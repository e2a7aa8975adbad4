#!/usr/bin/env bash
# Builds the libFuzzer targets (candump text, DBC, URDF to chain, CSV stream, binary stream, ROS 2
# bag in MCAP, robot profile) with clang and runs each from the captures and DBC files of
# tests/data/can, the URDFs of tests/data and tests/cli (each prefixed with its "ROOT TIP" line),
# the CSV streams of tests/data and tests/cli (and the same converted to binary, with a comment
# record), the bags of tests/data/mcap (and the uncompressed one with its chunks' CRCs zeroed, so
# that mutations reach the records inside), the profiles of tests/data and tests/cli, plus the
# inputs that once failed
# (tests/fuzz/regressions/<target>).
#   tests/fuzz/run.sh [RUNS]      RUNS inputs per target (default 20000) with a fixed seed, so
#                                 that CI is reproducible: the same tree gives the same verdict
#   FUZZ_SECONDS=600 tests/fuzz/run.sh    explore for that long instead, with a random seed
# Exits non-zero when a fuzzer finds a crash, a leak or undefined behaviour; the reproducer is
# left in the work directory and its path printed (add it to tests/fuzz/regressions/<target>/).
set -euo pipefail
runs=${1:-20000}
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
mkdir -p "$work/generated/momentum"
# The header CMake generates from version.hpp.in (this script builds without CMake).
version=$(sed -n 's/^project(momentum VERSION \([0-9.]*\).*/\1/p' "$src/CMakeLists.txt")
sed "s/@PROJECT_VERSION@/$version/" "$src/lib/include/momentum/version.hpp.in" > "$work/generated/momentum/version.hpp"
flags=(-std=c++20 -g -O1 -fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=undefined
  -I"$src/lib/include" -I"$work/generated" -isystem /usr/include/eigen3)
link_flags=(-fsanitize=fuzzer,address,undefined)
common_sources=("$src"/lib/src/stream/*.cpp "$src"/lib/src/core/*.cpp)
# URDF to chain needs these of model/; dynamics and the observer's stream code (two thirds of the
# instrumented compile) it does not.
model_sources=("$src"/lib/src/model/{model,collision,inertial_corrections,profile,profile_text}.cpp)
# The profile target reads the sections that the friction and detect stages own as well.
section_sources=("$src"/lib/src/friction/*.cpp "$src"/lib/src/detect/thresholds.cpp)
# FUZZ_TARGETS="stream_csv profile" builds and runs only those.
read -r -a targets <<< "${FUZZ_TARGETS:-candump dbc urdf stream_csv stream_binary stream_mcap profile}"
sources_of() {
  case $1 in
    urdf) printf '%s\n' "$src/tests/fuzz/urdf_fuzz.cpp" "${model_sources[@]}" "${common_sources[@]}" ;;
    profile) printf '%s\n' "$src/tests/fuzz/profile_fuzz.cpp" "${model_sources[@]}" "${section_sources[@]}" "${common_sources[@]}" ;;
    stream_*) printf '%s\n' "$src/tests/fuzz/$1_fuzz.cpp" "${common_sources[@]}" ;;
    *) printf '%s\n' "$src/tests/fuzz/$1_fuzz.cpp" "$src"/lib/src/can/*.cpp "${common_sources[@]}" ;;
  esac
}
object_of() { local rel=${1#"$src"/}; echo "$work/obj/${rel//\//_}.o"; }
status=0
# Each source compiles once, on every core (the targets share most of them), then each target links.
echo "fuzz: building ${targets[*]}"
mkdir -p "$work/obj"
printf '%s\n' "${flags[@]}" > "$work/compile.rsp"
export work src cxx
for target in "${targets[@]}"; do sources_of "$target"; done | sort -u |
  xargs -P "$(nproc)" -I{} bash -c 'rel=${1#"$src"/}; "$cxx" @"$work/compile.rsp" -c "$1" -o "$work/obj/${rel//\//_}.o"' _ {} ||
  { echo "fuzz: a source did not compile" >&2; exit 1; }
for target in "${targets[@]}"; do
  objects=()
  while read -r source; do objects+=("$(object_of "$source")"); done < <(sources_of "$target")
  libs=()
  [[ $target == urdf || $target == profile ]] && libs=(-lurdfdom_model -lconsole_bridge)
  libs+=(-lzstd -llz4)  # the stream stage's MCAP chunks (every target has the stream sources)
  "$cxx" "${link_flags[@]}" "${objects[@]}" "${libs[@]}" -o "$work/fuzz_$target" ||
    { echo "fuzz: $target did not link" >&2; exit 1; }
done
# One target's fuzzer on its corpus; 1 on a finding. The targets run side by side, as many at
# once as there are cores (each is single-threaded).
run_target() {
  local target=$1 corpus="$work/corpus_$1" max_len=4096
  [[ $target == urdf || $target == stream_mcap ]] && max_len=65536  # real URDFs and the bags: tens of kilobytes
  if ! (cd "$work" && ASAN_OPTIONS=detect_leaks=1 LSAN_OPTIONS=suppressions="$src/tests/lsan.supp":print_suppressions=0 "./fuzz_$target" "${budget[@]}" -max_len=$max_len -timeout=10 \
        -print_final_stats=1 -artifact_prefix="$work/${target}-" "$corpus" > "$work/$target.log" 2>&1); then
    echo "fuzz: $target FAILED; see $work/$target.log and $work/${target}-*" >&2
    tail -30 "$work/$target.log" >&2
    return 1
  fi
  grep -E "stat::number_of_executed_units|Done" "$work/$target.log" | sed "s/^/fuzz: $target: /" || true
}
running=0
for target in "${targets[@]}"; do
  corpus="$work/corpus_$target"
  mkdir -p "$corpus"
  if [[ $target == candump ]]; then
    cp "$src"/tests/data/can/*.log "$src"/tests/data/can/formats/*.log "$src"/tests/data/can/formats/*.txt "$corpus"/
  elif [[ $target == dbc ]]; then
    cp "$src"/tests/data/can/*.dbc "$src"/tests/data/can/formats/*.dbc "$corpus"/
  elif [[ $target == stream_csv || $target == stream_binary ]]; then
    # The streams of the tests: the data sets' and the golden cases' CSV files and standard
    # inputs, each cut to its first 4 KiB (the inputs' length limit below), as CSV; and as
    # binary (mo-log(5)), converted here with a comment record after the first row.
    python3 - "$src" "$corpus" "$target" <<'PY'
import glob, hashlib, os, struct, sys
src, corpus, target = sys.argv[1:4]
files = sorted(glob.glob(src + "/tests/data/**/*.csv", recursive=True) +
               glob.glob(src + "/tests/cli/*/*/*.csv") + glob.glob(src + "/tests/cli/*/*/stdin"))
def binary(text):
    lines = text.decode("utf-8", "replace").splitlines()
    comments = [l[1:] for l in lines if l.startswith("#")]
    body = [l for l in lines if l.strip() and not l.startswith("#")]
    if not body:
        return None
    columns = [c.strip() for c in body[0].split(",")]
    out = b"\x89MOLOG\r\n" + struct.pack("<III", 1, len(columns), len(comments[:2]))
    for s in comments[:2] + columns:
        b = s.encode()
        out += struct.pack("<I", len(b)) + b
    for n, row in enumerate(body[1:]):
        try:
            values = [float(v) for v in row.split(",")]
        except ValueError:
            continue
        if len(values) != len(columns):
            continue
        out += struct.pack("<%dd" % len(values), *values)
        if n == 0:
            note = b"fuzz seed comment"
            out += struct.pack("<QQ", 0x7ff84d4f434d4e54, len(note)) + note + b"\0" * (-len(note) % 8)
    return out
for path in files:
    data = open(path, "rb").read()
    if target == "stream_binary":
        data = binary(data[:65536])
        if data is None:
            continue
    data = data[:4096]
    if data:
        open(os.path.join(corpus, hashlib.sha1(data).hexdigest()), "wb").write(data)
PY
  elif [[ $target == stream_mcap ]]; then
    cp "$src"/tests/data/mcap/*.mcap "$corpus"/
    python3 - "$src/tests/data/mcap/uncompressed.mcap" "$corpus/uncompressed-no-crc.mcap" <<'PY'
import struct, sys
data = bytearray(open(sys.argv[1], "rb").read())
at = 8  # after the magic: top-level records, opcode (1) and length (8) each
while at + 9 <= len(data):
    opcode, length = data[at], struct.unpack_from("<Q", data, at + 1)[0]
    if opcode == 0x06:  # chunk: start, end, uncompressed_size (8 each), then its CRC
        data[at + 9 + 24:at + 9 + 28] = b"\0\0\0\0"
    if opcode == 0x02:
        break
    at += 9 + length
open(sys.argv[2], "wb").write(data)
PY
  elif [[ $target == profile ]]; then
    for profile in "$src"/tests/data/*.json "$src"/tests/data/*/profile.json "$src"/tests/cli/*/*/*.json; do
      head -c 4096 "$profile" > "$corpus/$(echo "$profile" | md5sum | cut -c1-16).json"
    done
  else
    # Each URDF with the chain its profile names (root and tip from the profile next to it).
    for profile in "$src"/tests/data/*.json "$src"/tests/cli/mo-model/urdf-*/profile.json; do
      python3 - "$profile" "$corpus" <<'PY' || true
import json, os, re, sys
path, corpus = sys.argv[1], sys.argv[2]
text = re.sub(r"^\s*//.*$", "", open(path).read(), flags=re.M)
try:
    p = json.loads(text)
    urdf = os.path.join(os.path.dirname(path), p["urdf"])
    body = open(urdf).read()
except Exception:
    sys.exit(0)
name = os.path.basename(os.path.dirname(path)) + "_" + os.path.basename(path) + ".txt"
open(os.path.join(corpus, name), "w").write(p["root"] + " " + p["tip"] + "\n" + body)
PY
    done
  fi
  if [[ -d "$src/tests/fuzz/regressions/$target" ]]; then
    cp "$src/tests/fuzz/regressions/$target"/* "$corpus"/
  fi
  echo "fuzz: running $target ($what)"
  run_target "$target" &
  if ((++running >= $(nproc))); then
    wait -n || status=1
    ((running--))
  fi
done
while ((running > 0)); do
  wait -n || status=1
  ((running--))
done
# A work folder of its own (not FUZZ_WORK) goes when every target passed: 165 MB of objects and
# corpora a run. A finding keeps it, with the inputs that crashed.
if ((status == 0)) && [[ -z ${FUZZ_WORK:-} ]]; then rm -rf "$work"; fi
exit $status
