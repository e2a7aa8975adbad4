#!/usr/bin/env python3
"""Runs every command example of a man page (man/*.scd) or of the README, on data it makes.

usage: run_examples.py --bin BIN --source SRC --data DATA PAGE

Every literal block (```) is a command example and is run, unless the line before it (blank
lines aside) says otherwise, in a form the reader does not see (an scdoc comment, an HTML
comment in Markdown):

    ; test: not run: REASON                 (<!-- test: not run: REASON -->)
        sample output, a file format, or a command that cannot run offline (a CAN interface,
        an installation, minutes of work): the reason says which
    ; test: with "OLD" as "NEW": REASON     (<!-- test: with "OLD" as "NEW": REASON -->)
        run with OLD replaced by NEW (a long simulation shortened); the rest as written

A block whose lines start with `$ ` is a terminal session: only those lines are run. The blocks
of a page run in order, each in its own bash, in one scratch folder, with the built tools first
on PATH and the variables that earlier blocks of the page set (lines `NAME=...`). The installed
data folder /usr/local/share/momentum is the source tree's share/momentum.

Before the first block the scratch folder gets the files the page's examples name and no
earlier example writes (FIXTURES below: a calibrated profile arm.json, logs made by mo-sim,
their residuals and events, a DBC and its captures, vendor exports...), made with the built
tools. A page whose examples use six joints (mo-cat, mo-model, mo-observe) gets a UR5 as
arm.json, the others the paper's 3-joint arm.

A block that needs a program the machine lacks (jq; gnuplot for mo-plot) is not run, and says
so. A block fails when bash exits with a status other than 0 (1 is allowed when its last command
is mo-detect: a collision), or standard error has an error: `tool: error:`, `command not
found`, `No such file or directory`, a Python traceback. Each block's time is printed.
"""
import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

SIX_JOINT_PAGES = {"mo-cat.1", "mo-model.1", "mo-observe.1"}
# Programs from outside the suite that some examples need (scripts/setup.sh installs them): a
# block that names one that is missing is not run, and says so.
NEEDS = {"jq": "jq", "mo-plot": "gnuplot", "stdbuf": "stdbuf"}
ERRORS = re.compile(r"^[\w.-]+: error:|command not found|No such file or directory|^Traceback", re.M)
MARK = re.compile(r'^(?:;|<!--)\s*test:\s*(?:(not run):\s*(.*?)|with "(.*)" as "(.*)":\s*(.*?))\s*(?:-->)?$')


def blocks(path):
    """(line, text, mark) of each literal block; mark: None, ("not run", reason), ("with", old, new).
    In a man page's source a backslash is written doubled (scdoc's escape): it is run as the
    reader sees it, single."""
    out, literal, body, start, mark, last = [], False, [], 0, None, None
    unescape = path.endswith(".scd")
    for number, line in enumerate(open(path, encoding="utf-8").read().split("\n"), 1):
        if line.strip().startswith("```"):
            if literal:
                out.append((start, "\n".join(body), mark))
            else:
                body, start = [], number
                m = MARK.match(last or "")
                mark = None if not m else ("not run", m.group(2)) if m.group(1) else ("with", m.group(3), m.group(4))
            literal = not literal
            continue
        if literal:
            body.append(line.replace("\\\\", "\\") if unescape else line)
        elif line.strip():
            last = line.strip()
    return out


def run(command, cwd, env, what):
    result = subprocess.run(command, cwd=cwd, env=env, shell=True, executable="/bin/bash",
                            capture_output=True, text=True)
    if result.returncode != 0 or ERRORS.search(result.stderr):
        sys.exit(f"run_examples: fixture {what} failed ({result.returncode}):\n{command}\n{result.stderr}")


class Fixture:
    """Makes the files examples name, on demand, in `work`."""

    def __init__(self, work, source, data, page, env):
        self.work, self.source, self.data, self.env, self.page = work, source, data, env, page
        six_joints = page in SIX_JOINT_PAGES
        self.thresholds = True  # whether arm.json needs calibrated thresholds (a page that detects)
        self.calibrated = False
        self.six = six_joints
        self.made = set()

    def sh(self, command, what):
        run(command, self.work, self.env, what)

    def path(self, name):
        return os.path.join(self.work, name)

    def need(self, name):
        if name in self.made:
            return
        self.made.add(name)
        getattr(self, "make_" + FILES[name])()

    # ---- the robot -------------------------------------------------------------------------
    def make_arm_json(self):
        # A profile with its URDF beside it, its friction, and for a page that detects thresholds
        # calibrated on 20 s of free motion.
        if self.six:
            shutil.copy(os.path.join(self.data, "ur5-sim.json"), self.path("arm.json"))
            shutil.copy(os.path.join(self.data, "ur5_robot.urdf"), self.work)
        else:
            robot = os.path.join(self.source, "share", "momentum", "robots", "paper-arm")
            shutil.copy(os.path.join(robot, "paper-arm.json"), self.path("arm.json"))
            shutil.copy(os.path.join(robot, "paper-arm.urdf"), self.work)
        # The friction a mo-lugre-fit run would have written: here the simulated arm's own.
        profile = json.loads(re.sub(r"(?m)^\s*//.*$", "", open(self.path("arm.json")).read()))
        profile["friction"] = profile["simulation"]["friction"]
        json.dump(profile, open(self.path("arm.json"), "w"), indent=1)
        if self.thresholds:
            self.calibrate()

    def calibrate(self):
        if self.calibrated:
            return
        self.calibrated = True
        self.sh("mo-sim -q -p arm.json --seed 1 --duration 20 --output-format bin > .free.bin && "
                "mo-observe -q -p arm.json .free.bin > .free.obs.bin && "
                "mo-calibrate -q -p arm.json .free.obs.bin > /dev/null", "arm.json")

    def make_ur5_json(self):
        shutil.copy(os.path.join(self.data, "ur5.json"), self.path("ur5.json"))
        shutil.copy(os.path.join(self.data, "ur5_robot.urdf"), self.work)

    def make_true_json(self):
        # mo-dynfit's page: a vendor's profile (arm.json) and the arm as it really is.
        example = os.path.join(self.source, "share", "momentum", "examples", "wrong-urdf")
        for name in ("true.json", "true-arm.urdf", "nominal-arm.urdf"):
            shutil.copy(os.path.join(example, name), self.work)
        shutil.copy(os.path.join(example, "nominal.json"), self.path("arm.json"))
        self.made.add("arm.json")

    # ---- logs ------------------------------------------------------------------------------
    def make_log_csv(self):
        self.need("arm.json")
        self.sh("mo-sim -q -p arm.json --seed 2 --duration 8 --rate 500 --collisions 3 --truth truth.csv "
                "-o log.csv && mo-cat log.csv --output-format bin > log.bin", "log.csv")
        self.made.update({"log.bin", "truth.csv"})
        if self.page == "mo-model.1":
            self.add_torques("log.csv")

    def add_torques(self, name):
        """A drive's log as mo-model's page reads it: with the motor torque k_i i and the
        acceleration, differentiated from dq (central differences)."""
        k_i = [j["k_i"] for j in json.loads(re.sub(r"(?m)^\s*//.*$", "", open(self.path("arm.json")).read()))["joints"]]
        lines = open(self.path(name)).read().split("\n")
        comments = [l for l in lines if l.startswith("#")]
        rows = [l.split(",") for l in lines if l and not l.startswith("#")]
        header, data = rows[0], [list(map(float, r)) for r in rows[1:]]
        n = len(k_i)
        t, dq = header.index("t"), [header.index(f"dq{j}") for j in range(1, n + 1)]
        i = [header.index(f"i{j}") for j in range(1, n + 1)]
        out = comments + [",".join(header + [f"ddq{j}" for j in range(1, n + 1)] + [f"tau_m{j}" for j in range(1, n + 1)])]
        for k, row in enumerate(data):
            a, b = data[max(k - 1, 0)], data[min(k + 1, len(data) - 1)]
            ddq = [(b[c] - a[c]) / (b[t] - a[t]) for c in dq]
            out.append(",".join(map(repr, row + ddq + [k_i[j] * row[i[j]] for j in range(n)])))
        open(self.path(name), "w").write("\n".join(out) + "\n")

    make_log_bin = make_truth_csv = make_log_csv

    def make_observed_csv(self):
        self.need("log.csv")
        self.sh("mo-observe -q -p arm.json log.csv > observed.csv && "
                "mo-cat observed.csv --output-format bin > observed.bin", "observed.csv")
        self.made.add("observed.bin")

    make_observed_bin = make_observed_csv

    def make_events_csv(self):
        self.need("observed.csv")
        self.calibrate()
        self.sh("mo-detect -q -p arm.json observed.csv > events.csv; [ $? -le 1 ]", "events.csv")

    def free(self, name, seed, observed):
        self.need("arm.json")
        self.sh(f"mo-sim -q -p arm.json --seed {seed} --duration 6 --output-format bin" +
                (" | mo-observe -q -p arm.json" if observed else "") + f" > {name}", name)

    def make_day_bin(self): self.free("day.bin", 3, True)
    def make_day1_bin(self): self.free("day1.bin", 4, True)
    def make_day2_bin(self): self.free("day2.bin", 5, True)
    def make_part1_bin(self):
        # Two parts of one day's residuals, cut where every joint moves (a part that began in a
        # reversal could not know that its joint had just been slow), after the start from rest.
        self.need("arm.json")
        self.sh("mo-sim -q -p arm.json --seed 6 --duration 25 | mo-observe -q -p arm.json > .day.csv", "part1.bin")
        lines = [l for l in open(self.path(".day.csv"))]
        head = [l for l in lines if l.startswith("#")]
        rows = [l for l in lines if not l.startswith("#")]
        header = rows[0].strip().split(",")
        dq = [k for k, name in enumerate(header) if name.startswith("dq")]
        values = [list(map(float, r.split(","))) for r in rows[1:]]

        def moving_from(t0):
            run = 0
            for k, v in enumerate(values):
                run = run + 1 if v[0] >= t0 and all(abs(v[c]) > 0.05 for c in dq) else 0
                if run == 200:
                    return k
            sys.exit("run_examples: fixture part1.bin: no stretch where every joint moves")

        a, b = moving_from(3), moving_from(values[-1][0] / 2)
        for name, part in (("part1", rows[1 + a:1 + b]), ("part2", rows[1 + b:])):
            open(self.path(f".{name}.csv"), "w").write("".join(head + [rows[0]] + part))
            self.sh(f"mo-cat .{name}.csv --output-format bin > {name}.bin", name)
        self.made.add("part2.bin")

    make_part2_bin = make_part1_bin
    def make_hour_bin(self): self.free("hour.bin", 8, False)

    def make_arm_csv(self):
        # A six-joint arm's log as mo-cat's page uses it, and its binary twin.
        self.need("arm.json")
        self.sh("mo-sim -q -p arm.json --seed 9 --duration 4 --rate 125 -o arm.csv && "
                "mo-cat arm.csv --output-format bin > arm.bin", "arm.csv")
        self.made.add("arm.bin")

    make_arm_bin = make_arm_csv

    def vendor_export(self, name, joints, scales, extra):
        """A controller's headerless export of a simulated log: ms, degrees, drive units."""
        self.need("arm.json")
        self.sh(f"mo-sim -q -p arm.json --seed 10 --duration 4 --rate 125 -o .vendor.csv", name)
        rows = [l for l in open(self.path(".vendor.csv")) if not l.startswith("#")]
        header = rows[0].strip().split(",")
        with open(self.path(name), "w") as out:
            for line in rows[1:]:
                row = dict(zip(header, map(float, line.split(","))))
                fields = [row["t"] * 1000]
                for family, scale in scales:
                    fields += [row[f"{family}{j}"] / scale(j) for j in range(1, joints + 1)]
                out.write(",".join("%.6f" % v for v in fields + extra) + "\n")

    def make_export_csv(self):
        deg = 0.0174532925199433
        self.vendor_export("export.csv", 6, [("q", lambda j: deg), ("i", lambda j: -0.002 if j == 1 else 0.002)], [])

    def make_controller_export_csv(self):
        deg = 0.0174532925199433
        self.vendor_export("controller-export.csv", 3,
                           [("q", lambda j: deg), ("dq", lambda j: deg), ("i", lambda j: -0.005 if j == 2 else 0.005)],
                           [0.0])

    # ---- CAN -------------------------------------------------------------------------------
    def make_arm_dbc(self):
        shutil.copy(os.path.join(self.source, "share", "momentum", "robots", "paper-arm", "paper-arm.dbc"),
                    self.path("arm.dbc"))

    def make_run_log(self):
        # candump -L of the paper arm's bus, as `candump -L can0 > run.log` records it.
        self.need("arm.json")
        self.need("arm.dbc")
        self.sh("mo-sim -q -p arm.json --seed 11 --duration 2 --rate 125 --candump --dbc arm.dbc > run.log",
                "run.log")

    def make_arm_map(self):
        # Every signal of the DBC by its message, as a map file names them.
        self.need("arm.dbc")
        lines, message = ["# column = Message.Signal"], None
        for line in open(self.path("arm.dbc")):
            if line.startswith("BO_ "):
                message = line.split()[2].rstrip(":")
            elif line.startswith(" SG_ "):
                signal = line.split()[1]
                lines.append(f"{signal} = {message}.{signal}")
        open(self.path("arm.map"), "w").write("\n".join(lines) + "\n")

    def make_drive_test_asc(self):
        # The same bus in Vector ASC, captured on channel 1.
        self.need("run.log")
        out = ["date Tue Nov 14 10:13:20.000 pm 2023", "base hex  timestamps absolute", "internal events logged",
               "Begin Triggerblock Tue Nov 14 10:13:20.000 pm 2023", "   0.000000 Start of measurement"]
        t0 = None
        for line in open(self.path("run.log")):
            m = re.match(r"\((\S+)\) \S+ ([0-9A-F]+)#([0-9A-F]*)$", line.strip())
            if not m:
                continue
            t, ident, data = float(m.group(1)), m.group(2), m.group(3)
            t0 = t if t0 is None else t0
            payload = " ".join(data[k:k + 2] for k in range(0, len(data), 2))
            out.append(f"{t - t0:11.6f} 1  {int(ident, 16):X}             Rx   d {len(data) // 2} {payload}".rstrip())
        out.append("End TriggerBlock")
        open(self.path("drive-test.asc"), "w").write("\n".join(out) + "\n")

    # ---- other things examples name ----------------------------------------------------------
    def make_stop_arm(self):
        # The site's own commands that README's hooks call.
        os.makedirs(self.path("bin"), exist_ok=True)
        for name in ("stop-arm", "comply"):
            script = self.path(os.path.join("bin", name))
            open(script, "w").write(f"#!/bin/sh\necho {name}: event $MOMENTUM_EVENT >&2\n")
            os.chmod(script, 0o755)
        self.made.add("comply")

    make_comply = make_stop_arm

    # ---- other robots' data -------------------------------------------------------------------
    def make_run_mcap(self):
        # A ROS 2 bag of the paper arm (tests/data/mcap, written by the MCAP project's own
        # writer; its joints shuffled in each message), where the examples expect rosbag2's.
        os.makedirs(self.path("run"), exist_ok=True)
        shutil.copy(os.path.join(self.data, "mcap", "zstd.mcap"), self.path("run/run_0.mcap"))

    def make_ur10e_json(self):
        real = os.path.join(self.data, "real-ur10e")
        shutil.copy(os.path.join(real, "profile.json"), self.path("ur10e.json"))
        shutil.copy(os.path.join(real, "ur10e.urdf"), self.work)

    def make_robot_data_csv(self):
        # The real UR10e's collision-free log as UR's RTDE client records it.
        self.need("ur10e.json")
        real = os.path.join(self.data, "real-ur10e")
        self.sh(f"python3 {os.path.join(self.data, 'rtde', 'make_rtde_recording.py')} "
                f"{os.path.join(real, 'logs', 'no_torque.csv')} ur10e.json > robot_data.csv", "robot_data.csv")

    def make_share(self):
        os.symlink(os.path.join(self.source, "share"), self.path("share"))

    def make_tests(self):
        os.symlink(os.path.join(self.source, "tests"), self.path("tests"))


# The file each fixture method makes, as examples name it ("dir/": a folder of the source tree).
FILES = {"true.json": "true_json", "arm.json": "arm_json", "ur5.json": "ur5_json", "log.csv": "log_csv",
         "log.bin": "log_bin", "truth.csv": "truth_csv", "observed.csv": "observed_csv",
         "observed.bin": "observed_bin", "events.csv": "events_csv", "day.bin": "day_bin", "day1.bin": "day1_bin",
         "day2.bin": "day2_bin", "part1.bin": "part1_bin", "part2.bin": "part2_bin", "hour.bin": "hour_bin",
         "arm.csv": "arm_csv", "arm.bin": "arm_bin", "export.csv": "export_csv",
         "controller-export.csv": "controller_export_csv", "arm.dbc": "arm_dbc", "run.log": "run_log",
         "arm.map": "arm_map", "drive-test.asc": "drive_test_asc", "stop-arm": "stop_arm", "comply": "comply",
         "run/run_0.mcap": "run_mcap", "ur10e.json": "ur10e_json", "robot_data.csv": "robot_data_csv",
         "share/": "share", "tests/": "tests"}


def named(text):
    """The fixture files a block's text names: (name, where it is first named)."""
    found = []
    for name in FILES:
        pattern = r"(?<![\w/.$-])" + re.escape(name) + (r"(?![\w.-])" if not name.endswith("/") else "")
        m = re.search(pattern, text)
        if m:
            found.append((name, m.end()))
    return found


def written(name, text):
    """Whether a block's text writes `name` (> name, -o name, mo-sim's --truth name)."""
    n = re.escape(name)
    return bool(re.search(rf"(>|-o)\s*{n}(?![\w.-])", text) or re.search(rf"mo-sim.*--truth\s+{n}(?![\w.-])", text))


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--bin", required=True)
    parser.add_argument("--source", required=True)
    parser.add_argument("--data", required=True)
    parser.add_argument("--keep", action="store_true", help="keep the scratch folder")
    parser.add_argument("page")
    args = parser.parse_args()
    page = os.path.basename(args.page)
    page_name = re.sub(r"\.(scd|md)$", "", page)
    work = tempfile.mkdtemp(prefix="momentum-examples-")
    env = dict(os.environ)
    env["PATH"] = os.pathsep.join([os.path.abspath(args.bin), os.path.join(work, "bin"), env.get("PATH", "")])
    env["LC_ALL"] = "C"
    env["TMPDIR"] = os.path.join(work, "tmp")  # an example's mktemp stays in the scratch folder
    os.makedirs(env["TMPDIR"])
    fixture = Fixture(work, os.path.abspath(args.source), os.path.abspath(args.data), page_name, env)
    installed = "/usr/local/share/momentum"
    failures, ran, skipped, earlier, variables = [], 0, 0, [], []
    page_blocks = blocks(args.page)
    fixture.thresholds = any(re.search(r"mo-detect|mo-plot|--classes", text)
                             for _, text, mark in page_blocks if not (mark and mark[0] == "not run"))
    try:
        for line, text, mark in page_blocks:
            where = f"{page}:{line}"
            if mark and mark[0] == "not run":
                print(f"{where}: not run: {mark[1]}")
                skipped += 1
                continue
            if not mark and not text.strip():
                continue
            script = text
            if any(l.startswith("$ ") for l in text.split("\n")):
                script = "\n".join(l[2:] for l in text.split("\n") if l.startswith("$ "))
            if mark:
                if mark[1] not in script:
                    failures.append(f'{where}: the test mark replaces "{mark[1]}", which the example does not hold')
                    continue
                script = script.replace(mark[1], mark[2])
            script = script.replace(installed, os.path.join(os.path.abspath(args.source), "share", "momentum"))
            missing = [program for word, program in NEEDS.items()
                       if re.search(rf"(^|[|;&(\s]){re.escape(word)}\s", script) and not shutil.which(program)]
            if missing:
                print(f"{where}: not run: {', '.join(missing)} not installed")
                skipped += 1
                continue
            for name, end in named(script):
                # Not what an earlier example, or this one before naming it again, writes.
                if not any(written(name, e) for e in earlier + [script[:end]]):
                    fixture.need(name)
            full = "\n".join(variables + [script])
            start = time.perf_counter()
            result = subprocess.run(full, cwd=work, env=env, shell=True, executable="/bin/bash",
                                    stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, errors="replace",
                                    timeout=300)
            seconds = time.perf_counter() - start
            # The last command of the block: after the last pipe of its last logical line.
            logical = re.split(r"(?<!\\)\n(?!\s)", script.strip())[-1]
            last_tool = logical.split("|")[-1].strip().split()[0] if logical.strip() else ""
            allowed = {0, 1} if last_tool == "mo-detect" else {0}
            error = ERRORS.search(result.stderr)
            status = "ok" if result.returncode in allowed and not error else "FAILED"
            print(f"{where}: {status} in {seconds:.2f} s (status {result.returncode})")
            if status != "ok":
                failures.append(f"{where}: status {result.returncode}"
                                f"{', error on standard error' if error else ''}:\n{script}\n"
                                f"---- stderr ----\n{result.stderr[-3000:]}")
            ran += 1
            earlier.append(script)
            variables += [l for l in script.split("\n") if re.match(r"^[A-Z]\w*=", l)]
    finally:
        if args.keep:
            print(f"scratch folder kept: {work}")
        else:
            shutil.rmtree(work, ignore_errors=True)
    for f in failures:
        print(f)
    print(f"{page}: {ran} examples run, {skipped} not run, {len(failures)} failed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
