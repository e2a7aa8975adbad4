# Shared by the nightly shell tests (sourced; they set `tmp` first).

# check DESCRIPTION COMMAND...: runs the command, prints "ok:" or "FAILED:" with the
# description, and counts the failures in `failures`.
failures=0
check() {
  local what=$1
  shift
  if "$@"; then
    echo "ok: $what"
  else
    echo "FAILED: $what"
    failures=$((failures + 1))
  fi
}

# sim_log SEED OUT [mo-sim options...]: 30 s of the paper arm at 125 Hz ($tmp/paper-arm.json,
# or the profile in `plant`: a worn arm) into OUT; says so when mo-sim fails.
sim_log() {
  mo-sim -q -p "${plant:-$tmp/paper-arm.json}" --seed "$1" --rate 125 --duration 30 "${@:3}" -o "$2" ||
    echo "mo-sim failed for $2"
}
