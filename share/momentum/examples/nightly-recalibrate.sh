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
#  2. observes every log with the profile in place (mo-observe --strict: a broken log stops
#     the night, the profile stays);
#  3. fits friction on the calibration part (mo-lugre-fit); when the fit is refused (worse
#     than the friction in place) or fails, the current friction is kept;
#  4. observes the calibration part again with the candidate's friction and calibrates the
#     thresholds (mo-calibrate --reject-contact: a log that looks like it holds a contact
#     stops the night, the profile stays);
#  5. checks the candidate on the check part: mo-detect must find no event at all (the day
#     was collision-free, or the logs are not fit to calibrate on), no more than the profile
#     in place finds there, and no threshold may grow by more than --max-increase percent;
#  6. installs the candidate by renaming it over the profile, after a dated backup
#     (--backups, the newest --keep kept).
# Exit status: 0 when the new profile was installed or the old one was kept as at least as
# good; 1 when the night failed or the candidate was refused (the old profile stays; see the
# log); 2 on a usage error.
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
  --no-friction-fit       keep the friction in place, recalibrate the thresholds only
  --seed N                seed of the friction fit (default 1)
  -n, --dry-run           do everything but install
  -h, --help              this help
EOF
}

profile="" logs_dir="" backups="" keep=30 log_file="" max_increase=50 seed=1
dry_run=0 fit_friction=1
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
    --no-friction-fit) fit_friction=0; shift ;;
    --seed) seed=${2:?}; shift 2 ;;
    -n|--dry-run) dry_run=1; shift ;;
    -h|--help) usage; exit 0 ;;
    -*) echo "nightly-recalibrate: unknown option $1" >&2; usage >&2; exit 2 ;;
    *) logs+=("$1"); shift ;;
  esac
done
if [[ -z $profile || ! -f $profile ]]; then
  echo "nightly-recalibrate: give the profile in use with -p (a file)" >&2
  exit 2
fi
profile=$(cd "$(dirname "$profile")" && pwd)/$(basename "$profile")
folder=$(dirname "$profile")
name=$(basename "$profile" .json)
backups=${backups:-$folder/backups}
mkdir -p "$backups" || exit 2
log_file=${log_file:-$backups/nightly.log}
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
cleanup() { [[ -n $work ]] && rm -rf "$work"; rm -f "$candidate"; }
trap cleanup EXIT
# Ends the night keeping the profile in place.
keep_old() {
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
  say "another nightly run holds $folder/.$name.nightly.lock; nothing done"
  exit 1
fi

say "---- nightly recalibration of $profile from ${#logs[@]} logs"
for tool in mo-observe mo-lugre-fit mo-calibrate mo-detect; do
  command -v "$tool" > /dev/null || keep_old "$tool not found on PATH"
done
((${#logs[@]} >= 2)) || keep_old "need at least 2 logs (one to calibrate on, one to check), got ${#logs[@]}"
work=$(mktemp -d "${TMPDIR:-/tmp}/momentum-nightly.XXXXXX") || keep_old "cannot create a work folder"
# sed's pattern and replacement, each with its special characters escaped.
pattern() { printf '%s' "$1" | sed 's/[]\/$*.^|[]/\\&/g'; }
replacement() { printf '%s' "$1" | sed 's/[\/&|]/\\&/g'; }
{
  for i in "${!logs[@]}"; do
    echo "s|$(pattern "$work/old-$i.bin")|$(replacement "${logs[i]} (observed with the profile in place)")|g"
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

# 2. Observe everything with the profile in place.
observe() {  # profile log out
  run mo-observe -q --strict -p "$1" --output-format bin -o "$3" "$2" || return 1
}
for i in "${!logs[@]}"; do
  observe "$profile" "${logs[i]}" "$work/old-$i.bin" || keep_old "cannot observe ${logs[i]} (broken log?)"
done
old_calibration=() old_check=()
for i in "${!logs[@]}"; do
  if ((i % 2 == 0)); then old_calibration+=("$work/old-$i.bin"); else old_check+=("$work/old-$i.bin"); fi
done

# 3. Friction.
cp "$profile" "$candidate" || keep_old "cannot write $candidate"
if ((fit_friction)); then
  if run mo-lugre-fit -p "$profile" -o "$candidate" --seed "$seed" "${old_calibration[@]}"; then
    say "friction refitted (report above in this log)"
  else
    say "friction fit refused or failed (see above): keeping the friction in place"
    cp "$profile" "$candidate" || keep_old "cannot write $candidate"
  fi
fi

# 4. Thresholds, on residuals compensated with the candidate's friction.
new_calibration=()
for i in "${!logs[@]}"; do
  ((i % 2 == 0)) || continue
  observe "$candidate" "${logs[i]}" "$work/new-$i.bin" || keep_old "cannot observe ${logs[i]} with the candidate"
  new_calibration+=("$work/new-$i.bin")
done
if ! run mo-calibrate -q -p "$candidate" --reject-contact --strict "${calibrate_options[@]}" "${new_calibration[@]}" \
    > "$work/calibration.txt"; then
  to_log < "$work/calibration.txt"
  keep_old "calibration refused or failed (a contact in the calibration logs?)"
fi
to_log < "$work/calibration.txt"

# 5. Check: events on the check part, candidate and profile in place.
events() {  # profile observed-streams...: prints the number of events, or "none" without thresholds
  local p=$1 total=0 n status
  shift
  for f in "$@"; do
    mo-detect -q -p "$p" "$f" > "$work/events.csv" 2>> "$work/detect.err"
    status=$?
    if ((status == 2)); then
      echo none
      return
    fi
    n=$(grep -c ',onset,' "$work/events.csv")
    total=$((total + n))
  done
  echo "$total"
}
new_check=()
for i in "${!logs[@]}"; do
  ((i % 2 == 1)) || continue
  observe "$candidate" "${logs[i]}" "$work/new-$i.bin" || keep_old "cannot observe ${logs[i]} with the candidate"
  new_check+=("$work/new-$i.bin")
done
new_events=$(events "$candidate" "${new_check[@]}")
old_events=$(events "$profile" "${old_check[@]}")
say "check part: candidate $new_events events, profile in place $old_events"
if [[ $new_events == none ]]; then
  to_log < "$work/detect.err"
  keep_old "the candidate cannot run the detector (see above)"
fi
((new_events == 0)) || keep_old "the candidate raises $new_events events on collision-free logs"
if [[ $old_events != none ]] && ((new_events > old_events)); then
  keep_old "the candidate raises more events than the profile in place"
fi

# Thresholds must not balloon: a day that calibrates far looser than the profile in place is
# suspicious (a contact the contact check missed, a sensor fault).
growth=$(awk -v limit="$max_increase" '
  $1 == "#" && $2 == "change" && $9 ~ /%$/ && $9 + 0 > limit { printf "%s%s %s %s -> %s Nm (%s)", sep, $3, $4, $5, $7, $9; sep = "; " }
' "$work/calibration.txt")
[[ -z $growth ]] || keep_old "thresholds grew by more than $max_increase%: $growth"

if ((dry_run)); then
  say "dry run: the candidate would be installed"
  exit 0
fi

# 6. Install: dated backup, then one rename.
backup="$backups/$name.$(date -u +%Y%m%dT%H%M%SZ).json"
cp -p "$profile" "$backup" || keep_old "cannot back up to $backup"
chmod --reference="$profile" "$candidate" 2> /dev/null
mv -f "$candidate" "$profile" || keep_old "cannot rename the candidate over the profile"
say "INSTALLED the new profile; the old one is $backup"
mapfile -t old_backups < <(ls -1 "$backups"/"$name".*.json 2> /dev/null | sort -r | tail -n +$((keep + 1)))
for f in "${old_backups[@]}"; do
  rm -f "$f" && say "removed old backup $f"
done
exit 0
