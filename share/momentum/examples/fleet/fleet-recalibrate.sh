#!/usr/bin/env bash
# fleet-recalibrate.sh: the nightly recalibration of every robot of a fleet on one machine,
# with GNU parallel (no scheduler of our own). Each robot's night is recalibrate-robot.sh (which
# runs ../nightly-recalibrate.sh); each writes one JSON line, collected in a results file and
# printed on standard output; a one-line summary goes to standard error.
#
#   fleet-recalibrate.sh [-j N] [--day DAY] [--results FILE] FLEET [-- nightly options...]
#   fleet-recalibrate.sh --day 2024-05-17 /srv/fleet -- --margin-percent 10
#
# The fleet's folder: FLEET/robots/NAME/profile.json (with its URDF), FLEET/robots/NAME/logs/DAY/
# (the day's *.csv, *.bin), FLEET/robots/NAME/backups/ (replaced profiles, nightly.log).
#   -j, --jobs N      robots at a time (default: nproc; each night uses one core)
#   --day DAY         the logs folder's name (default: yesterday, date -d yesterday +%F)
#   --results FILE    append the lines to FILE (default: FLEET/results/DAY.jsonl)
#   after --           options for nightly-recalibrate.sh, the same for every robot
#
# Exit status: 0 when every robot's night ran to a result: installed, refused (a refusal is a
# result: the robot keeps yesterday's profile) or kept (nothing to go on); 1 when any failed
# (a broken log, a missing tool; the line says why, the robot's nightly.log says more) or ended
# alarming (neither its candidate nor its profile in place keeps its promise on the check logs:
# the line names the logs and the times of the events); 2 on a usage error.
#
# The fleet's night with jq (one line per robot; see README.md):
#   jq -r '.outcome' RESULTS | sort | uniq -c
#   jq -r 'select(.outcome != "installed") | "\(.robot): \(.outcome): \(.reason)"' RESULTS
#   jq -cs 'group_by(.outcome) | map({(.[0].outcome): map(.robot)}) | add' RESULTS
#   jq -r 'select(.outcome == "installed") | [.robot, (.thresholds_after.mu.moving | map(. * 100 | round / 100) | tostring)] | @tsv' RESULTS
# (RESULTS: FLEET/results/DAY.jsonl) print e.g.
#         2 installed
#         1 refused
#   arm-b: refused: calibration refused or failed (a contact in the calibration logs?)
#   {"installed":["arm-a","arm-c"],"refused":["arm-b"]}
#   arm-a   [0.59,0.82,0.42]
#   arm-c   [0.6,0.8,0.32]
set -uo pipefail
here=$(cd "$(dirname "$0")" && pwd)

usage() {  # [exit-status]: 2 (default) on standard error, else standard output
  local status=${1:-2}
  ((status == 0)) || exec >&2
  sed -n '/^#   fleet-recalibrate.sh \[/,/^#   after --/p' "$0" | sed 's/^# \{0,1\}//'
  exit "$status"
}
jobs="" day="" results="" fleet=""
while (($#)); do
  case $1 in
    -j | --jobs) jobs=${2:?}; shift 2 ;;
    --day) day=${2:?}; shift 2 ;;
    --results) results=${2:?}; shift 2 ;;
    --) shift; break ;;
    -h | --help) usage 0 ;;
    -*) echo "fleet-recalibrate: unknown option $1" >&2; usage ;;
    *) [[ -z $fleet ]] || usage; fleet=$1; shift ;;
  esac
done
[[ -n $fleet ]] || usage
for tool in parallel jq python3; do
  command -v "$tool" > /dev/null || { echo "fleet-recalibrate: $tool not found (apt-get install $tool)" >&2; exit 2; }
done
jobs=${jobs:-$(nproc)}
[[ $jobs =~ ^[1-9][0-9]*$ ]] || { echo "fleet-recalibrate: -j takes a number of robots" >&2; exit 2; }
day=${day:-$(date -d yesterday +%F)}
results=${results:-$fleet/results/$day.jsonl}
mapfile -t robots < <("$here/robot-at-index.sh" --all "$fleet") || exit 2
((${#robots[@]})) || { echo "fleet-recalibrate: no robot in $fleet/robots/*/profile.json" >&2; exit 2; }
mkdir -p "$(dirname "$results")" || exit 2
night=$(mktemp "${TMPDIR:-/tmp}/momentum-fleet.XXXXXX") || exit 2
trap 'rm -f "$night"' EXIT

start=$SECONDS
# --group (parallel's default): a robot's line comes out whole when its night ends. -q: the
# command's words reach recalibrate-robot.sh as they are (spaces in paths). The exit status of
# parallel counts failed nights; what counts here is the lines.
parallel -j "$jobs" -q "$here/recalibrate-robot.sh" --fleet "$fleet" --day "$day" --robot {} -- "$@" \
  ::: "${robots[@]}" | tee -a "$results" > "$night"
cat "$night"

# The summary, and which robots have no line.
summary=$(jq -rs --arg day "$day" --argjson robots "${#robots[@]}" '
  (group_by(.outcome) | map("\(length) \(.[0].outcome)") | join(", ")) as $counts
  | "fleet: day \($day), \($robots) robots: \(if $counts == "" then "no results" else $counts end)"
' "$night") || summary="fleet: day $day, ${#robots[@]} robots: unreadable results (see $results)"
lines=$(grep -c '^{' "$night")
failed=$(jq -s '[.[] | select(.outcome == "failed" or .outcome == "alarming")] | length' "$night" 2> /dev/null || echo 1)
missing=""
((lines == ${#robots[@]})) || missing=", $((${#robots[@]} - lines)) robots without a result"
echo "$summary$missing; $((SECONDS - start)) s, -j $jobs; results in $results" >&2
((lines == ${#robots[@]} && failed == 0)) || exit 1
exit 0
