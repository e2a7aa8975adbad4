#!/usr/bin/env bash
# Test of share/momentum/examples/fleet/: a fleet of four simulated paper arms (mo-sim, 125 Hz,
# two 30 s logs a robot), recalibrated by fleet-recalibrate.sh with GNU parallel: two clean
# nights (installed with new thresholds), a contaminated one (a collision in its calibration
# log: refused with its reason, its profile unchanged byte for byte) and a worn arm (its
# simulated friction 30% up: the profile in place breaks its promise, the candidate is
# installed and the line says so with both counts). Then a fleet of one robot whose check log
# holds a collision: neither profile keeps its promise, the night is alarming (its outcome, the
# collision's log and time in the reason) and the fleet run exits 1. Checks one valid JSON line
# per robot, the jq summaries of the README, the index -> robot mapping that the Kubernetes and
# Slurm examples share, one Slurm array task run by hand, and the examples' syntax (bash -n,
# the YAML when python3 has yaml). Needs the tools on PATH and SRC (the source tree) set; exits
# 77 (skipped) without GNU parallel or jq.
set -uo pipefail
: "${SRC:?set SRC to the source tree}"
fleet_dir="$SRC/share/momentum/examples/fleet"
for tool in parallel jq python3; do
  command -v "$tool" > /dev/null || { echo "fleet_test: $tool not installed (scripts/setup.sh installs it); skipped"; exit 77; }
done
tmp=$(mktemp -d)
trap '[[ -n ${KEEP:-} ]] || rm -rf "$tmp"' EXIT
echo "work: $tmp" >&2
source "$(dirname "$0")/helpers.sh"

# Syntax of every script of the examples, and the YAML.
for f in "$fleet_dir"/*.sh "$fleet_dir"/*.sbatch "$SRC/share/momentum/examples/nightly-recalibrate.sh"; do
  check "bash -n $(basename "$f")" bash -n "$f"
done
if python3 -c 'import yaml' 2> /dev/null; then
  check "k8s-cronjob.yaml: a ConfigMap list and an Indexed Job of as many completions" python3 - "$fleet_dir/k8s-cronjob.yaml" <<'PY'
import sys, yaml
docs = {d["kind"]: d for d in yaml.safe_load_all(open(sys.argv[1]))}
robots = [l for l in docs["ConfigMap"]["data"]["robots.txt"].splitlines() if l.strip() and not l.startswith("#")]
job = docs["CronJob"]["spec"]["jobTemplate"]["spec"]
pod = job["template"]["spec"]
script = " ".join(pod["containers"][0]["args"])
assert job["completionMode"] == "Indexed", job
assert job["completions"] == len(robots), (job["completions"], robots)
assert 1 <= job["parallelism"], job
assert pod["restartPolicy"] == "Never"
assert "recalibrate-robot.sh" in script and "$JOB_COMPLETION_INDEX" in script and "--results" in script, script
PY
else
  echo "skipped: the YAML (python3 without yaml)"
fi
check "slurm-array.sbatch: an array of 100, 10 at a time" grep -q '^#SBATCH --array=0-99%10$' "$fleet_dir/slurm-array.sbatch"

# The fleet: robots/NAME/profile.json (the paper arm, commissioned: thresholds calibrated on a
# log without friction) and robots/NAME/logs/DAY/. Robot arm-b's calibration log (the first)
# holds a collision; arm-d is worn: its simulated plant's friction (the profile's
# simulation.friction, which only mo-sim reads) is 30% up on every joint. In a second fleet,
# arm-e's check log (the second) holds a collision.
day=2024-05-17
fleet="$tmp/fleet" fleet2="$tmp/fleet2"
cp "$SRC/share/momentum/robots/paper-arm/paper-arm.json" "$SRC/share/momentum/robots/paper-arm/paper-arm.urdf" "$tmp/"
mkdir -p "$tmp/worn"
cp "$tmp/paper-arm.urdf" "$tmp/worn/"
python3 - "$tmp/paper-arm.json" "$tmp/worn/paper-arm.json" 1.3 <<'EOF'
import json, re, sys
source, worn, scale = sys.argv[1], sys.argv[2], float(sys.argv[3])
p = json.loads(re.sub(r"(?m)^\s*//.*$", "", open(source).read()))
for joint in p["simulation"]["friction"]["joints"]:
    for key in ("sigma1", "sigma2", "tau_c", "tau_s"):
        joint[key] *= scale
json.dump(p, open(worn, "w"), indent=1)
EOF
mkdir -p "$fleet/robots/arm-"{a,b,c,d}"/logs/$day" "$fleet2/robots/arm-e/logs/$day"
sim_log 100 "$tmp/commissioning.csv" &
sim_log 11 "$fleet/robots/arm-a/logs/$day/log-1.csv" &
wait
sim_log 12 "$fleet/robots/arm-a/logs/$day/log-2.csv" &
sim_log 21 "$fleet/robots/arm-b/logs/$day/log-1.csv" --collisions 1 --min-spacing 5 &
wait
sim_log 22 "$fleet/robots/arm-b/logs/$day/log-2.csv" &
sim_log 31 "$fleet/robots/arm-c/logs/$day/log-1.csv" &
wait
sim_log 32 "$fleet/robots/arm-c/logs/$day/log-2.csv" &
plant=$tmp/worn/paper-arm.json sim_log 41 "$fleet/robots/arm-d/logs/$day/log-1.csv" &
wait
plant=$tmp/worn/paper-arm.json sim_log 42 "$fleet/robots/arm-d/logs/$day/log-2.csv" &
sim_log 51 "$fleet2/robots/arm-e/logs/$day/log-1.csv" &
wait
sim_log 32 "$fleet2/robots/arm-e/logs/$day/log-2.csv" --collisions 1 --min-spacing 5 --truth "$tmp/arm-e.truth" &
mo-observe -q -p "$tmp/paper-arm.json" "$tmp/commissioning.csv" --output-format bin -o "$tmp/commissioning.bin" &&
  mo-calibrate -q -p "$tmp/paper-arm.json" --margin-percent 30 "$tmp/commissioning.bin" > /dev/null ||
  echo "commissioning failed"
wait
for r in a b c d e; do
  robot_dir=$fleet/robots/arm-$r
  [[ $r == e ]] && robot_dir=$fleet2/robots/arm-$r
  cp "$tmp/paper-arm.json" "$robot_dir/profile.json"
  cp "$tmp/paper-arm.urdf" "$robot_dir/"
  cp "$tmp/paper-arm.json" "$tmp/arm-$r.before.json"
done

# index -> robot, as the Kubernetes and Slurm examples map it.
printf '# the fleet\narm-c\n\n  arm-a\narm-b\n' > "$tmp/robots.txt"
mapping=$(for i in 0 1 2 3; do "$fleet_dir/robot-at-index.sh" "$i" "$fleet"; done | tr '\n' ' ')
check "robot-at-index.sh: sorted folders ($mapping)" test "$mapping" == "arm-a arm-b arm-c arm-d "
mapping=$(for i in 0 1 2; do "$fleet_dir/robot-at-index.sh" "$i" --list "$tmp/robots.txt"; done | tr '\n' ' ')
check "robot-at-index.sh --list: lines, comments and blanks skipped ($mapping)" test "$mapping" == "arm-c arm-a arm-b "
check "robot-at-index.sh --count" test "$("$fleet_dir/robot-at-index.sh" --count "$fleet")" == 4
"$fleet_dir/robot-at-index.sh" 4 "$fleet" 2> /dev/null
check "robot-at-index.sh: index past the end, exit status 1" test $? == 1

# The night.
SECONDS=0
"$fleet_dir/fleet-recalibrate.sh" -j 2 --day "$day" "$fleet" -- --margin-percent 30 --seed 1 \
  > "$tmp/out.jsonl" 2> "$tmp/err"
status=$?
echo "fleet-recalibrate.sh: ${SECONDS} s" >&2
cat "$tmp/err" >&2
check "fleet-recalibrate.sh exits 0 (a refusal is a result)" test $status == 0
check "the results file holds what standard output did" cmp -s "$tmp/out.jsonl" "$fleet/results/$day.jsonl"
summary=$(grep '^fleet: ' "$tmp/err")
check "summary on standard error ($summary)" grep -q "^fleet: day $day, 4 robots: 3 installed, 1 refused; " <<< "$summary"

check "one JSON line per robot, as expected" python3 - "$tmp/out.jsonl" "$fleet" "$tmp" <<'PY'
import hashlib, json, sys
out, fleet, tmp = sys.argv[1:]
lines = open(out).read().splitlines()
rows = [json.loads(l) for l in lines]
assert len(rows) == 4, lines
by = {r["robot"]: r for r in rows}
assert sorted(by) == ["arm-a", "arm-b", "arm-c", "arm-d"], sorted(by)
keys = {"robot", "profile", "profile_version", "day", "logs", "outcome", "reason", "exit_status",
        "thresholds_before", "thresholds_after", "started", "finished", "duration_s"}
sha = lambda path: hashlib.sha256(open(path, "rb").read()).hexdigest()
def stated_rate(path):
    import re
    text = re.sub(r"(?m)^\s*//.*$", "", open(path).read())
    for entry in reversed(json.loads(text).get("provenance", [])):
        d = entry.get("details", {}) if entry.get("tool") == "mo-calibrate" else {}
        if "rule" in d:
            stated = d.get("false_alarms_expected_per_hour")
            stated = stated.get("r") if isinstance(stated, dict) else stated
            return stated if isinstance(stated, (int, float)) else 0.03
    return 0.03
for name, r in by.items():
    assert keys <= set(r), (name, keys - set(r))
    assert r["day"] == "2024-05-17" and r["logs"] == 2, r
    assert r["profile"] == f"{fleet}/robots/{name}/profile.json", r["profile"]
    v = r["profile_version"]
    assert v["name"] == "paper-arm" and v["sha256_before"] == sha(f"{tmp}/{name}.before.json"), v
    assert v["sha256_after"] == sha(r["profile"]), v
    # Commissioned without friction: thresholds on r only.
    assert list(r["thresholds_before"]) == ["r"] and len(r["thresholds_before"]["r"]["moving"]) == 3, r["thresholds_before"]
    assert r["started"].endswith("Z") and r["duration_s"] >= 0, r
for name in ("arm-a", "arm-c", "arm-d"):
    r = by[name]
    assert r["outcome"] == "installed" and r["exit_status"] == 0, r
    assert (r["reason"] is None) == (name != "arm-d"), r
    after, before = r["thresholds_after"], r["thresholds_before"]
    # Friction fitted: thresholds on mu too; those on r measured again.
    assert sorted(after) == ["mu", "r"], after
    assert after["r"]["moving"] != before["r"]["moving"] and after["r"]["slow"] != before["r"]["slow"], (before, after)
    assert all(x > 0 for x in after["mu"]["moving"] + after["r"]["moving"]), after
    assert r["profile_version"]["sha256_after"] != r["profile_version"]["sha256_before"]
    assert r["profile_version"]["changes_after"] > r["profile_version"]["changes_before"]
    assert r["check_events"]["candidate"] == 0, r
    # The candidate's stated false alarms over the check part's hours (2 logs of 30 s: 1 checked).
    ce = r["check_events"]
    assert 0 < ce["expected"] < 0.05 and abs(ce["hours"] - 30 / 3600) < 1e-3, ce
    assert ce["candidate_keeps_promise"] is True, ce
    # The commissioned profile promises what its calibration stated (mo-calibrate's provenance,
    # false_alarms_expected_per_hour of r), else what it asked: 0.01 an hour of each of 3 joints.
    assert abs(ce["in_place_expected"] - stated_rate(f"{tmp}/{name}.before.json") * ce["hours"]) < 1e-6, ce
# The worn arm: the commissioned profile (no friction model, thresholds on r) alarms all along
# its check log; the candidate, friction fitted on the worn arm, keeps its promise.
ce = by["arm-d"]["check_events"]
assert ce["in_place_keeps_promise"] is False and ce["in_place"] >= 2 and ce["in_place_chance"] < 1e-6, ce
assert by["arm-d"]["reason"] == (
    f"the profile in place breaks its promise: {ce['in_place']} events on the check logs where it stands for "
    f"{ce['in_place_expected']:g} (chance {ce['in_place_chance']:g}); the candidate keeps its: {ce['candidate']} "
    f"where it stands for {ce['expected']:g}"), by["arm-d"]["reason"]
assert [a["log"] for a in ce["alarms"]["in_place"]] == [f"{fleet}/robots/arm-d/logs/2024-05-17/log-2.csv"], ce["alarms"]
for name in ("arm-a", "arm-c"):
    assert by[name]["check_events"]["in_place_keeps_promise"] is True, by[name]["check_events"]
r = by["arm-b"]
assert r["outcome"] == "refused" and r["exit_status"] == 1, r
assert "contact in the calibration logs" in r["reason"], r["reason"]
assert r["thresholds_after"] is None, r
assert r["profile_version"]["sha256_after"] == r["profile_version"]["sha256_before"]
PY
check "arm-b's profile unchanged byte for byte" cmp -s "$tmp/arm-b.before.json" "$fleet/robots/arm-b/profile.json"
for r in a c d; do
  check "arm-$r's profile replaced, the old one backed up" \
    bash -c '! cmp -s "$1" "$2" && cmp -s "$1" "$3"/profile.*.json' _ \
    "$tmp/arm-$r.before.json" "$fleet/robots/arm-$r/profile.json" "$fleet/robots/arm-$r/backups"
done

# The jq summaries of the README.
results="$fleet/results/$day.jsonl"
counts=$(jq -r '.outcome' "$results" | sort | uniq -c | awk '{print $1, $2}' | tr '\n' ';')
check "jq: outcomes counted ($counts)" test "$counts" == "3 installed;1 refused;"
refused=$(jq -r 'select(.outcome != "installed") | "\(.robot): \(.outcome): \(.reason)"' "$results")
check "jq: what was not installed, and why ($refused)" \
  test "$refused" == "arm-b: refused: calibration refused or failed (a contact in the calibration logs?)"
groups=$(jq -cs 'group_by(.outcome) | map({(.[0].outcome): map(.robot)}) | add' "$results")
check "jq: robots by outcome ($groups)" test "$groups" == '{"installed":["arm-a","arm-c","arm-d"],"refused":["arm-b"]}'
rises=$(jq -r 'select(.outcome == "installed") | [.robot, (.thresholds_after.mu.moving | length)] | @tsv' "$results" | tr '\t\n' ' ;')
check "jq: thresholds after per installed robot ($rises)" test "$rises" == "arm-a 3;arm-c 3;arm-d 3;"

# One robot as a Slurm array task (and a Kubernetes pod) runs it: index 1 is arm-b; a day
# without logs keeps its profile, a result (exit status 0), in results/DAY/arm-b.json.
SLURM_ARRAY_TASK_ID=1 FLEET=$fleet DAY=2024-05-18 MOMENTUM_FLEET_SCRIPTS=$fleet_dir \
  bash "$fleet_dir/slurm-array.sbatch" > "$tmp/task.out" 2> "$tmp/task.err"
status=$?
check "Slurm task: exit status 0" test $status == 0
check "Slurm task: arm-b kept, nothing to go on, in results/2024-05-18/arm-b.json" \
  bash -c 'jq -e "select(.robot == \"arm-b\" and .outcome == \"kept\" and (.reason | test(\"need at least 2 logs\")))" "$1" > /dev/null && cmp -s "$1" "$2"' _ \
  "$fleet/results/2024-05-18/arm-b.json" "$tmp/task.out"
# A robot the list names without a folder: one line all the same, outcome failed, exit 1.
"$fleet_dir/recalibrate-robot.sh" --fleet "$fleet" --robot ghost --day "$day" > "$tmp/ghost.json" 2> /dev/null
status=$?
check "a robot without a profile: exit status 1, one failed line" \
  bash -c '[[ $1 == 1 ]] && [[ $(jq -r "[.robot, .outcome, .reason] | join(\"|\")" "$2") == "ghost|failed|no profile "*"/robots/ghost/profile.json" ]]' _ \
  "$status" "$tmp/ghost.json"

# A fleet of one robot whose check log holds a collision: the profile in place and the
# candidate both raise events there, where each stands for far less than one. Neither keeps its
# promise: the night is alarming (exit status 3, the profile unchanged), its reason names the
# log and the time of the collision (the simulated truth), and the fleet run exits 1.
"$fleet_dir/fleet-recalibrate.sh" -j 1 --day "$day" "$fleet2" -- --margin-percent 30 --seed 1 \
  > "$tmp/out2.jsonl" 2> "$tmp/err2"
status=$?
cat "$tmp/err2" >&2
check "an alarming night: fleet-recalibrate.sh exits 1" test $status == 1
summary=$(grep '^fleet: ' "$tmp/err2")
check "an alarming night: summary ($summary)" grep -q "^fleet: day $day, 1 robots: 1 alarming; " <<< "$summary"
check "an alarming night: its line, the collision's log and time named" python3 - "$tmp/out2.jsonl" "$fleet2" "$tmp/arm-e.truth" <<'PY'
import csv, json, sys
out, fleet, truth = sys.argv[1:]
lines = open(out).read().splitlines()
assert len(lines) == 1, lines
r = json.loads(lines[0])
assert r["robot"] == "arm-e" and r["outcome"] == "alarming" and r["exit_status"] == 3, r
assert r["profile_version"]["sha256_after"] == r["profile_version"]["sha256_before"], r
ce = r["check_events"]
assert ce["candidate_keeps_promise"] is False and ce["in_place_keeps_promise"] is False, ce
contact = next(csv.DictReader(l for l in open(truth) if not l.startswith("#")))
onset, end = float(contact["t_onset"]), float(contact["t_end"])
log = f"{fleet}/robots/arm-e/logs/2024-05-17/log-2.csv"
alarms = ce["alarms"]["candidate"]
assert [a["log"] for a in alarms] == [log], alarms
t = [t for t in alarms[0]["t_detect"] if onset <= t <= end + 0.5]
assert t, (onset, end, alarms)
assert r["reason"].startswith("neither profile keeps its promise on the check logs: "), r["reason"]
assert f"the candidate's events: {log} at {alarms[0]['t_detect'][0]:g}" in r["reason"], r["reason"]
PY
check "an alarming night: arm-e's profile unchanged byte for byte" cmp -s "$tmp/arm-e.before.json" "$fleet2/robots/arm-e/profile.json"

echo "sample line: $(grep arm-a "$results")"
((failures == 0)) || { echo "$failures checks failed"; exit 1; }
echo "all checks passed"
