#!/usr/bin/env bash
# nightly-recalibrate.sh: refit friction and recalibrate collision thresholds from a day's
# logs, and install the new robot profile only when it is at least as good as the one in
# place. Run by cron or a systemd timer (see nightly-recalibrate.cron, momentum-nightly.timer).
#
#   nightly-recalibrate.sh -p /etc/momentum/arm.json --logs /var/log/arm/2024-05-17
#
# What it does, every step logged with a time stamp (--log):
#  1. takes the day's logs (*.csv, *.bin in --logs, or the files given), in name order, and
#     splits them: the 1st, 3rd, 5th ... fit and calibrate, the 2nd, 4th ... check. At least
#     two logs are needed.
#  2. identifies corrections to the URDF's inertial parameters on the calibration part
#     (mo-dynfit, its held-out check inside); when the fit fails or explains the held-out data
#     worse than the corrections in place, those are kept (--no-dynfit skips the step);
#  3. observes the check part with the profile in place, and the calibration part with the
#     corrected model (mo-observe --strict: a broken log stops the night, the profile stays);
#  4. fits friction on the calibration part (mo-lugre-fit); when the fit is refused (worse
#     than the friction in place) or fails, the current friction is kept;
#  5. observes the calibration part again with the candidate's friction and calibrates the
#     thresholds (mo-calibrate --reject-contact: a log that looks like it holds a contact
#     stops the night, the profile stays);
#  6. checks the candidate on the check part. Its events there must be no more than its
#     calibration stands for: mo-calibrate states the false alarms per hour its thresholds
#     stand for, and the candidate is refused when that rate, over the hours of the check
#     part, makes its count of events less likely than --check-level (default 0.01; on a few
#     minutes of logs, any event is refused: the day held a collision, or its logs are not fit
#     to calibrate on). It must raise no more events than the profile in place raises there,
#     and no threshold may grow by more than --max-increase percent;
#  7. installs the candidate by renaming it over the profile, after a dated backup
#     (--backups, the newest --keep kept).
# Exit status: 0 when the new profile was installed (or would be, with --dry-run); 1 when the
# night failed, had nothing to go on, or the candidate was refused (the old profile stays; see
# the log); 2 on a usage error.
#
# With --json FILE (- for standard output), every run but a usage error also writes exactly one
# JSON line, appended to FILE (a fleet's results are `jq` over these lines; see fleet/), e.g.
#   {"robot": "arm", "profile": "/etc/momentum/arm.json", "day": "2024-05-17", "logs": 4,
#    "outcome": "refused", "reason": "the candidate raises 1 events on collision-free logs",
#    "exit_status": 1, "profile_version": {...}, "thresholds_before": {...},
#    "thresholds_after": {...}, "started": "...Z", "finished": "...Z", "duration_s": 41.2, ...}
# (one line in the file). Keys:
#   robot            --robot NAME, else the profile's file name without .json
#   profile, log     the profile's path, the log file's
#   day, logs        the name of the --logs folder (null when log files are given), their count
#   outcome          "installed": the candidate replaced the profile;
#                    "dry-run": it would have (--dry-run);
#                    "refused": a candidate was made and judged unfit (a contact in the
#                      calibration logs, more events on the check logs than its rate stands
#                      for, thresholds grown too much);
#                    "kept": nothing to go on (fewer than 2 logs) or another run holds the lock;
#                    "failed": the night could not run (a tool missing, a broken log, a write
#                      failed); the profile stays in every case but "installed"
#   reason           why the profile was kept (the KEPT line of the log), else null
#   exit_status      the script's exit status (0, 1, or 2 when the backups folder is unusable)
#   profile_version  what identifies the profile: "sha256_before", "sha256_after" (of the file;
#                    equal unless installed), its "name", and "version"/"id"/"serial" when the
#                    profile carries them, "changes_before"/"changes_after" (provenance entries)
#                    and "last_change" (tool, version, time of the newest one, after the run)
#   thresholds_before  the profile's thresholds at the start, per signal ("mu", "r") and state
#                    ("moving", "slow", "rest": one number per joint, null where the joint has
#                    none; "envelope": {"a", "b"} per joint), {} when it has none
#   thresholds_after   the candidate's, as calibrated this night (also when refused), null when
#                    the night did not get that far
#   check_events     events on the check logs, {"candidate": N, "in_place": N or null,
#                    "expected": the candidate's stated false alarms over the check part's
#                    "hours"}, when the check ran
#   backup           the replaced profile's backup (installed only)
#   started, finished, duration_s   UTC, ISO 8601; seconds
set -uo pipefail

usage() {
  cat <<'EOF'
usage: nightly-recalibrate.sh -p PROFILE [--logs DIR | LOG...] [options]
  -p, --profile FILE      the robot profile in use (replaced only by a better one)
  --logs DIR              the day's logs (*.csv, *.bin); or give the log files as arguments
  --backups DIR           dated backups of replaced profiles (default: PROFILE's folder/backups)
  --keep N                backups to keep (default 30)
  --log FILE              append what was done to FILE (default: BACKUPS/nightly.log)
  --margin NM             safety margin of the thresholds in Nm (default: mo-calibrate's 10%)
  --margin-percent P      safety margin in percent
  --envelope              also calibrate velocity envelopes
  --max-increase P        refuse a candidate whose threshold grows by more than P% (default 50)
  --check-level P         refuse a candidate whose events on the check part are less likely
                          than P under its stated false-alarm rate (default 0.01)
  --no-dynfit             keep the inertial parameters in place (no mo-dynfit step)
  --torque-held           the logs' motor torque was held between samples (mo-sim's drives;
                          passed to mo-dynfit)
  --no-friction-fit       keep the friction in place, recalibrate the thresholds only
  --seed N                seed of the friction fit (default 1)
  -j, --jobs N            logs observed at a time (default 1: a fleet runs one night per core)
  -n, --dry-run           do everything but install
  --json FILE             append one JSON line saying what happened to FILE (- for standard
                          output; then the tools' own standard output goes to standard error)
  --robot NAME            the robot's name in the JSON line (default: PROFILE's name, no .json)
  -h, --help              this help
EOF
}

profile="" logs_dir="" backups="" keep=30 log_file="" max_increase=50 seed=1
dry_run=0 fit_friction=1 fit_dynamics=1 json_file="" robot="" jobs=1 check_level=0.01
dynfit_options=()
calibrate_options=()
logs=()
while (($#)); do
  case $1 in
    -p|--profile) profile=${2:?}; shift 2 ;;
    --logs) logs_dir=${2:?}; shift 2 ;;
    --backups) backups=${2:?}; shift 2 ;;
    --keep) keep=${2:?}; shift 2 ;;
    --log) log_file=${2:?}; shift 2 ;;
    --margin) calibrate_options+=(--margin "${2:?}"); shift 2 ;;
    --margin-percent) calibrate_options+=(--margin-percent "${2:?}"); shift 2 ;;
    --envelope) calibrate_options+=(--envelope); shift ;;
    --max-increase) max_increase=${2:?}; shift 2 ;;
    --check-level) check_level=${2:?}; shift 2 ;;
    --no-dynfit) fit_dynamics=0; shift ;;
    --torque-held) dynfit_options+=(--torque-held); shift ;;
    --no-friction-fit) fit_friction=0; shift ;;
    --seed) seed=${2:?}; shift 2 ;;
    -j|--jobs) jobs=${2:?}; shift 2 ;;
    -n|--dry-run) dry_run=1; shift ;;
    --json) json_file=${2:?}; shift 2 ;;
    --robot) robot=${2:?}; shift 2 ;;
    -h|--help) usage; exit 0 ;;
    -*) echo "nightly-recalibrate: unknown option $1" >&2; usage >&2; exit 2 ;;
    *) logs+=("$1"); shift ;;
  esac
done
if ! [[ $jobs =~ ^[1-9][0-9]*$ ]]; then
  echo "nightly-recalibrate: --jobs takes a number of logs (>= 1)" >&2
  exit 2
fi
if ! awk -v p="$check_level" 'BEGIN { exit !(p ~ /^[0-9.eE+-]+$/ && p + 0 > 0 && p + 0 < 1) }'; then
  echo "nightly-recalibrate: --check-level takes a probability between 0 and 1" >&2
  exit 2
fi
if [[ -z $profile || ! -f $profile ]]; then
  echo "nightly-recalibrate: give the profile in use with -p (a file)" >&2
  exit 2
fi
profile=$(cd "$(dirname "$profile")" && pwd)/$(basename "$profile")
folder=$(dirname "$profile")
name=$(basename "$profile" .json)
robot=${robot:-$name}
backups=${backups:-$folder/backups}

# --json: one line at exit, whatever happened (see the header). The profile is read with its
# comments (// and /* */) taken out; python3 does the JSON.
json_program=$(cat <<'EOF'
import hashlib, json, os, sys

def strip_comments(text):
    out, i, n, quoted = [], 0, len(text), False
    while i < n:
        c = text[i]
        if quoted:
            out.append(c)
            if c == "\\" and i + 1 < n:
                out.append(text[i + 1]); i += 1
            elif c == '"':
                quoted = False
        elif c == '"':
            quoted = True; out.append(c)
        elif text.startswith("//", i):
            j = text.find("\n", i)
            i = n if j < 0 else j
            continue
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            i = n if j < 0 else j + 2
            out.append(" ")
            continue
        else:
            out.append(c)
        i += 1
    return "".join(out)

def load(path):
    """(sha256 of the file, the profile as JSON or None)"""
    try:
        data = open(path, "rb").read()
    except OSError:
        return None, None
    try:
        return hashlib.sha256(data).hexdigest(), json.loads(strip_comments(data.decode("utf-8")))
    except ValueError:
        return hashlib.sha256(data).hexdigest(), None

def thresholds(p):
    """Per signal and state, one value per joint (None where a joint has none)."""
    if not isinstance(p, dict):
        return None
    out = {}
    for signal, entry in sorted((p.get("thresholds") or {}).items()):
        joints = entry.get("joints") or [] if isinstance(entry, dict) else []
        states = {}
        for state in ("moving", "slow", "rest", "envelope"):
            values = [j.get(state) if isinstance(j, dict) else None for j in joints]
            if any(v is not None for v in values):
                states[state] = values
        out[signal] = states
    return out

def identity(p):
    """The profile's own names for itself and its newest change."""
    if not isinstance(p, dict):
        return {}
    ident = {k: p[k] for k in ("name", "version", "id", "serial") if k in p}
    provenance = p.get("provenance") if isinstance(p.get("provenance"), list) else []
    ident["changes"] = len(provenance)
    last = provenance[-1] if provenance and isinstance(provenance[-1], dict) else None
    ident["last_change"] = {k: last.get(k) for k in ("tool", "version", "time")} if last else None
    return ident

mode = sys.argv[1]
if mode == "before":  # PROFILE: what the night starts from, as one JSON object
    sha, p = load(sys.argv[2])
    print(json.dumps({"sha256": sha, "identity": identity(p), "thresholds": thresholds(p)}))
    sys.exit(0)

# line: everything else from the environment (NIGHTLY_*)
e = os.environ
before = json.loads(e.get("NIGHTLY_BEFORE") or "{}")
sha_after, after = load(e["NIGHTLY_PROFILE"])
ident_before, ident_after = before.get("identity", {}), identity(after)
version = {k: v for k, v in ident_after.items() if k not in ("changes", "last_change")}
for k, v in ident_before.items():
    if k not in ("changes", "last_change"):
        version.setdefault(k, v)
version.update({"sha256_before": before.get("sha256"), "sha256_after": sha_after,
                "changes_before": ident_before.get("changes"), "changes_after": ident_after.get("changes"),
                "last_change": ident_after.get("last_change")})
source = e.get("NIGHTLY_AFTER_FROM")
after_thresholds = thresholds(load(source)[1]) if source else None
status = int(e["NIGHTLY_STATUS"])
outcome = e.get("NIGHTLY_OUTCOME") or "failed"
reason = e.get("NIGHTLY_REASON") or None
if not e.get("NIGHTLY_OUTCOME"):
    reason = reason or f"stopped with exit status {status} before saying why (see the log)"
def number(name):
    v = e.get(name, "")
    return int(v) if v.isdigit() else None
line = {
    "robot": e["NIGHTLY_ROBOT"],
    "profile": e["NIGHTLY_PROFILE"],
    "day": e.get("NIGHTLY_DAY") or None,
    "logs": int(e.get("NIGHTLY_LOGS", "0")),
    "outcome": outcome,
    "reason": reason,
    "exit_status": status,
    "profile_version": version,
    "thresholds_before": before.get("thresholds"),
    "thresholds_after": after_thresholds,
}
if e.get("NIGHTLY_NEW_EVENTS"):
    def real(name):
        try:
            return float(e.get(name, ""))
        except ValueError:
            return None
    line["check_events"] = {"candidate": number("NIGHTLY_NEW_EVENTS"), "in_place": number("NIGHTLY_OLD_EVENTS"),
                            "expected": real("NIGHTLY_EXPECTED_EVENTS"), "hours": real("NIGHTLY_CHECK_HOURS")}
if e.get("NIGHTLY_BACKUP") and outcome == "installed":
    line["backup"] = e["NIGHTLY_BACKUP"]
started, finished = float(e["NIGHTLY_STARTED_S"]), float(e["NIGHTLY_FINISHED_S"])
line.update({"log": e.get("NIGHTLY_LOG") or None, "started": e["NIGHTLY_STARTED"],
             "finished": e["NIGHTLY_FINISHED"], "duration_s": round(finished - started, 1)})
print(json.dumps(line, separators=(", ", ": ")))
EOF
)
outcome="" reason="" calibrated=0 backup="" new_events="" old_events="" locked=0 json_ready=0
expected_events="" check_hours=""
started=$(date -u +%Y-%m-%dT%H:%M:%SZ) started_s=$(date +%s.%N)
if [[ -n $json_file ]]; then
  command -v python3 > /dev/null || { echo "nightly-recalibrate: --json needs python3" >&2; exit 2; }
  if [[ $json_file == - ]]; then
    exec 8>&1 1>&2  # standard output holds the JSON line only
  else
    exec 8>> "$json_file" || { echo "nightly-recalibrate: cannot write $json_file" >&2; exit 2; }
  fi
  before_info=$(python3 -c "$json_program" before "$profile")
  json_ready=1
fi
write_json() {  # exit-status
  local after_from=""
  if [[ $outcome == installed ]]; then
    after_from=$profile
  elif ((calibrated)) && [[ -f $candidate ]]; then
    after_from=$candidate
  fi
  NIGHTLY_BEFORE=$before_info NIGHTLY_PROFILE=$profile NIGHTLY_AFTER_FROM=$after_from NIGHTLY_STATUS=$1 \
    NIGHTLY_OUTCOME=$outcome NIGHTLY_REASON=$reason NIGHTLY_ROBOT=$robot NIGHTLY_DAY=${logs_dir:+$(basename "$logs_dir")} \
    NIGHTLY_LOGS=${#logs[@]} NIGHTLY_NEW_EVENTS=$new_events NIGHTLY_OLD_EVENTS=$old_events NIGHTLY_BACKUP=$backup \
    NIGHTLY_EXPECTED_EVENTS=$expected_events NIGHTLY_CHECK_HOURS=$check_hours \
    NIGHTLY_LOG=$log_file NIGHTLY_STARTED=$started NIGHTLY_STARTED_S=$started_s \
    NIGHTLY_FINISHED=$(date -u +%Y-%m-%dT%H:%M:%SZ) NIGHTLY_FINISHED_S=$(date +%s.%N) \
    python3 -c "$json_program" line >&8 ||
    echo "nightly-recalibrate: cannot write the JSON line" >&2
}

log_file=${log_file:-$backups/nightly.log}
if ! mkdir -p "$backups"; then
  outcome=failed reason="cannot create the backups folder $backups" log_file=""
  ((json_ready)) && write_json 2
  exit 2
fi
if [[ -n $logs_dir ]]; then
  shopt -s nullglob
  logs+=("$logs_dir"/*.csv "$logs_dir"/*.bin)
  shopt -u nullglob
fi
# Sorted; no logs at all stays an empty list (printf would make one empty name of it).
((${#logs[@]} == 0)) || mapfile -t logs < <(printf '%s\n' "${logs[@]}" | sort)

stamp() { date -u +%Y-%m-%dT%H:%M:%SZ; }
say() { echo "$(stamp) $*" >> "$log_file"; [[ -t 2 ]] && echo "$*" >&2; return 0; }
work=""
candidate="$folder/.$name.candidate.json"
cleanup() {
  local status=$?
  ((json_ready)) && write_json "$status"
  [[ -n $work ]] && rm -rf "$work"
  # The candidate is this run's only while it holds the lock (another run's otherwise).
  ((locked)) && rm -f "$candidate"
  return 0
}
trap cleanup EXIT
# Ends the night keeping the profile in place: failed (default), --refused (a candidate judged
# unfit) or --kept (nothing to go on), for the JSON line.
keep_old() {
  outcome=failed
  case $1 in
    --refused) outcome=refused; shift ;;
    --kept) outcome=kept; shift ;;
  esac
  reason="$*"
  say "KEPT $profile unchanged: $*"
  exit 1
}
# Copies stdin to the log with the work files (deleted at exit) named by what they hold: the
# day's log they were observed from, the candidate profile.
names=""
to_log() {
  if [[ -n $names ]]; then sed -f "$names" >> "$log_file"; else cat >> "$log_file"; fi
}
# Runs a step; its standard error goes to the log.
run() {
  local status
  if [[ -n $names ]]; then
    "$@" 2> "$work/step.err"
    status=$?
    to_log < "$work/step.err"
    return $status
  fi
  "$@" 2>> "$log_file"
}

# One night at a time per profile.
exec 9> "$folder/.$name.nightly.lock" || exit 2
if ! flock -n 9; then
  outcome=kept reason="another nightly run holds $folder/.$name.nightly.lock; nothing done"
  say "$reason"
  exit 1
fi
locked=1

say "---- nightly recalibration of $profile from ${#logs[@]} logs"
tools=(mo-observe mo-lugre-fit mo-calibrate mo-detect)
((fit_dynamics)) && tools+=(mo-dynfit)
for tool in "${tools[@]}"; do
  command -v "$tool" > /dev/null || keep_old "$tool not found on PATH"
done
((${#logs[@]} >= 2)) || keep_old --kept "need at least 2 logs (one to calibrate on, one to check), got ${#logs[@]}"
work=$(mktemp -d "${TMPDIR:-/tmp}/momentum-nightly.XXXXXX") || keep_old "cannot create a work folder"
# sed's pattern and replacement, each with its special characters escaped.
pattern() { printf '%s' "$1" | sed 's/[]\/$*.^|[]/\\&/g'; }
replacement() { printf '%s' "$1" | sed 's/[\/&|]/\\&/g'; }
{
  for i in "${!logs[@]}"; do
    echo "s|$(pattern "$work/old-$i.bin")|$(replacement "${logs[i]} (observed with the profile in place)")|g"
    echo "s|$(pattern "$work/mid-$i.bin")|$(replacement "${logs[i]} (observed with the corrected model)")|g"
    echo "s|$(pattern "$work/new-$i.bin")|$(replacement "${logs[i]} (observed with the candidate)")|g"
  done
  echo "s|$(pattern "$candidate")|the candidate profile|g"
} > "$work/names.sed" && names=$work/names.sed

calibrate=() check=()
for i in "${!logs[@]}"; do
  if ((i % 2 == 0)); then calibrate+=("${logs[i]}"); else check+=("${logs[i]}"); fi
done
say "calibration part: ${calibrate[*]}"
say "check part: ${check[*]}"

# Observes the logs of the given indices with a profile into $work/PREFIX-i.bin, --jobs at a
# time; their messages go to the log in the logs' order. Returns 1 at the first batch holding a
# log that could not be observed (failed_log: its name).
failed_log=""
observe_logs() {  # profile prefix index...
  local p=$1 prefix=$2 k j status=0
  shift 2
  local -a all=("$@") batch pids
  for ((k = 0; k < ${#all[@]}; k += jobs)); do
    batch=("${all[@]:k:jobs}") pids=()
    for j in "${batch[@]}"; do
      mo-observe -q --strict -p "$p" --output-format bin -o "$work/$prefix-$j.bin" "${logs[j]}" \
        2> "$work/observe-$j.err" &
      pids+=($!)
    done
    for j in "${!batch[@]}"; do
      if ! wait "${pids[j]}"; then
        status=1
        [[ -n $failed_log ]] || failed_log=${logs[batch[j]]}
      fi
      to_log < "$work/observe-${batch[j]}.err"
    done
    ((status == 0)) || return 1
  done
}
even=() odd=()
for i in "${!logs[@]}"; do
  if ((i % 2 == 0)); then even+=("$i"); else odd+=("$i"); fi
done
# The work files of the given indices: $work/PREFIX-i.bin.
observed() {  # prefix index...
  local prefix=$1 i
  shift
  for i in "$@"; do printf '%s\n' "$work/$prefix-$i.bin"; done
}

# 2. Inertial parameters, on the raw calibration logs.
cp "$profile" "$candidate" || keep_old "cannot write $candidate"
corrected=0
if ((fit_dynamics)); then
  if run mo-dynfit -q -p "$profile" -o "$candidate" "${dynfit_options[@]}" "${calibrate[@]}"; then
    corrected=1
    say "inertial parameters corrected (mo-dynfit)"
  else
    say "inertial fit refused or failed (see above): keeping the inertial parameters in place"
    cp "$profile" "$candidate" || keep_old "cannot write $candidate"
  fi
fi

# 3. Observe: the check part with the profile in place (to compare with), the calibration part
# with the corrected model (the friction is fitted on its residuals).
observe_logs "$profile" old "${odd[@]}" || keep_old "cannot observe $failed_log (broken log?)"
observe_logs "$candidate" mid "${even[@]}" || keep_old "cannot observe $failed_log (broken log?)"
mapfile -t mid_calibration < <(observed mid "${even[@]}")
mapfile -t old_check < <(observed old "${odd[@]}")

# 4. Friction.
# (A refused or failed fit leaves the candidate as it was: --update replaces it in one rename.)
if ((fit_friction)); then
  if run mo-lugre-fit -p "$candidate" --update --seed "$seed" "${mid_calibration[@]}"; then
    say "friction refitted (report above in this log)"
  else
    say "friction fit refused or failed (see above): keeping the friction in place"
  fi
fi

# 5. Thresholds, on residuals compensated with the candidate's friction (without a friction
# fit, the corrected model's residuals are already those).
if ((fit_friction)); then
  observe_logs "$candidate" new "${even[@]}" || keep_old "cannot observe $failed_log with the candidate"
  mapfile -t new_calibration < <(observed new "${even[@]}")
else
  new_calibration=("${mid_calibration[@]}")
fi
if ! run mo-calibrate -q -p "$candidate" --reject-contact --strict "${calibrate_options[@]}" "${new_calibration[@]}" \
    > "$work/calibration.txt"; then
  to_log < "$work/calibration.txt"
  keep_old --refused "calibration refused or failed (a contact in the calibration logs?)"
fi
to_log < "$work/calibration.txt"
calibrated=1

# 6. Check: events on the check part, candidate and profile in place.
events() {  # profile observed-streams...: prints the number of events and the hours the
  # streams cover, or "none" without thresholds
  local p=$1 total=0 seconds=0 n s status
  shift
  for f in "$@"; do
    mo-detect -q --stats -p "$p" "$f" > "$work/events.csv" 2> "$work/detect.stats"
    status=$?
    grep -v '^mo-detect: ' "$work/detect.stats" >> "$work/detect.err"
    if ((status == 2)); then
      echo none
      return
    fi
    n=$(grep -c ',onset,' "$work/events.csv")
    s=$(sed -n 's/^mo-detect: [0-9]* rows over \([^ ]*\) s,.*/\1/p' "$work/detect.stats")
    total=$((total + n))
    seconds=$(awk -v a="$seconds" -v b="${s:-0}" 'BEGIN { printf "%.6f", a + b }')
  done
  awk -v n="$total" -v s="$seconds" 'BEGIN { printf "%d %.6g\n", n, s / 3600 }'
}
observe_logs "$candidate" new "${odd[@]}" || keep_old "cannot observe $failed_log with the candidate"
mapfile -t new_check < <(observed new "${odd[@]}")
read -r new_events check_hours < <(events "$candidate" "${new_check[@]}")
read -r old_events _ < <(events "$profile" "${old_check[@]}")
if [[ $new_events == none ]]; then
  to_log < "$work/detect.err"
  keep_old "the candidate cannot run the detector (see above)"
fi
# The candidate's stated rate for the signal mo-detect judges (mu when calibrated, else r).
rate=$(awk '$1 == "#" && $3 == "false" && $4 == "alarms" && $5 == "expected:" { r[$2] = $6 }
  END { print ("mu" in r) ? r["mu"] : ("r" in r) ? r["r"] : "" }' "$work/calibration.txt")
[[ -n $rate ]] || keep_old "the calibration states no false-alarm rate (see above)"
expected_events=$(awk -v r="$rate" -v h="$check_hours" 'BEGIN { printf "%.4g", r * h }')
# P(N >= n) for N Poisson with mean `expected_events`.
chance=$(awk -v n="$new_events" -v m="$expected_events" 'BEGIN {
  below = 0; term = exp(-m)
  for (k = 0; k < n; ++k) { below += term; term *= m / (k + 1) }
  p = 1 - below; printf "%.3g", p < 0 ? 0 : p }')
say "check part ($check_hours h): candidate $new_events events (its calibration stands for $expected_events;" \
  "as many or more by chance: $chance), profile in place $old_events"
if awk -v p="$chance" -v level="$check_level" 'BEGIN { exit !(p < level) }'; then
  keep_old --refused "the candidate raises $new_events events on collision-free logs (its calibration stands for $expected_events)"
fi
if [[ $old_events != none ]] && ((new_events > old_events)); then
  keep_old --refused "the candidate raises more events than the profile in place"
fi

# Thresholds must not balloon: a day that calibrates far looser than the profile in place is
# suspicious (a contact the contact check missed, a sensor fault).
growth=$(awk -v limit="$max_increase" '
  $1 == "#" && $2 == "change" && $9 ~ /%$/ && $9 + 0 > limit { printf "%s%s %s %s -> %s Nm (%s)", sep, $3, $4, $5, $7, $9; sep = "; " }
' "$work/calibration.txt")
[[ -z $growth ]] || keep_old --refused "thresholds grew by more than $max_increase%: $growth"

if ((dry_run)); then
  outcome=dry-run
  say "dry run: the candidate would be installed"
  exit 0
fi

# 7. Install: dated backup, then one rename.
backup="$backups/$name.$(date -u +%Y%m%dT%H%M%SZ).json"
cp -p "$profile" "$backup" || keep_old "cannot back up to $backup"
chmod --reference="$profile" "$candidate" 2> /dev/null
mv -f "$candidate" "$profile" || keep_old "cannot rename the candidate over the profile"
outcome=installed
say "INSTALLED the new profile; the old one is $backup"
mapfile -t old_backups < <(ls -1 "$backups"/"$name".*.json 2> /dev/null | sort -r | tail -n +$((keep + 1)))
for f in "${old_backups[@]}"; do
  rm -f "$f" && say "removed old backup $f"
done
exit 0
