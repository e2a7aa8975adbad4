#!/usr/bin/env bash
# recalibrate-robot.sh: one robot's night of a fleet, the job every scheduler here runs per
# robot (fleet-recalibrate.sh under GNU parallel, k8s-cronjob.yaml's pods, slurm-array.sbatch's
# tasks). Runs ../nightly-recalibrate.sh on the robot's profile and the day's logs and prints
# its JSON line; always exactly one line, also when the night could not start (no profile, the
# script killed): then outcome "failed" and the reason.
#
#   recalibrate-robot.sh --fleet DIR (--robot NAME | --index N [--list FILE]) [--day DAY]
#                        [--results DIR] [-- nightly-recalibrate.sh options...]
#
# The fleet's folder:
#   DIR/robots/NAME/profile.json   the robot's profile (and the URDF it names, beside it)
#   DIR/robots/NAME/logs/DAY/      the day's logs (*.csv, *.bin)
#   DIR/robots/NAME/backups/       replaced profiles and nightly.log (nightly-recalibrate.sh's
#                                  default: the profile's folder/backups)
# --index N picks the robot as robot-at-index.sh does (sorted folder names, or --list FILE).
# --day defaults to yesterday (date -d yesterday +%F), as nightly-recalibrate.cron.
# --results DIR also writes the line to DIR/NAME.json, replacing it (a retried index leaves one
# line per robot; a fleet summary is then `cat DIR/*.json | jq ...`).
# The nightly script is MOMENTUM_NIGHTLY, else ../nightly-recalibrate.sh beside this folder.
#
# Exit status: 0 when the night ran to a result (installed, dry-run, refused or kept: a refusal
# is a result); 1 when it failed or ended alarming (neither the candidate nor the profile in
# place keeps its promise on the check logs: the line names the logs and times); 2 on a usage
# error or an index past the end of the fleet.
set -uo pipefail
here=$(cd "$(dirname "$0")" && pwd)
nightly=${MOMENTUM_NIGHTLY:-$here/../nightly-recalibrate.sh}

usage() {  # [exit-status]: 2 (default) on standard error, else standard output
  local status=${1:-2}
  ((status == 0)) || exec >&2
  sed -n '/^#   recalibrate-robot.sh/,/^#  *\[--results/p' "$0" | sed 's/^# *//'
  exit "$status"
}
fleet="" robot="" index="" list="" day="" results=""
while (($#)); do
  case $1 in
    --fleet) fleet=${2:?}; shift 2 ;;
    --robot) robot=${2:?}; shift 2 ;;
    --index) index=${2:?}; shift 2 ;;
    --list) list=${2:?}; shift 2 ;;
    --day) day=${2:?}; shift 2 ;;
    --results) results=${2:?}; shift 2 ;;
    --) shift; break ;;
    -h | --help) usage 0 ;;
    *) echo "recalibrate-robot: unknown argument $1" >&2; usage ;;
  esac
done
[[ -n $fleet && -d $fleet ]] || { echo "recalibrate-robot: give the fleet's folder with --fleet" >&2; usage; }
if [[ -z $robot ]]; then
  [[ -n $index ]] || { echo "recalibrate-robot: give --robot NAME or --index N" >&2; usage; }
  if [[ -n $list ]]; then
    robot=$("$here/robot-at-index.sh" "$index" --list "$list") || exit 2
  else
    robot=$("$here/robot-at-index.sh" "$index" "$fleet") || exit 2
  fi
fi
day=${day:-$(date -d yesterday +%F)}
dir=$fleet/robots/$robot
profile=$dir/profile.json

tmp=$(mktemp "${TMPDIR:-/tmp}/momentum-robot.XXXXXX") || exit 1
trap 'rm -f "$tmp"' EXIT
status=0
if [[ ! -f $profile ]]; then
  status=1 why="no profile $profile"
else
  "$nightly" -p "$profile" --logs "$dir/logs/$day" --robot "$robot" --json "$tmp" "$@" < /dev/null
  status=$?
  why="nightly-recalibrate.sh wrote no result (exit status $status)"
fi
lines=$(grep -c '^{' "$tmp")
if ((lines != 1)); then
  # No line (or, impossibly, several): say so in the same form, so that the fleet's summary
  # counts the robot.
  ((lines == 0)) || why="nightly-recalibrate.sh wrote $lines lines (exit status $status)"
  ROBOT=$robot PROFILE=$profile DAY=$day STATUS=$status WHY=$why python3 -c '
import json, os, time
e = os.environ
now = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
print(json.dumps({"robot": e["ROBOT"], "profile": e["PROFILE"], "day": e["DAY"], "logs": None,
                  "outcome": "failed", "reason": e["WHY"], "exit_status": int(e["STATUS"]),
                  "profile_version": None, "thresholds_before": None, "thresholds_after": None,
                  "log": None, "started": now, "finished": now, "duration_s": None},
                 separators=(", ", ": ")))' > "$tmp" || exit 1
fi
if [[ -n $results ]]; then
  # Replaced by one rename beside the file it names (a symbolic link stays a link).
  written=0
  if mkdir -p "$results" && out=$(readlink -f -- "$results/$robot.json") &&
    part=$(mktemp "$(dirname "$out")/.$(basename "$out").XXXXXX"); then
    cp "$tmp" "$part" && chmod 644 "$part" && mv -T -- "$part" "$out" < /dev/null && written=1
    ((written)) || rm -f "$part"
  fi
  ((written)) || echo "recalibrate-robot: cannot write $results/$robot.json" >&2
fi
cat "$tmp"
grep -q -e '"outcome": "failed"' -e '"outcome": "alarming"' "$tmp" && exit 1
exit 0
