#!/usr/bin/env bash
# Times a night's recalibration of one robot from a day of logs (man momentum, "nightly").
#   scripts/bench-nightly.sh [--hours H] [--rate HZ] [--work DIR] [--dynfit-all] [--script] [BUILD_DIR]
# defaults: 8 hours, 1 kHz, a fresh work folder (deleted at exit unless --work is given), build.
#
# The day: H hourly files of the simulated 6-joint UR5 (tests/data/ur5-sim.json: true friction
# LuGre, sensors of a real controller) in multisine and paper motion, collision-free, binary
# streams. Simulating them is not timed (2 files at a time; with --work they are kept and
# reused). The night, each step timed for wall, CPU and peak memory:
#   1. mo-dynfit on the first half of the day (both kinds of motion): the inertial corrections
#      (held-out check inside; nightly-recalibrate.sh runs it on its calibration part, the
#      odd hours, here the first half for the reason below). On the simulated day, each fit
#      held to mo-dynfit's sample budget (1.8 M of the 14.4 M and 28.8 M samples), hours 1-4
#      and all 8 agree on every identified parameter within 0.93 of their combined
#      uncertainty. Before the budget, hours 1, 3, 5, 7 (multisine only) differed from all 8
#      by up to 2.9 of its uncertainty: the half must keep the day's mix of motion, since the
#      friction model's error differs between them (--dynfit-all: every hour);
# then the commands of nightly-recalibrate.sh --jobs 2, with the corrected profile in place,
# where every observed stream goes through a named pipe to the one tool that reads it (none is
# written to a file):
#   2. mo-lugre-fit --seed 1 on the 1st, 3rd, ... hours (the calibration part, as the script
#      splits), observed by mo-observe --strict as it reads them;
#   3. mo-calibrate --reject-contact --strict on the calibration part, observed again with the
#      fitted friction;
#   4. mo-detect on the 2nd, 4th, ... hours (the check part), observed with the candidate and
#      with the profile in place (2 logs at a time): the candidate's count of events must be one
#      its calibration's stated false-alarm rate makes likelier than 0.01 over those hours (the
#      script's rule).
# Issue 30's target on 2 free cores: the whole night under 60 s (an earlier one: 2 minutes, 100 MB).
# --script: then runs share/momentum/examples/nightly-recalibrate.sh --jobs 2 --torque-held on
# the same day (a copy of the profile; its own split: dynfit on the calibration part) and prints
# its wall time, CPU, largest process and its JSON line's outcome.
set -euo pipefail
hours=8 rate=1000 work="" keep=0 dynfit_all=0 script=0
while (($#)); do
  case $1 in
    --hours) hours=${2:?}; shift 2 ;;
    --rate) rate=${2:?}; shift 2 ;;
    --work) work=${2:?}; keep=1; shift 2 ;;
    --dynfit-all) dynfit_all=1; shift ;;
    --script) script=1; shift ;;
    -h|--help) sed -n '2,32p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    -*) echo "bench-nightly: unknown option $1" >&2; exit 2 ;;
    *) break ;;
  esac
done
build=$(cd "${1:-build}" && pwd)
here=$(cd "$(dirname "$0")/.." && pwd)
for t in mo-sim mo-dynfit mo-observe mo-lugre-fit mo-calibrate mo-detect; do
  [[ -x $build/bin/$t ]] || { echo "bench-nightly: $build/bin/$t not built (cmake --build $build)" >&2; exit 1; }
done
export PATH=$build/bin:$PATH
if [[ -z $work ]]; then
  work=$(mktemp -d /tmp/momentum-bench-nightly.XXXXXX)
  trap 'rm -rf "$work"' EXIT
fi
mkdir -p "$work/day" "$work/night"
cp "$here/tests/data/ur5-sim.json" "$here/tests/data/ur5_robot.urdf" "$work/"
profile=$work/ur5-sim.json

echo "== the day: $hours hourly files at $rate Hz of a 6-joint arm (simulated, not timed)"
simulate() {  # hour
  local h=$1 file
  file=$(printf '%s/day/hour-%02d.bin' "$work" "$h")
  [[ -s $file ]] && return 0
  # Alternate rich excitation and the paper's smooth sines, each hour a different seed.
  local trajectory=multisine
  ((h % 2)) || trajectory=paper
  mo-sim -q -p "$profile" --seed "$h" --rate "$rate" --duration 3600 --trajectory "$trajectory" \
    --integrator semi-implicit --internal-rate $((rate * 2 > 2000 ? rate * 2 : 2000)) \
    --output-format bin -o "$file.part" && mv "$file.part" "$file"
}
export -f simulate
export work profile rate
seq 1 "$hours" | xargs -P 2 -I{} bash -c 'simulate {}'
mapfile -t logs < <(ls "$work"/day/hour-*.bin | head -n "$hours")
calibration=() check=()
for i in "${!logs[@]}"; do
  if ((i % 2 == 0)); then calibration+=("${logs[i]}"); else check+=("${logs[i]}"); fi
done
du -sh "$work/day" | awk '{print "   " $1 " on disk"}'

total_wall=0 total_cpu=0 peak=0
# Runs a step under /usr/bin/time; with several commands (one per line on stdin), 2 at a time,
# the peak being the largest single process's.
step() {  # label, then the command; or label and -P (commands on stdin)
  local label=$1; shift
  local t0 t1 wall cpu rss=0 status=0
  : > "$work/night/times"
  t0=$(date +%s.%N)
  if [[ $1 == -P ]]; then
    xargs -P 2 -d '\n' -I{} /usr/bin/time -a -o "$work/night/times" -f "%U %S %M" bash -c '{}' || status=$?
  else
    /usr/bin/time -a -o "$work/night/times" -f "%U %S %M" "$@" || status=$?
  fi
  t1=$(date +%s.%N)
  ((status == 0)) || label="$label (exit $status)"
  read -r wall cpu rss < <(awk -v a="$t0" -v b="$t1" '
    NF == 3 && $1 ~ /^[0-9.]+$/ { cpu += $1 + $2; if ($3 > rss) rss = $3 }
    END { printf "%.2f %.2f %d\n", b - a, cpu, rss }' "$work/night/times")
  printf '%-44s wall %7.2f s  cpu %7.2f s  peak %6.1f MB\n' "$label" "$wall" "$cpu" "$(echo "$rss / 1024" | bc -l)"
  total_wall=$(echo "$total_wall + $wall" | bc -l)
  total_cpu=$(echo "$total_cpu + $cpu" | bc -l)
  ((rss > peak)) && peak=$rss
  return 0
}

echo "== the night, $(nproc) cores, load $(cut -d' ' -f1 /proc/loadavg)"
dynfit_logs=("${logs[@]:0:$(((${#logs[@]} + 1) / 2))}")
((dynfit_all)) && dynfit_logs=("${logs[@]}")
step "1. mo-dynfit, ${#dynfit_logs[@]} h" \
  mo-dynfit -q -p "$profile" --torque-held -o "$work/night/corrected.json" --report "$work/night/dynfit.json" "${dynfit_logs[@]}"
corrected=$work/night/corrected.json
[[ -s $corrected ]] || { echo "bench-nightly: mo-dynfit wrote no profile (see $work/night/dynfit.json)" >&2; cp "$profile" "$corrected"; }

# Runs a command on the logs observed with a profile, each streamed through a named pipe
# $work/night/PREFIX-NAME that the command (given those paths after its own arguments) reads as
# the observer writes it, as nightly-recalibrate.sh does: no observed stream goes to a file.
on_streams() {  # profile prefix log... -- command...
  local profile=$1 prefix=$2 f fd status=0
  shift 2
  local -a pipes=() pids=()
  while [[ $1 != -- ]]; do
    pipes+=("$work/night/$prefix-$(basename "$1")")
    rm -f "${pipes[-1]}" && mkfifo "${pipes[-1]}"
    mo-observe -q --strict -p "$profile" --output-format bin -o "${pipes[-1]}" "$1" &
    pids+=($!)
    shift
  done
  shift
  "$@" "${pipes[@]}" || status=$?
  # A command that stopped early left observers waiting for it to open their pipes.
  for f in "${pipes[@]}"; do exec {fd}<> "$f" && exec {fd}<&-; done
  for f in "${pids[@]}"; do wait "$f" || status=1; done
  rm -f "${pipes[@]}"
  return $status
}
export -f on_streams

step "2. mo-observe -> mo-lugre-fit, ${#calibration[@]} h" \
  bash -c 'on_streams "$@"' on_streams "$corrected" mid "${calibration[@]}" -- \
  mo-lugre-fit -q --seed 1 -p "$corrected" -o "$work/night/fitted.json" --report "$work/night/lugre.json"
fitted=$work/night/fitted.json
[[ -s $fitted ]] || { echo "bench-nightly: mo-lugre-fit wrote no profile" >&2; exit 1; }

step "3. mo-observe -> mo-calibrate, ${#calibration[@]} h" \
  bash -c 'on_streams "$@"' on_streams "$fitted" new "${calibration[@]}" -- \
  sh -c 'report=$1; shift; exec mo-calibrate "$@" > "$report"' sh "$work/night/calibration.txt" \
  -q --reject-contact --strict -p "$fitted" -o "$work/night/calibrated.json"

if [[ ! -s $work/night/calibrated.json ]]; then
  # The script would end the night here, keeping the profile in place (see calibration.txt
  # for the outlier): the check is timed on thresholds calibrated without --reject-contact,
  # made here untimed.
  echo "   mo-calibrate refused the calibration part: nightly-recalibrate.sh keeps the profile here;" \
    "step 4 runs on thresholds calibrated without --reject-contact (not timed)"
  on_streams "$fitted" new "${calibration[@]}" -- mo-calibrate -q --strict -p "$fitted" -o "$work/night/calibrated.json" \
    > "$work/night/calibration-accepting.txt" || true
fi

# The check part observed and judged by the candidate and by the profile in place, 2 logs at a
# time. (The profile in place may hold no thresholds: mo-detect's status 2, which the script
# counts as none.) (The commands go through a file: a pipe into step would run it in a
# subshell, losing the totals.)
for f in "${check[@]}"; do
  name=$(basename "$f")
  echo "on_streams '$work/night/calibrated.json' new '$f' -- mo-detect -q -p '$work/night/calibrated.json' > '$work/night/new-$name.events.csv'; [ \$? -le 1 ]"
  echo "on_streams '$profile' old '$f' -- mo-detect -q -p '$profile' > '$work/night/old-$name.events.csv' 2> /dev/null; [ \$? -le 2 ]"
done > "$work/night/commands"
step "4. mo-observe -> mo-detect on the check part, ${#check[@]} h" -P < "$work/night/commands"
events=$(cat "$work"/night/new-*.events.csv 2>/dev/null | grep -c ',onset,' || true)
report=$work/night/calibration.txt
[[ -s $work/night/calibration-accepting.txt ]] && report=$work/night/calibration-accepting.txt
rate=$(awk '$1 == "#" && $2 == "mu" && $3 == "false" && $5 == "stated:" {
    r = $6; for (k = 6; k < NF; ++k) if ($k == "aim" && $(k + 1) == "at") r = $(k + 2); print r }' "$report")

printf '%-44s wall %7.2f s  cpu %7.2f s  peak %6.1f MB\n' "the night" "$total_wall" "$total_cpu" "$(echo "$peak / 1024" | bc -l)"
old_events=$(cat "$work"/night/old-*.events.csv 2>/dev/null | grep -c ',onset,' || true)
awk -v n="$events" -v r="${rate:-nan}" -v h="${#check[@]}" -v old="$old_events" 'BEGIN {
  m = r * h; below = 0; term = exp(-m)
  for (k = 0; k < n; ++k) { below += term; term *= m / (k + 1) }
  printf "events on the check part (%d h, collision-free): %d; the calibration stands for %.3g (%.3g per h): " \
    "as many or more by chance %.3g, %s at the script'"'"'s level 0.01; with the profile in place: %s\n",
    h, n, m, r, 1 - below, (1 - below < 0.01) ? "refused" : "accepted", old }'
python3 - "$work/night/dynfit.json" "$work/night/lugre.json" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
print("dynfit: outcome:", d.get("outcome"), "| held-out RMS before -> after (Nm):",
      " ".join(f"{b:.3f}->{a:.3f}" for b, a in zip(d["rms_before"], d["rms_after"])))
l = json.load(open(sys.argv[2]))
for j in l["joints"]:
    m = j["fit"]["metrics"]
    print(f"lugre-fit joint {j.get('joint', '?')}: rms {m.get('rms', float('nan')):.3f} Nm")
PY
if ((script)); then
  echo "== nightly-recalibrate.sh --jobs 2 --torque-held on the same day"
  rm -rf "$work/script" && mkdir -p "$work/script"
  cp "$here/tests/data/ur5-sim.json" "$here/tests/data/ur5_robot.urdf" "$work/script/"
  /usr/bin/time -o "$work/script/time" -f "%e %U %S %M" "$here/share/momentum/examples/nightly-recalibrate.sh" \
    -p "$work/script/ur5-sim.json" --jobs 2 --torque-held --json "$work/script/night.jsonl" "${logs[@]}" \
    2> "$work/script/stderr" || true
  read -r wall user sys rss < <(tail -n 1 "$work/script/time")  # (GNU time may first say the exit status)
  python3 - "$work/script/night.jsonl" "$wall" "$user" "$sys" "$rss" <<'PY'
import json, sys
line = json.loads(open(sys.argv[1]).read().splitlines()[-1])
wall, user, system, rss = map(float, sys.argv[2:])
print(f"the script: wall {wall:.1f} s, cpu {user + system:.1f} s, largest process {rss / 1024:.1f} MB; "
      f"outcome {line['outcome']}" + (f" ({line['reason']})" if line.get("reason") else ""))
if line.get("check_events"):
    c = line["check_events"]
    print(f"  check part: {c['candidate']} events over {c['hours']} h, its calibration stands for {c['expected']}")
PY
fi
((keep)) && echo "work folder kept: $work"
exit 0
