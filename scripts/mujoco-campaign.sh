#!/usr/bin/env bash
# The documented workflow on a campaign of the foreign simulator (../shared/reference/mujoco/):
#   scripts/mujoco-campaign.sh [--classes-from DIR] [--work DIR] CAMPAIGN_DIR [BUILD_DIR]
#
# CAMPAIGN_DIR holds profile.json with its URDF, ident_<rate>.csv (excitation, collision-free),
# free_<rate>.csv (collision-free motion), coll_<rate>.csv (with contacts), truth_coll.csv and
# truth_coll_detail.json. As a user would:
#   1. friction from the excitation (mo-lugre-fit), thresholds from the free motion (mo-calibrate);
#   2. the contact/collision rule from a labelled campaign (mo-calibrate --classes): the one of
#      --classes-from (another campaign of the same generator: the honest figure), else this
#      campaign's own (an in-sample figure, said so);
#   3. detection, identification and classification on coll (mo-detect), scored by mo-eval
#      against the truth converted by scripts/mujoco-truth.py.
set -euo pipefail
classes_from="" work="" keep=0
while (($#)); do
  case $1 in
    --classes-from) classes_from=${2:?}; shift 2 ;;
    --work) work=${2:?}; keep=1; shift 2 ;;
    -h|--help) sed -n '2,14p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    -*) echo "mujoco-campaign: unknown option $1" >&2; exit 2 ;;
    *) break ;;
  esac
done
campaign=$(cd "${1:?usage: mujoco-campaign.sh [--classes-from DIR] [--work DIR] CAMPAIGN_DIR [BUILD_DIR]}" && pwd)
build=$(cd "${2:-build}" && pwd)
here=$(cd "$(dirname "$0")/.." && pwd)
export PATH=$build/bin:$PATH
if [[ -z $work ]]; then
  work=$(mktemp -d /tmp/momentum-mujoco.XXXXXX)
  trap 'rm -rf "$work"' EXIT
fi
mkdir -p "$work"

# Calibrates a campaign folder into $2/calibrated.json and observes its coll log.
prepare() {  # campaign_dir out_dir
  local c=$1 o=$2 ident free coll
  mkdir -p "$o"
  ident=$(ls "$c"/ident_*.csv | head -1) free=$(ls "$c"/free_*.csv | head -1) coll=$(ls "$c"/coll_*.csv | head -1)
  cp "$c/profile.json" "$c"/*.urdf "$o/"
  mo-observe -q -p "$o/profile.json" "$ident" > "$o/ident.obs.csv"
  mo-lugre-fit -q -p "$o/profile.json" -o "$o/fitted.json" "$o/ident.obs.csv"
  mo-observe -q -p "$o/fitted.json" "$free" > "$o/free.obs.csv"
  mo-calibrate -q -p "$o/fitted.json" -o "$o/calibrated.json" "$o/free.obs.csv" > /dev/null
  mo-observe -q -p "$o/calibrated.json" "$coll" > "$o/coll.obs.csv"
  python3 "$here/scripts/mujoco-truth.py" "$c/truth_coll.csv" "$c/truth_coll_detail.json" > "$o/truth.csv"
  mo-detect -q -p "$o/calibrated.json" "$o/coll.obs.csv" > "$o/events.csv" || [[ $? == 1 ]]
}

prepare "$campaign" "$work/test"
if [[ -n $classes_from ]]; then
  prepare "$(cd "$classes_from" && pwd)" "$work/train"
  train=$work/train
  echo "class rule learnt on $classes_from"
else
  train=$work/test
  echo "class rule learnt on this campaign itself: the class figure is in-sample"
fi
mo-calibrate -p "$work/test/calibrated.json" --classes "$train/events.csv" --truth "$train/truth.csv" \
  -o "$work/test/classified.json"
mo-detect -q -p "$work/test/classified.json" "$work/test/coll.obs.csv" > "$work/test/events.csv" || [[ $? == 1 ]]
duration=$(tail -1 "$(ls "$campaign"/coll_*.csv | head -1)" | cut -d, -f1)
mo-eval --truth "$work/test/truth.csv" --duration "$duration" "$work/test/events.csv"
