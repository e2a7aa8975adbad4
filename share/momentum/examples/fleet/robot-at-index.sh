#!/usr/bin/env bash
# robot-at-index.sh: which robot of a fleet an array index stands for, the same way for every
# scheduler (a Kubernetes Indexed Job's JOB_COMPLETION_INDEX, a Slurm array's
# SLURM_ARRAY_TASK_ID, the order fleet-recalibrate.sh lists them in).
#
#   robot-at-index.sh INDEX FLEET          the INDEX-th (from 0) folder FLEET/robots/NAME/ holding
#                                          a profile.json, in byte order of NAME (LC_ALL=C: the
#                                          same on every node whatever its locale)
#   robot-at-index.sh INDEX --list FILE    the INDEX-th name in FILE (one a line; blank lines and
#                                          lines starting with # skipped), e.g. a ConfigMap's
#   robot-at-index.sh --all FLEET | --list FILE     every name, one a line, in index order
#   robot-at-index.sh --count FLEET | --list FILE   how many (the array's size)
#
# Exit status: 0; 1 when INDEX is past the end (or the fleet holds no robot); 2 on a usage error.
set -uo pipefail

usage() {
  echo "usage: robot-at-index.sh (INDEX | --all | --count) (FLEET | --list FILE)" >&2
  exit 2
}
(($# == 2 || $# == 3)) || usage
what=$1
shift
case $what in
  --all | --count) ;;
  *) [[ $what =~ ^[0-9]+$ ]] || usage ;;
esac
names() {
  if [[ $1 == --list ]]; then
    [[ $# == 2 && -r $2 ]] || { echo "robot-at-index: cannot read the list ${2:-}" >&2; exit 2; }
    sed -e 's/^[[:space:]]*//' -e 's/[[:space:]]*$//' -e '/^$/d' -e '/^#/d' "$2"
  else
    [[ $# == 1 && -d $1/robots ]] || { echo "robot-at-index: no folder ${1:-FLEET}/robots" >&2; exit 2; }
    local p
    for p in "$1"/robots/*/profile.json; do
      [[ -f $p ]] && basename "$(dirname "$p")"
    done | LC_ALL=C sort
  fi
}
list=$(names "$@") || exit $?
case $what in
  --all) [[ -z $list ]] || printf '%s\n' "$list" ;;
  --count) if [[ -z $list ]]; then echo 0; else printf '%s\n' "$list" | wc -l; fi ;;
  *)
    name=$(printf '%s\n' "$list" | sed -n "$((10#$what + 1))p")
    if [[ -z $name ]]; then
      echo "robot-at-index: no robot at index $what (the fleet has $(printf '%s' "$list" | grep -c '^'))" >&2
      exit 1
    fi
    printf '%s\n' "$name"
    ;;
esac
