#!/usr/bin/env bash
# Identification and classification on simulated campaigns (mo-detect(1), CONTACTS AND COLLISIONS).
#   scripts/identify-campaigns.sh [--robots LIST] [--rates LIST] [--contacts N] [--seeds TRAIN,TEST]
#                                 [--work DIR] [BUILD_DIR]
# defaults: paper-arm,ur5,panda; 125,1000; 30 contacts per campaign; seeds 2,3; a fresh work
# folder.
#
# Per robot and rate, as a user would run it:
#   1. friction identified (mo-lugre-fit) on 60 s of multisine excitation, thresholds calibrated
#      on 600 s of collision-free motion of the campaigns' kind (the paper's sines); every robot
#      through a first-order observer at 50 rad/s (the paper arm's second order leaves a tail of
#      seconds after each held push, as the demo notes);
#   2. a training campaign (seed TRAIN, mo-sim --mixed): half impacts (stiff obstacles met at speed,
#      300 N/mm, held 10-50 ms: collisions), half slow pushes (rise 0.15-0.4 s, held 0.2-0.6 s:
#      contacts); its events teach mo-calibrate --classes the rule;
#   3. a test campaign of the same kinds (seed TEST), scored by mo-eval: isolation, class, force
#      and point errors, the link sets (truth in the set, mean size), per link.
# Prints one table row per robot and rate, and mo-eval's per-link table. With two rates or more,
# then the class rule learnt at each rate applied to the test campaign of each other rate (the
# rule's width and rise are in seconds: it should hold across rates).
set -euo pipefail
robots=paper-arm,ur5,panda rates=125,1000 contacts=30 seeds=2,3 work="" keep=0
while (($#)); do
  case $1 in
    --robots) robots=${2:?}; shift 2 ;;
    --rates) rates=${2:?}; shift 2 ;;
    --contacts) contacts=${2:?}; shift 2 ;;
    --seeds) seeds=${2:?}; shift 2 ;;
    --work) work=${2:?}; keep=1; shift 2 ;;
    -h|--help) sed -n '2,18p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    -*) echo "identify-campaigns: unknown option $1" >&2; exit 2 ;;
    *) break ;;
  esac
done
IFS=, read -r train_seed test_seed <<< "$seeds"
[[ $train_seed =~ ^[0-9]+$ && $test_seed =~ ^[0-9]+$ ]] ||
  { echo "identify-campaigns: --seeds wants two seeds, TRAIN,TEST (got '$seeds')" >&2; exit 2; }
build=$(cd "${1:-build}" && pwd)
here=$(cd "$(dirname "$0")/.." && pwd)
for t in mo-sim mo-observe mo-lugre-fit mo-calibrate mo-detect mo-eval; do
  [[ -x $build/bin/$t ]] || { echo "identify-campaigns: $build/bin/$t not built" >&2; exit 1; }
done
export PATH=$build/bin:$PATH
if [[ -z $work ]]; then
  work=$(mktemp -d /tmp/momentum-identify.XXXXXX)
  trap 'rm -rf "$work"' EXIT
fi

profile_of() {  # robot -> profile path (copied with its URDF into the work folder)
  case $1 in
    paper-arm) cp "$here"/share/momentum/robots/paper-arm/paper-arm.{json,urdf} "$2/"; echo "$2/paper-arm.json" ;;
    ur5) cp "$here"/tests/data/ur5-sim.json "$here"/tests/data/ur5_robot.urdf "$2/"; echo "$2/ur5-sim.json" ;;
    panda) cp "$here"/tests/data/panda-sim.json "$here"/tests/data/panda.urdf "$2/"; echo "$2/panda-sim.json" ;;
    *) echo "identify-campaigns: unknown robot $1" >&2; exit 2 ;;
  esac
}

kinds=(--mixed)  # half impacts, half slow pushes (mo-sim(1))
printf '%-10s %5s  %-9s %-8s %-9s %-10s %-10s %-8s %s\n' robot Hz detected isolated class "force err" "point err" \
  "in set" "set size"
IFS=, read -ra robot_list <<< "$robots"
IFS=, read -ra rate_list <<< "$rates"
for robot in "${robot_list[@]}"; do
  for rate in "${rate_list[@]}"; do
    dir=$work/$robot-$rate
    mkdir -p "$dir"
    profile=$(profile_of "$robot" "$dir")
    sim=(mo-sim -q -p "$profile" --rate "$rate" --integrator semi-implicit --internal-rate $((rate > 2000 ? rate : 2000)))
    # 1. friction from excitation, thresholds from collision-free motion like the campaigns'
    "${sim[@]}" --seed 11 --duration 60 --trajectory multisine -o "$dir/ident.csv"
    "${sim[@]}" --seed 1 --duration 600 -o "$dir/free.csv"
    mo-observe -q --order 1 --k1 50 -p "$profile" "$dir/ident.csv" > "$dir/ident.r.csv"
    mo-lugre-fit -q -p "$profile" -o "$dir/fitted.json" "$dir/ident.r.csv"
    mo-observe -q --order 1 --k1 50 -p "$dir/fitted.json" "$dir/free.csv" > "$dir/free.obs.csv"
    mo-calibrate -q -p "$dir/fitted.json" -o "$dir/calibrated.json" "$dir/free.obs.csv" > /dev/null
    # 2. the class rule from a training campaign
    "${sim[@]}" --seed "$train_seed" --collisions "$contacts" "${kinds[@]}" --truth "$dir/train.truth.csv" -o "$dir/train.csv"
    mo-observe -q --order 1 --k1 50 -p "$dir/calibrated.json" "$dir/train.csv" > "$dir/train.obs.csv"
    mo-detect -q -p "$dir/calibrated.json" "$dir/train.obs.csv" > "$dir/train.events.csv" || [[ $? == 1 ]]
    mo-calibrate -q -p "$dir/calibrated.json" --classes "$dir/train.events.csv" --truth "$dir/train.truth.csv" \
      > "$dir/classes.txt"
    # 3. the test campaign
    "${sim[@]}" --seed "$test_seed" --collisions "$contacts" "${kinds[@]}" --truth "$dir/test.truth.csv" -o "$dir/test.csv"
    mo-observe -q --order 1 --k1 50 -p "$dir/calibrated.json" "$dir/test.csv" > "$dir/test.obs.csv"
    mo-detect -q -p "$dir/calibrated.json" "$dir/test.obs.csv" > "$dir/test.events.csv" || [[ $? == 1 ]]
    mo-eval --truth "$dir/test.truth.csv" --json "$dir/test.events.csv" > "$dir/score.json"
    mo-eval --truth "$dir/test.truth.csv" "$dir/test.events.csv" > "$dir/score.txt"
    python3 - "$dir/score.json" "$robot" "$rate" <<'EOF'
import json, sys
s = json.load(open(sys.argv[1]))
i = s["identification"]
med = lambda d, f: "-" if d["median"] is None else f.format(d["median"])
l = s["link_sets"]
size = "-" if l["mean_size"] is None else f"{l['mean_size']:.2f}"
print(f"{sys.argv[2]:<10} {sys.argv[3]:>5}  {s['detected']:>2}/{s['contacts']:<6} {s['isolated']:>2}/{s['detected']:<5} "
      f"{i['class_right']:>2}/{i['classified']:<6} {med(i['force_error_percent'], '{:.0f} %'):<10} "
      f"{med(i['point_error_m'], '{:.3f} m'):<10} {l['truth_in_set']:>2}/{l['with_set']:<5} {size}")
EOF
  done
done
if ((${#rate_list[@]} > 1)); then
  echo
  for robot in "${robot_list[@]}"; do
    for learnt in "${rate_list[@]}"; do
      for tested in "${rate_list[@]}"; do
        [[ $learnt == "$tested" ]] && continue
        from=$work/$robot-$learnt to=$work/$robot-$tested
        # The test rate's profile with the class rule of the other rate.
        python3 - "$from/calibrated.json" "$to/calibrated.json" "$to/cross.json" <<'EOF'
import json, re, sys
read = lambda p: json.loads(re.sub(r'(?m)^\s*//.*$', '', open(p).read()))
source, target = read(sys.argv[1]), read(sys.argv[2])
for signal, entry in source["thresholds"].items():
    if isinstance(entry, dict) and "classify" in entry:
        target["thresholds"][signal]["classify"] = entry["classify"]
json.dump(target, open(sys.argv[3], "w"), indent=1)
EOF
        mo-detect -q -p "$to/cross.json" "$to/test.obs.csv" > "$to/cross.events.csv" || [[ $? == 1 ]]
        echo "$robot: rule learnt at $learnt Hz on the $tested Hz test campaign:" \
          "$(mo-eval --truth "$to/test.truth.csv" "$to/cross.events.csv" | grep '^class' | sed 's/^class *//')" \
          "(its own rule: $(grep '^class' "$to/score.txt" | sed 's/^class *//'))"
      done
    done
  done
fi
echo
for robot in "${robot_list[@]}"; do
  for rate in "${rate_list[@]}"; do
    echo "== $robot, $rate Hz: $(cat "$work/$robot-$rate/classes.txt")"
    sed -n '/^link  classified/,$p' "$work/$robot-$rate/score.txt"
    sed -n '/^link  contacts/,/^$/p' "$work/$robot-$rate/score.txt"
  done
done
