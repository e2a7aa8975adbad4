#!/usr/bin/env bash
# Test of share/momentum/examples/fleet/slurm-array.sbatch on a real Slurm: starts a one-node
# cluster of its own (munged, slurmctld and slurmd of Debian's munge and slurm-wlm, every file
# in a temporary folder, on ports of their own, torn down on exit), and runs the array over a
# fleet of three simulated paper arms (mo-sim, 125 Hz, two 30 s logs a robot):
#   arm-a  a broken row in its check log: the night fails (mo-observe --strict);
#   arm-b  clean logs: installed;
#   arm-c  a collision in its calibration log: refused.
# The same fleet, laid out afresh at the same path, is first recalibrated with GNU parallel
# (fleet-recalibrate.sh, the tested way). Checks: each robot's Slurm line equals its GNU
# parallel line but for the run's clock (started, finished, duration_s, time stamps in names),
# the installed profiles equal likewise; arm-a's task (the first) is FAILED with exit code 1 and
# its line says failed, while arm-b's and arm-c's tasks COMPLETED with theirs, arm-c's started
# after arm-a's had failed (two tasks at a time): a failed task stops no other.
# Needs root (slurmd runs the tasks as the submitting user, and the daemons as root here), the
# tools on PATH and SRC (the source tree) set; exits 77 (skipped) without Slurm, munge, GNU
# parallel or jq (scripts/setup.sh installs them) or when not root.
set -uo pipefail
: "${SRC:?set SRC to the source tree}"
fleet_dir="$SRC/share/momentum/examples/fleet"
skip() { echo "slurm_test: $1; skipped"; exit 77; }
((EUID == 0)) || skip "not root (the test starts slurmd, which runs tasks as their user)"
for tool in slurmctld slurmd munged mungekey sbatch scontrol sinfo parallel jq python3; do
  command -v "$tool" > /dev/null || skip "$tool not installed (scripts/setup.sh installs it)"
done
SECONDS=0
# The folder must be searchable by everyone: munged refuses a socket in a folder that is not.
tmp=$(mktemp -d /tmp/momentum-slurm.XXXXXX)
chmod 755 "$tmp"
cluster=$tmp/cluster
pids=()
cleanup() {
  local pid
  for pid in "${pids[@]}"; do kill "$pid" 2> /dev/null; done
  for pid in "${pids[@]}"; do wait "$pid" 2> /dev/null; done
  [[ -n ${KEEP:-} ]] || rm -rf "$tmp"
}
trap cleanup EXIT
trap 'exit 143' TERM INT
echo "work: $tmp" >&2
source "$(dirname "$0")/helpers.sh"
fatal() {
  echo "FAILED: $1"
  local f
  for f in "$cluster"/log/*; do
    [[ -f $f ]] && { echo "--- $f"; tail -n 20 "$f"; }
  done
  exit 1
}

# The cluster. munge: a key of its own (munged checks that only its owner reads it) and a socket
# in the temporary folder; Slurm's auth/munge and cred/munge reach it through AuthInfo.
mkdir -p "$cluster"/{munge,run,state,spool,log}
chmod 700 "$cluster/munge"
chmod 755 "$cluster" "$cluster/run"
mungekey --create --keyfile "$cluster/munge/munge.key" 2> "$cluster/log/mungekey.err" ||
  fatal "mungekey could not make a key"
munged --foreground --force --socket "$cluster/run/munge.sock" --key-file "$cluster/munge/munge.key" \
  --pid-file "$cluster/run/munged.pid" --log-file "$cluster/log/munged.log" \
  --seed-file "$cluster/munge/munged.seed" > "$cluster/log/munged.out" 2>&1 &
pids+=($!)
for _ in $(seq 50); do [[ -S $cluster/run/munge.sock ]] && break; sleep 0.1; done
[[ -S $cluster/run/munge.sock ]] || fatal "munged made no socket"
# Two free ports (the kernel's choice), so that the test runs beside a Slurm of the machine.
read -r ctld_port slurmd_port < <(python3 -c '
import socket
s = [socket.socket() for _ in range(2)]
for x in s: x.bind(("127.0.0.1", 0))
print(*[x.getsockname()[1] for x in s])')
node=$(hostname -s)
# No cgroups anywhere: proctrack/linuxproc tracks tasks by parent process, task/none binds
# nothing, no accounting. The node as slurmd itself sees it (slurmd -C), so that it is not
# drained for a configuration that promises more than the machine has.
node_line=$(slurmd -C | grep '^NodeName=') || fatal "slurmd -C describes no node"
export SLURM_CONF=$cluster/slurm.conf
cat > "$SLURM_CONF" <<EOF
ClusterName=momentum-test
SlurmctldHost=$node
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$cluster/run/munge.sock
SlurmUser=root
SlurmdUser=root
StateSaveLocation=$cluster/state
SlurmdSpoolDir=$cluster/spool
SlurmctldPidFile=$cluster/run/slurmctld.pid
SlurmdPidFile=$cluster/run/slurmd.pid
SlurmctldLogFile=$cluster/log/slurmctld.log
SlurmdLogFile=$cluster/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MpiDefault=none
MailProg=/bin/true
SchedulerType=sched/builtin
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
MinJobAge=600
SchedulerParameters=sched_interval=1
$node_line State=UNKNOWN
PartitionName=test Nodes=$node Default=YES MaxTime=INFINITE State=UP
EOF
slurmctld -D -f "$SLURM_CONF" > "$cluster/log/slurmctld.out" 2>&1 &
pids+=($!)
slurmd -D -f "$SLURM_CONF" > "$cluster/log/slurmd.out" 2>&1 &
pids+=($!)
state=""
for _ in $(seq 150); do
  state=$(sinfo -h -n "$node" -o %T 2> /dev/null)
  [[ $state == idle ]] && break
  sleep 0.2
done
[[ $state == idle ]] || fatal "the node is not idle after 30 s (sinfo: ${state:-no answer})"
echo "cluster up in ${SECONDS} s: node $node, slurmctld port $ctld_port, slurmd port $slurmd_port" >&2

# The fleet, laid out in $tmp/pristine and copied to $tmp/fleet before each run, so that both
# runs see the same paths. Commissioned as fleet_test.sh commissions it: thresholds calibrated
# on a log of the paper arm without friction.
day=2024-05-17
pristine=$tmp/pristine fleet=$tmp/fleet
cp "$SRC/share/momentum/robots/paper-arm/paper-arm.json" "$SRC/share/momentum/robots/paper-arm/paper-arm.urdf" "$tmp/"
sim() {  # seed out [options]: in the background, its pid in `sims`
  sim_log "$@" &
  sims+=($!)
}
settle() { wait "${sims[@]}"; sims=(); }  # not `wait`: that would wait for the daemons too
sims=()
mkdir -p "$pristine/robots/arm-"{a,b,c}"/logs/$day"
sim 100 "$tmp/commissioning.csv"
sim 11 "$pristine/robots/arm-b/logs/$day/log-1.csv"
settle
sim 12 "$pristine/robots/arm-b/logs/$day/log-2.csv"
sim 21 "$pristine/robots/arm-c/logs/$day/log-1.csv" --collisions 1 --min-spacing 5
settle
sim 22 "$pristine/robots/arm-c/logs/$day/log-2.csv"
sim 31 "$pristine/robots/arm-a/logs/$day/log-1.csv"
settle
sim 32 "$pristine/robots/arm-a/logs/$day/log-2.csv"
mo-observe -q -p "$tmp/paper-arm.json" "$tmp/commissioning.csv" --output-format bin -o "$tmp/commissioning.bin" &&
  mo-calibrate -q -p "$tmp/paper-arm.json" --margin-percent 30 "$tmp/commissioning.bin" > /dev/null ||
  echo "commissioning failed"
settle
# arm-a's check log: a row that is not numbers, half way through (a broken write).
sed -i '1000s/^[^,]*,/garbage,/' "$pristine/robots/arm-a/logs/$day/log-2.csv"
for r in a b c; do
  cp "$tmp/paper-arm.json" "$pristine/robots/arm-$r/profile.json"
  cp "$tmp/paper-arm.urdf" "$pristine/robots/arm-$r/"
done
echo "fleet made at ${SECONDS} s" >&2
options=(--margin-percent 30 --seed 1)

# GNU parallel, the tested way; its fleet folder is then kept aside as $tmp/fleet.parallel.
cp -a "$pristine" "$fleet"
start=$SECONDS
"$fleet_dir/fleet-recalibrate.sh" -j 2 --day "$day" "$fleet" -- "${options[@]}" \
  > "$tmp/parallel.jsonl" 2> "$tmp/parallel.err"
status=$?
echo "GNU parallel: $((SECONDS - start)) s" >&2
cat "$tmp/parallel.err" >&2
check "fleet-recalibrate.sh exits 1 (arm-a failed)" test $status == 1
mv "$fleet" "$tmp/fleet.parallel"

# Slurm: the example as a site submits it (README.md, Slurm), the array sized to the fleet,
# two tasks at a time. (Not sbatch --wait: it polls at intervals growing to half a minute.)
cp -a "$pristine" "$fleet"
mkdir -p "$tmp/submit"
n=$("$fleet_dir/robot-at-index.sh" --count "$fleet")
check "robot-at-index.sh --count: 3 robots ($n)" test "$n" == 3
start=$SECONDS
job=$(cd "$tmp/submit" && MOMENTUM_FLEET_SCRIPTS=$fleet_dir \
  sbatch --parsable --array=0-$((n - 1))%2 --export=ALL,FLEET=$fleet,DAY=$day \
  "$fleet_dir/slurm-array.sbatch" "${options[@]}" 2> "$tmp/sbatch.err")
cat "$tmp/sbatch.err" >&2
job=${job%%;*}
[[ $job =~ ^[0-9]+$ ]] || fatal "sbatch printed no job id"
while [[ -n $(squeue -h -j "$job" 2> /dev/null) ]]; do
  ((SECONDS - start < 900)) || fatal "the array is not done after 15 minutes"
  sleep 0.5
done
echo "Slurm array: $((SECONDS - start)) s" >&2

# Each task's state and exit code, as Slurm kept them (MinJobAge: 10 minutes).
scontrol -o show job "$job" > "$tmp/tasks.txt" 2>&1
tasks=$(python3 - "$tmp/tasks.txt" <<'PY'
import re, sys
rows = []
for line in open(sys.argv[1]):
    f = dict(re.findall(r"(\w+)=(\S+)", line))
    if "ArrayTaskId" in f:
        rows.append((int(f["ArrayTaskId"]), f["JobState"], f["ExitCode"]))
print(" ".join(f"{i}:{s}:{e}" for i, s, e in sorted(rows)))
PY
)
check "tasks: arm-a failed with exit code 1, arm-b and arm-c completed ($tasks)" \
  test "$tasks" == "0:FAILED:1:0 1:COMPLETED:0:0 2:COMPLETED:0:0"
# Slurm starts a pending task at its next scheduling pass, a second or so after a slot frees, so
# arm-c may start when arm-a's slot freed or, if arm-b ended within that second, when arm-b's
# did: what holds either way is that it waited for one of them (%2) and that arm-a's failure did
# not cancel it (COMPLETED, above).
check "arm-c's task started only once arm-a's or arm-b's had ended (two at a time)" python3 - "$tmp/tasks.txt" <<'PY'
import re, sys
when = {}
for line in open(sys.argv[1]):
    f = dict(re.findall(r"(\w+)=(\S+)", line))
    if "ArrayTaskId" in f:
        when[int(f["ArrayTaskId"])] = (f["StartTime"], f["EndTime"])
assert when[2][0] >= min(when[0][1], when[1][1]), when  # ISO times compare as text
PY
for i in 0 1 2; do
  robot=$("$fleet_dir/robot-at-index.sh" "$i" "$fleet")
  check "task $i's output is $robot's results file" \
    cmp -s "$tmp/submit/momentum-nightly-${job}_$i.out" "$fleet/results/$day/$robot.json"
done
cat "$fleet"/results/$day/*.json > "$tmp/slurm.jsonl"

# The lines and the profiles, Slurm's against GNU parallel's. What differs between two runs of
# the same night is the clock: started, finished, duration_s, the time stamps in names and in the
# profile's provenance (with the night's scratch folder), and so the installed profile's sha256.
check "each robot's line from Slurm equals its line from GNU parallel, the clock aside" \
  python3 - "$tmp/parallel.jsonl" "$tmp/slurm.jsonl" "$tmp/fleet.parallel" "$fleet" <<'PY'
import json, re, sys
parallel, slurm, fleet_parallel, fleet = sys.argv[1:]
# (and the nightly script's scratch folder, mktemp's, named in the profile's provenance)
stamp = re.compile(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d(\.\d+)?Z|\d{8}T\d{6}(\.\d+)?Z|momentum-nightly\.\w{6}")
def clockless(x):
    if isinstance(x, dict):
        return {k: clockless(v) for k, v in x.items()
                if k not in ("started", "finished", "duration_s", "sha256_after", "time")}
    if isinstance(x, list):
        return [clockless(v) for v in x]
    return stamp.sub("TIME", x) if isinstance(x, str) else x
def lines(path):
    rows = [json.loads(l) for l in open(path).read().splitlines()]
    by = {r["robot"]: r for r in rows}
    assert len(by) == len(rows) == 3, [r["robot"] for r in rows]
    return by
a, b = lines(parallel), lines(slurm)
assert sorted(a) == sorted(b) == ["arm-a", "arm-b", "arm-c"], (sorted(a), sorted(b))
outcomes = {k: a[k]["outcome"] for k in sorted(a)}
assert outcomes == {"arm-a": "failed", "arm-b": "installed", "arm-c": "refused"}, outcomes
for robot in sorted(a):
    x, y = clockless(a[robot]), clockless(b[robot])
    for key in sorted(set(x) | set(y)):
        assert x.get(key) == y.get(key), (robot, key, x.get(key), y.get(key))
    # The profile each run left: the installed candidate, or the one in place, byte for byte but
    # for the clock.
    p = [clockless(json.loads(re.sub(r"(?m)^\s*//.*$", "", open(f"{f}/robots/{robot}/profile.json").read())))
         for f in (fleet_parallel, fleet)]
    assert p[0] == p[1], robot
print("equal:", ", ".join(f"{k} {v}" for k, v in outcomes.items()))
PY
reason=$(jq -r .reason "$fleet/results/$day/arm-a.json")
check "arm-a's line says why it failed ($reason)" grep -q "^cannot observe $fleet/robots/arm-a/logs/$day/log-2.csv" <<< "$reason"

echo "slurm_test: ${SECONDS} s in all" >&2
((failures == 0)) || { echo "$failures checks failed"; exit 1; }
echo "all checks passed"
