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
#  3. observes the calibration part with the corrected model (mo-observe --strict: a broken
#     log stops the night, the profile stays); every observed stream goes through a pipe to
#     the one tool that reads it, none to a file;
#  4. fits friction on it (mo-lugre-fit); when the fit is refused (worse than the friction in
#     place) or fails, the current friction is kept;
#  5. observes the calibration part again with the candidate's friction and calibrates the
#     thresholds (mo-calibrate --reject-contact: a log that looks like it holds a contact
#     stops the night, the profile stays);
#  6. observes the check part with the candidate and with the profile in place, and judges
#     each there (mo-detect) by its own promise: mo-calibrate states the false alarms per hour
#     a calibration's thresholds stand for (the candidate's report; for the profile in place,
#     the statement its provenance records, else the rate its calibration asked of each joint
#     times the joints). A profile breaks its promise when that rate, over the hours of the
#     check part, makes its count of events less likely than --check-level (default 0.01; on a
#     few minutes of logs, any event does). Then:
#     - the candidate breaks its promise and the profile in place keeps its (or states none):
#       refused;
#     - both break theirs: the night ends ALARMING (exit status 3), naming the logs and the
#       times of the candidate's events: the day held collisions, or the arm no longer matches
#       any profile (a fault, a new tool): someone must look;
#     - the profile in place breaks its promise and the candidate keeps its: the arm changed
#       (wear, a new payload): the candidate is installed, whatever its thresholds' growth;
#     - both keep theirs: the candidate may raise no more events than the profile in place,
#       and no threshold may grow by more than --max-increase percent (a day that calibrates
#       far looser while the profile in place stays quiet hides a contact or a sensor fault);
#  7. installs the candidate through the tools' own lock and rename, after a dated backup
#     (--backups, the newest --keep kept): the file the profile names (through symbolic links:
#     a link stays a link) is locked with flock(2) as the tools lock it for an in-place update
#     (waiting at most --lock-wait s for a tool that holds it), and, when it is still the
#     profile the night started from, replaced by renaming a temporary file beside it. A
#     profile changed during the night is not written over (outcome "kept").
# Exit status: 0 when the new profile was installed (or would be, with --dry-run); 1 when the
# night failed, had nothing to go on, or the candidate was refused (the old profile stays; see
# the log); 2 on a usage error; 3 when neither the candidate nor the profile in place keeps
# its promise on the check logs (ALARMING in the log: the profile stays, and someone must look).
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
#                    "kept": nothing to go on (fewer than 2 logs), another run holds the lock,
#                      or the profile changed during the night;
#                    "alarming": neither the candidate nor the profile in place keeps its
#                      promise on the check logs (exit status 3; the reason names the logs and
#                      the times of the candidate's events);
#                    "failed": the night could not run (a tool missing, a broken log, a write
#                      failed); the profile stays in every case but "installed"
#   reason           why the profile was kept (the KEPT or ALARMING line of the log); when
#                    installed because the profile in place broke its promise, that (with both
#                    counts); else null
#   exit_status      the script's exit status (0, 1, 3, or 2 when the backups folder is unusable)
#   profile_version  what identifies the profile: "sha256_before", "sha256_after" (of the file;
#                    equal unless installed), its "name", and "version"/"id"/"serial" when the
#                    profile carries them, "changes_before"/"changes_after" (provenance entries)
#                    and "last_change" (tool, version, time of the newest one, after the run)
#   thresholds_before  the profile's thresholds at the start, per signal ("mu", "r") and state
#                    ("moving", "slow", "rest": one number per joint, null where the joint has
#                    none; "envelope": {"a", "b"} per joint), {} when it has none
#   thresholds_after   the candidate's, as calibrated this night (also when refused), null when
#                    the night did not get that far
#   check_events     events on the check logs, when the check ran: {"candidate": N,
#                    "in_place": N or null, "expected": the candidate's stated false alarms
#                    over the check part's "hours", "in_place_expected": the profile in place's
#                    (null when it states none), "candidate_chance", "in_place_chance": the
#                    chance of as many events or more under that promise, "level":
#                    --check-level, "candidate_keeps_promise", "in_place_keeps_promise": true,
#                    false or null, "alarms": {"candidate": [...], "in_place": [...]}: per check
#                    log with events {"log", "events", "t_detect": the first 20 times, s}}
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
  --lock-wait S           wait at most S s for the profile's lock at install (default 600)
  --seed N                seed of the friction fit (default 1)
  -j, --jobs N            check logs observed and judged at a time (default 1: a fleet runs
                          one night per core)
  -n, --dry-run           do everything but install
  --json FILE             append one JSON line saying what happened to FILE (- for standard
                          output; then the tools' own standard output goes to standard error)
  --robot NAME            the robot's name in the JSON line (default: PROFILE's name, no .json)
  -h, --help              this help
EOF
}

profile="" logs_dir="" backups="" keep=30 log_file="" max_increase=50 seed=1
dry_run=0 fit_friction=1 fit_dynamics=1 json_file="" robot="" jobs=1 check_level=0.01 lock_wait=600
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
    --lock-wait) lock_wait=${2:?}; shift 2 ;;
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
if ! [[ $lock_wait =~ ^[0-9]+$ ]]; then
  echo "nightly-recalibrate: --lock-wait takes whole seconds (>= 0)" >&2
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

def promise(p):
    """(false alarms per hour the thresholds mo-detect judges with stand for, whence), or None.
    The newest calibration's statement in the provenance when it recorded one; else the rate its
    rule asked of each joint (false_alarms_per_hour, per hour of every motion state) times the
    joints; None when the thresholds were not calibrated by that rule (hand-set, --rule max)."""
    if not isinstance(p, dict) or not isinstance(p.get("thresholds"), dict):
        return None
    th = p["thresholds"]
    sig = "mu" if "mu" in th else "r" if "r" in th else None
    if sig is None or not isinstance(th[sig], dict) or not isinstance(th[sig].get("joints"), list):
        return None
    joints = len(th[sig]["joints"])
    provenance = p.get("provenance") if isinstance(p.get("provenance"), list) else []
    for entry in reversed(provenance):
        if not isinstance(entry, dict) or entry.get("tool") != "mo-calibrate":
            continue
        d = entry.get("details") if isinstance(entry.get("details"), dict) else {}
        if "rule" not in d:  # not a threshold calibration (--classes)
            continue
        when = entry.get("time") or "an unknown time"
        # Held to the rate its thresholds aim at, as the candidate is (see the candidate's rate
        # below), not to the looser rate the calibration's data vouch for.
        stated = d.get("false_alarms_expected_per_hour")
        if isinstance(stated, dict):
            stated = stated.get(sig)
        if isinstance(stated, (int, float)) and stated >= 0:
            return stated, f"aimed at by mo-calibrate on {when}"
        asked = d.get("false_alarms_per_hour")
        if d["rule"] == "rate" and isinstance(asked, (int, float)) and asked > 0 and joints:
            return asked * joints, f"{asked:g} an hour asked of each of its {joints} joints by mo-calibrate on {when}"
        return None
    return None

mode = sys.argv[1]
if mode == "promise":  # PROFILE: prints "RATE<tab>WHENCE", or a tab alone without a promise
    r = promise(load(sys.argv[2])[1])
    print(f"{r[0]:.6g}\t{r[1]}" if r else "\t")
    sys.exit(0)
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
    def keeps(name):
        v = e.get(name, "")
        return True if v == "yes" else False if v == "no" else None
    def alarms(name):  # the alarms file: log, events, times of detection
        rows = []
        try:
            for row in open(e.get(name, "")).read().splitlines():
                log, n, times = (row.split("\t") + ["", ""])[:3]
                rows.append({"log": log, "events": int(n), "t_detect": [float(t) for t in times.split()]})
        except (OSError, ValueError):
            pass
        return rows
    line["check_events"] = {"candidate": number("NIGHTLY_NEW_EVENTS"), "in_place": number("NIGHTLY_OLD_EVENTS"),
                            "expected": real("NIGHTLY_EXPECTED_EVENTS"), "hours": real("NIGHTLY_CHECK_HOURS"),
                            "in_place_expected": real("NIGHTLY_OLD_EXPECTED_EVENTS"),
                            "candidate_chance": real("NIGHTLY_NEW_CHANCE"), "in_place_chance": real("NIGHTLY_OLD_CHANCE"),
                            "level": real("NIGHTLY_CHECK_LEVEL"),
                            "candidate_keeps_promise": keeps("NIGHTLY_NEW_KEEPS"),
                            "in_place_keeps_promise": keeps("NIGHTLY_OLD_KEEPS"),
                            "alarms": {"candidate": alarms("NIGHTLY_NEW_ALARMS"), "in_place": alarms("NIGHTLY_OLD_ALARMS")}}
if e.get("NIGHTLY_BACKUP") and outcome == "installed":
    line["backup"] = e["NIGHTLY_BACKUP"]
started, finished = float(e["NIGHTLY_STARTED_S"]), float(e["NIGHTLY_FINISHED_S"])
line.update({"log": e.get("NIGHTLY_LOG") or None, "started": e["NIGHTLY_STARTED"],
             "finished": e["NIGHTLY_FINISHED"], "duration_s": round(finished - started, 1)})
print(json.dumps(line, separators=(", ", ": ")))
EOF
)
outcome="" reason="" calibrated=0 backup="" new_events="" old_events="" locked=0 json_ready=0
expected_events="" check_hours="" old_expected_events="" new_chance="" old_chance="" new_keeps="" old_keeps=""
sha_start="" install_temp=""
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
    NIGHTLY_OLD_EXPECTED_EVENTS=$old_expected_events NIGHTLY_NEW_CHANCE=$new_chance NIGHTLY_OLD_CHANCE=$old_chance \
    NIGHTLY_CHECK_LEVEL=$check_level NIGHTLY_NEW_KEEPS=$new_keeps NIGHTLY_OLD_KEEPS=$old_keeps \
    NIGHTLY_NEW_ALARMS=${work:+$work/alarms-candidate.tsv} NIGHTLY_OLD_ALARMS=${work:+$work/alarms-in_place.tsv} \
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
declare -A stream_pid=()  # observers writing into named pipes in $work (stream_logs)
candidate="$folder/.$name.candidate.json"
cleanup() {
  local status=$?
  ((json_ready)) && write_json "$status"
  # Observers still waiting for their reader (the night cut short) end with it.
  local pid
  for pid in "${stream_pid[@]}"; do kill "$pid" 2> /dev/null; done
  [[ -n $work ]] && rm -rf "$work"
  [[ -n $install_temp ]] && rm -f "$install_temp"
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
# What the night starts from: installed over only if the profile is still this at the end.
sha_start=$(sha256sum < "$profile") || keep_old "cannot read $profile"
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

# Observes the logs of the given indices with a profile, each into a named pipe
# $work/PREFIX-i.bin that one tool (the fit, the calibration, a detector) reads as the observer
# writes it: a night at 1 kHz wrote 14 GB of observed streams to read each back once, and the
# disk, not the observer, set the night's pace (8 hours: 73 s, 53 of them observing). Each
# mo-observe starts when its reader opens the pipe (a tool reading several, in turn); its
# messages go to $work/observe-PREFIX-i.err and its exit status to $work/PREFIX-i.status.
# end_streams waits for them.
failed_log="" fifo_warned=0
stream_logs() {  # profile prefix index...
  local p=$1 prefix=$2 j pipe
  shift 2
  for j in "$@"; do
    pipe=$work/$prefix-$j.bin
    rm -f "$pipe" "$work/$prefix-$j.status"
    if ! mkfifo "$pipe" 2> /dev/null; then
      # A file system without named pipes: the stream goes to a file, observed before its
      # reader starts, as every stream did before the pipes.
      ((fifo_warned)) || say "no named pipes in the work folder (TMPDIR): observed streams go to files there"
      fifo_warned=1
      mo-observe -q --strict -p "$p" --output-format bin -o "$pipe" "${logs[j]}" 2> "$work/observe-$prefix-$j.err"
      echo $? > "$work/$prefix-$j.status"
      continue
    fi
    {
      mo-observe -q --strict -p "$p" --output-format bin -o - "${logs[j]}" 2> "$work/observe-$prefix-$j.err"
      echo $? > "$work/$prefix-$j.status"
    } > "$pipe" &
    stream_pid[$prefix-$j]=$!
  done
}
# Once the tool reading the pipes of the given indices is done: waits for their observers;
# their messages go to the log in the logs' order. Returns 1 when a log could not be observed
# (failed_log: the first such).
end_streams() {  # prefix index...
  local prefix=$1 j fd status=0
  shift
  for j in "$@"; do
    # A reader that stopped early (an error) did not open the pipes after it, whose observers
    # still wait to start: a reader that comes and goes lets each start, meet a closed pipe and
    # end (quietly, status 0). (Opened for reading and writing, the pipe does not wait for a
    # writer, which the observer may no longer be.)
    if [[ -n ${stream_pid[$prefix-$j]:-} ]]; then
      exec {fd}<> "$work/$prefix-$j.bin" && exec {fd}<&-
      wait "${stream_pid[$prefix-$j]}"
      unset "stream_pid[$prefix-$j]"
    fi
    to_log < "$work/observe-$prefix-$j.err"
    if [[ $(cat "$work/$prefix-$j.status" 2> /dev/null) != 0 ]]; then
      status=1
      [[ -n $failed_log ]] || failed_log=${logs[j]}
    fi
  done
  return $status
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

# 3.-4. Friction, fitted on the calibration part observed with the corrected model.
# (A refused or failed fit leaves the candidate as it was: --update replaces it in one rename.)
if ((fit_friction)); then
  mapfile -t mid_calibration < <(observed mid "${even[@]}")
  stream_logs "$candidate" mid "${even[@]}"
  run mo-lugre-fit -p "$candidate" --update --seed "$seed" "${mid_calibration[@]}"
  fitted=$?
  end_streams mid "${even[@]}" || keep_old "cannot observe $failed_log (broken log?)"
  if ((fitted == 0)); then
    say "friction refitted (report above in this log)"
  else
    say "friction fit refused or failed (see above): keeping the friction in place"
  fi
fi

# 5. Thresholds, on residuals compensated with the candidate's friction (without a friction
# fit, the corrected model's residuals are already those).
prefix=mid
((fit_friction)) && prefix=new
stream_logs "$candidate" "$prefix" "${even[@]}"
mapfile -t new_calibration < <(observed "$prefix" "${even[@]}")
run mo-calibrate -q -p "$candidate" --reject-contact --strict "${calibrate_options[@]}" "${new_calibration[@]}" \
  > "$work/calibration.txt"
calibration_status=$?
if ! end_streams "$prefix" "${even[@]}"; then
  [[ $prefix == new ]] && keep_old "cannot observe $failed_log with the candidate"
  keep_old "cannot observe $failed_log (broken log?)"
fi
if ((calibration_status != 0)); then
  to_log < "$work/calibration.txt"
  keep_old --refused "calibration refused or failed (a contact in the calibration logs?)"
fi
to_log < "$work/calibration.txt"
calibrated=1
# The candidate's provenance lists what its fit and calibration read, the work files deleted at
# exit: named instead, as in the log, by the day's logs they were observed from (a JSON string
# each; a name with a control character keeps the work file's).
json_string() {
  local s=${1//\\/\\\\}
  printf '"%s"' "${s//\"/\\\"}"
}
for i in "${!logs[@]}"; do
  [[ ${logs[i]} == *[[:cntrl:]]* ]] && continue
  echo "s|$(pattern "\"$work/mid-$i.bin\"")|$(replacement "$(json_string "${logs[i]} (observed with the corrected model)")")|g"
  echo "s|$(pattern "\"$work/new-$i.bin\"")|$(replacement "$(json_string "${logs[i]} (observed with the candidate)")")|g"
done > "$work/provenance.sed" && sed -i -f "$work/provenance.sed" "$candidate"

# 6. Check: events on the check part, candidate and profile in place.
# Runs mo-detect with a profile on the check part's logs as they are observed with it, --jobs
# logs at a time: per log i, its events go to $work/LABEL-i.csv, its standard error to
# $work/LABEL-i.stats and its exit status to $work/LABEL-i.status. Returns 1 when a log could not
# be observed (failed_log).
detect_logs() {  # label profile prefix index...
  local label=$1 p=$2 prefix=$3 k j
  shift 3
  local -a all=("$@") batch pids
  for ((k = 0; k < ${#all[@]}; k += jobs)); do
    batch=("${all[@]:k:jobs}") pids=()
    stream_logs "$p" "$prefix" "${batch[@]}"
    for j in "${batch[@]}"; do
      {
        mo-detect -q --stats -p "$p" "$work/$prefix-$j.bin" > "$work/$label-$j.csv" 2> "$work/$label-$j.stats"
        echo $? > "$work/$label-$j.status"
      } &
      pids+=($!)
    done
    wait "${pids[@]}"
    end_streams "$prefix" "${batch[@]}" || return 1
  done
}
# Counts the events detect_logs found with a profile: prints the number of events and the hours
# the streams cover, or "none" when the detector could not run with that profile (no
# thresholds); the logs with events and the times of detection go to $work/alarms-LABEL.tsv
# (log, events, the first 20 t_detect in s).
events() {  # label index...
  local label=$1 total=0 seconds=0 n s status i
  shift
  : > "$work/alarms-$label.tsv"
  for i in "$@"; do
    status=$(cat "$work/$label-$i.status")
    grep -v '^mo-detect: ' "$work/$label-$i.stats" >> "$work/detect.err"
    # 0: no collision, 1: collisions; anything else: the detector could not judge the log.
    if [[ $status != 0 && $status != 1 ]]; then
      echo none
      return
    fi
    n=$(grep -c ',onset,' "$work/$label-$i.csv")
    s=$(sed -n 's/^mo-detect: [0-9]* rows over \([^ ]*\) s,.*/\1/p' "$work/$label-$i.stats")
    total=$((total + n))
    seconds=$(awk -v a="$seconds" -v b="${s:-0}" 'BEGIN { printf "%.6f", a + b }')
    if ((n > 0)); then
      printf '%s\t%d\t%s\n' "${logs[i]}" "$n" \
        "$(awk -F, '$5 == "onset" && ++k <= 20 { printf "%s%s", sep, $2; sep = " " }' "$work/$label-$i.csv")" \
        >> "$work/alarms-$label.tsv"
    fi
  done
  awk -v n="$total" -v s="$seconds" 'BEGIN { printf "%d %.6g\n", n, s / 3600 }'
}
# P(N >= n) for N Poisson with mean m: how likely a count at least this large is by chance.
chance_of() {  # n m
  awk -v n="$1" -v m="$2" 'BEGIN {
    below = 0; term = exp(-m)
    for (k = 0; k < n; ++k) { below += term; term *= m / (k + 1) }
    p = 1 - below; printf "%.3g", p < 0 ? 0 : p }'
}
# "LOG at T1, T2 s; LOG at T s" from an alarms file: at most 5 times a log, 5 logs.
alarm_list() {  # alarms-file
  awk -F'\t' 'NR <= 5 {
      split($3, t, " "); times = ""
      for (k = 1; k <= 5 && k in t; ++k) times = times (k > 1 ? ", " : "") t[k]
      more = $2 > 5 ? sprintf(" and %d more", $2 - 5) : ""
      printf "%s%s at %s s%s", sep, $1, times, more; sep = "; " }
    END { if (NR > 5) printf "; %d more logs", NR - 5 }' "$1"
}
detect_logs in_place "$profile" old "${odd[@]}" || keep_old "cannot observe $failed_log (broken log?)"
detect_logs candidate "$candidate" new "${odd[@]}" || keep_old "cannot observe $failed_log with the candidate"
read -r new_events check_hours < <(events candidate "${odd[@]}")
read -r old_events _ < <(events in_place "${odd[@]}")
if [[ $new_events == none ]]; then
  to_log < "$work/detect.err"
  keep_old "the candidate cannot run the detector (see above)"
fi
# The rate the candidate's thresholds aim at for the signal mo-detect judges (mu when
# calibrated, else r): the night holds both profiles to their aim, which errs towards refusing
# and alarming when the day's data are too short to vouch for it (the report's "stated" rate is
# then higher, and says so).
rate=$(awk '$1 == "#" && $3 == "false" && $4 == "alarms" && $5 == "stated:" {
    r[$2] = $6; for (k = 6; k < NF; ++k) if ($k == "aim" && $(k + 1) == "at") r[$2] = $(k + 2) }
  END { print ("mu" in r) ? r["mu"] : ("r" in r) ? r["r"] : "" }' "$work/calibration.txt")
[[ -n $rate ]] || keep_old "the calibration states no false-alarm rate (see above)"
expected_events=$(awk -v r="$rate" -v h="$check_hours" 'BEGIN { printf "%.4g", r * h }')
new_chance=$(chance_of "$new_events" "$expected_events")
# The profile in place promised a rate too, when it was calibrated (its provenance says which;
# see in_place_promise): judged on the same logs by the same rule.
old_rate="" old_rate_from=""
if [[ $old_events != none ]]; then
  if command -v python3 > /dev/null; then
    IFS=$'\t' read -r old_rate old_rate_from < <(python3 -c "$json_program" promise "$profile")
  else
    say "python3 not found: the profile in place's promise cannot be read, only the candidate is judged"
  fi
fi
old_keeps=unknown
if [[ -n $old_rate ]]; then
  old_expected_events=$(awk -v r="$old_rate" -v h="$check_hours" 'BEGIN { printf "%.4g", r * h }')
  old_chance=$(chance_of "$old_events" "$old_expected_events")
  old_keeps=yes
  awk -v p="$old_chance" -v level="$check_level" 'BEGIN { exit !(p < level) }' && old_keeps=no
fi
new_keeps=yes
awk -v p="$new_chance" -v level="$check_level" 'BEGIN { exit !(p < level) }' && new_keeps=no
say "check part ($check_hours h): candidate $new_events events (its calibration stands for $expected_events;" \
  "as many or more by chance: $new_chance), profile in place $old_events" \
  "${old_rate:+(it stands for $old_expected_events, $old_rate_from; as many or more by chance: $old_chance)}"
[[ -s $work/alarms-candidate.tsv ]] && say "the candidate's events: $(alarm_list "$work/alarms-candidate.tsv")"
[[ -s $work/alarms-in_place.tsv ]] && say "the events of the profile in place: $(alarm_list "$work/alarms-in_place.tsv")"
old_said="the profile in place raises $old_events events there where it stands for $old_expected_events"
new_said="the candidate raises $new_events where it stands for $expected_events"
if [[ $new_keeps == no && $old_keeps == no ]]; then
  # Neither profile describes the arm of this day (or the day held collisions): no profile to
  # trust, and nothing a night can decide. Loud: its own outcome and exit status.
  outcome=alarming
  reason="neither profile keeps its promise on the check logs: $old_said, $new_said;"
  reason+=" the candidate's events: $(alarm_list "$work/alarms-candidate.tsv")"
  reason+="; a collision in these logs, or an arm that no longer matches its model: look at them"
  say "ALARMING, $profile unchanged: $reason"
  exit 3
fi
if [[ $new_keeps == no ]]; then
  keep_old --refused "the candidate raises $new_events events on collision-free logs (its calibration stands for $expected_events)"
fi
arm_changed=0
if [[ $old_keeps == no ]]; then
  # The profile in place breaks its own promise where the candidate, fitted on the same day,
  # keeps its: the arm changed (wear, a new tool). Thresholds that grew are then what the arm
  # needs, not a sign of a contact the calibration missed.
  arm_changed=1
  reason="the profile in place breaks its promise: $old_events events on the check logs where it stands for"
  reason+=" $old_expected_events (chance $old_chance); the candidate keeps its: $new_events where it stands for $expected_events"
  say "the arm changed: $reason"
else
  if [[ $old_events != none ]] && ((new_events > old_events)); then
    keep_old --refused "the candidate raises more events than the profile in place"
  fi
  # Thresholds must not balloon: a day that calibrates far looser than the profile in place,
  # while the profile in place keeps quiet, is suspicious (a contact the contact check missed,
  # a sensor fault).
  growth=$(awk -v limit="$max_increase" '
    $1 == "#" && $2 == "change" && $9 ~ /%$/ && $9 + 0 > limit { printf "%s%s %s %s -> %s Nm (%s)", sep, $3, $4, $5, $7, $9; sep = "; " }
  ' "$work/calibration.txt")
  [[ -z $growth ]] || keep_old --refused "thresholds grew by more than $max_increase%: $growth"
fi

if ((dry_run)); then
  outcome=dry-run
  say "dry run: the candidate would be installed"
  exit 0
fi

# 7. Install, through the tools' own lock and rename (lib/src/core/file.cpp: FileLock,
# replace_file): the file the profile names through its symbolic links is locked with flock(2)
# on the file itself (and locked again when a holder renamed a new file over it meanwhile);
# under the lock the night checks that the profile is still the one it started from, backs it
# up, writes the candidate to a temporary file beside it (.NAME.XXXXXX, the tools' pattern) and
# renames that over it. A symbolic link stays a link and its target gets the new profile; a
# tool updating the profile in place holds the same lock, so the night waits for it (at most
# --lock-wait s) and never writes over its update.
target=$(readlink -f -- "$profile") && [[ -f $target ]] || keep_old "cannot resolve $profile to a plain file"
lock_fd=""
take_profile_lock() {  # 0: locked (lock_fd); 1: still held by another after --lock-wait s; 2: cannot open
  local attempt
  for ((attempt = 0; attempt < 100; ++attempt)); do
    exec {lock_fd}< "$target" || return 2
    if ! flock -n "$lock_fd"; then
      say "waiting (at most $lock_wait s) for the lock on $target: a tool is updating it in place"
      if ! flock -w "$lock_wait" "$lock_fd"; then
        exec {lock_fd}<&-
        return 1
      fi
    fi
    # The holder may have renamed a new file over the one locked: lock that one.
    [[ $(stat -L -c %d:%i "/dev/fd/$lock_fd") == "$(stat -c %d:%i "$target" 2> /dev/null)" ]] && return 0
    exec {lock_fd}<&-
  done
  return 2
}
take_profile_lock
case $? in
  1) keep_old "the lock on $target was held for more than $lock_wait s (a tool updating the profile in place?);" \
       "the candidate is not installed" ;;
  2) keep_old "cannot lock $target" ;;
esac
if [[ $(sha256sum < "$target") != "$sha_start" ]]; then
  keep_old --kept "the profile changed during the night (updated in place by a tool, or by hand): the candidate," \
    "made from the profile as it was, is not installed over the change"
fi
# Stamped to the nanosecond, so that names sort in time order for --keep: stamped to the second,
# two nights installed within one second (a rerun, a test) left one backup, the other overwritten.
backup="$backups/$name.$(date -u +%Y%m%dT%H%M%S.%NZ).json"
[[ ! -e $backup ]] && cp -p "$target" "$backup" || keep_old "cannot back up to $backup"
install_temp=$(mktemp "$(dirname "$target")/.$(basename "$target").XXXXXX") ||
  keep_old "cannot create a temporary file beside $target"
cat "$candidate" > "$install_temp" || keep_old "cannot write $install_temp"
chmod --reference="$target" "$install_temp" 2> /dev/null
chown --reference="$target" "$install_temp" 2> /dev/null
sync "$install_temp" 2> /dev/null
# One rename(2) within the target's folder (mv asks nothing with standard input not a terminal).
mv -T -- "$install_temp" "$target" < /dev/null || keep_old "cannot rename the candidate over $target"
install_temp=""
sync "$(dirname "$target")" 2> /dev/null
exec {lock_fd}<&-
rm -f "$candidate"
outcome=installed
say "INSTALLED the new profile$([[ $target == "$profile" ]] || echo " in $target, the file the link names"); the old one is $backup"
mapfile -t old_backups < <(ls -1 "$backups"/"$name".*.json 2> /dev/null | sort -r | tail -n +$((keep + 1)))
for f in "${old_backups[@]}"; do
  rm -f "$f" && say "removed old backup $f"
done
exit 0
