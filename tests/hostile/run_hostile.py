#!/usr/bin/env python3
"""Hostile-input test (issue 26): every class of the second hostile round against every tool.

The tools are the build's (--tools, from CMake's MOMENTUM_TOOLS, checked against the mo-*
programs in --bin), so a new tool meets these cases on the day it is added: it needs a line in
RECIPES (how to run it on a small input) or the test fails, and its options are read from its
--help, so a new option meets the absurd values too.

Classes, each run against every tool it applies to:
  crash      an output path that cannot be opened (a missing folder, a folder, a symlink loop),
             a truncated binary record, a byte order mark, a line of 2 MiB, a profile nested
             30,000 deep
  hang       standard input closed; every run of every class has a time limit
  blind      a span of NaN in the signals and a clock that steps back: a tool that judges the
             signals says so on standard error, naming the file; mo-detect still finds a
             collision after the step
  data loss  the output is one of the inputs
  injection  a line break in free-text options and output names (gnuplot), in a binary
             stream's comments and column names (CSV)
  resource   absurd values of every option that takes a number or a range

Properties of every run: no death by a signal and no sanitizer report, no run past the time
limit nor above the memory limit, an exit status in the tool's documented set (its man page's
EXIT STATUS), on an error a message naming the hostile file or path, and no input file changed.

PENDING lists the cases that fail today only because of a defect of issue 26 that is being
fixed on another branch: they are run, reported as skipped with the defect's short name, and
must fail (a pending case that passes is reported, so the table is emptied as the fixes land).
Exit status 0 when every other case passes.
"""
import argparse
import concurrent.futures
import hashlib
import os
import re
import shutil
import signal
import struct
import subprocess
import sys
import tempfile
import time

# Cases that fail only because of a defect of issue 26 fixed on another branch (tool, case) ->
# the defect's short name. The coordinator empties this table after merging those branches.
PENDING = {
    # Empty since the branches that fixed issue 26's defects merged (output open crash, same-file
    # refusal, column ranges, option overflow, CSV and gnuplot injection, JSON depth, mo-detect's
    # closed stdin and NaN span): a defect found later and fixed elsewhere waits here.
}

# Failures found by this test that are not in issue 26's list, reported to the coordinator and
# not fixed here (each outside this branch's files): run and reported as skipped like PENDING.
NEW_FINDINGS = {
}

# How to run each tool on a small input. {profile}, {log} (t, q, dq, i), {residual} (mo-observe
# output), {capture} and {dbc} (candump text), {truth} and {events} (mo-eval), {out} (an output
# file). `stream`: the placeholder of the stream input the stream cases replace; `stdin`: of
# another input the tool reads from standard input when it is left out; `output`: the
# output option; `judges`: the tool judges the signals (blind cases apply); `ok`: the exit
# statuses of success, the other documented ones are errors.
RECIPES = {
    "mo-cat": dict(argv=["{log}", "-o", "{out}"], stream="{log}", output="-o"),
    "mo-observe": dict(argv=["-p", "{profile}", "{log}", "-o", "{out}"], stream="{log}", output="-o", judges=True),
    "mo-detect": dict(argv=["-p", "{profile}", "--threshold", "30", "{residual}", "-o", "{out}"], stream="{residual}",
                      output="-o", judges=True, ok=(0, 1)),
    "mo-detect --pass": dict(argv=["--pass", "--threshold", "30", "{residual}", "-o", "{out}"], stream="{residual}",
                             output="-o", ok=(0, 1)),
    "mo-model": dict(argv=["-p", "{profile}", "{log}", "-o", "{out}"], stream="{log}", output="-o"),
    "mo-sim": dict(argv=["-q", "-p", "{profile}", "--duration", "0.5", "--blend", "0.1", "--rate", "100", "--seed", "1", "-o", "{out}"],
                   output="-o"),
    "mo-can2csv": dict(argv=["--dbc", "{dbc}", "{capture}", "-o", "{out}"], output="-o", stdin="{capture}"),
    "mo-calibrate": dict(argv=["-p", "{profile}", "--signal", "r", "--rest-time", "0.1", "{residual}", "-o", "{out}"],
                         stream="{residual}", output="-o", judges=True),
    "mo-friction-fit": dict(argv=["-p", "{profile}", "--population", "8", "--generations", "3", "--restarts", "1",
                              "--no-polish", "{residual}", "-o", "{out}"], stream="{residual}", output="-o",
                         judges=True),
    "mo-dynfit": dict(argv=["-p", "{profile}", "--force", "{log}", "-o", "{out}"], stream="{log}", output="-o", judges=True),
    "mo-eval": dict(argv=["--truth", "{truth}", "{events}"], stdin="{events}"),
    "mo-plot": dict(argv=["-o", "{out_png}", "{residual}"], stream="{residual}", output="-o"),
}

SANITIZER = re.compile(r"AddressSanitizer|LeakSanitizer|UndefinedBehaviorSanitizer|runtime error:|"
                       r"MemorySanitizer|ThreadSanitizer")


class Result:
    def __init__(self, status, signal_number, stdout, stderr, seconds, max_rss_mb, timed_out):
        self.status = status
        self.signal = signal_number
        self.stdout = stdout
        self.stderr = stderr
        self.seconds = seconds
        self.max_rss_mb = max_rss_mb
        self.timed_out = timed_out


def run(argv, cwd, limit, stdin_bytes=None, close_stdin=False, env=None):
    """Runs argv in its own process group; kills the group at the time limit."""
    read_fd = None
    if close_stdin:
        stdin = None
    elif stdin_bytes is not None:
        stdin = tempfile.TemporaryFile()
        stdin.write(stdin_bytes)
        stdin.seek(0)
    else:
        stdin = subprocess.DEVNULL

    def prepare():
        os.setsid()
        if close_stdin:
            os.close(0)

    out = tempfile.TemporaryFile()
    err = tempfile.TemporaryFile()
    start = time.monotonic()
    process = subprocess.Popen(argv, cwd=cwd, stdin=stdin, stdout=out, stderr=err, preexec_fn=prepare, env=env)
    timed_out = False
    rusage = None
    while True:
        pid, status, rusage = os.wait4(process.pid, os.WNOHANG)
        if pid:
            break
        if time.monotonic() - start > limit:
            timed_out = True
            try:
                os.killpg(process.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            pid, status, rusage = os.wait4(process.pid, 0)
            break
        time.sleep(0.01)
    process.returncode = 0  # reaped above
    seconds = time.monotonic() - start
    out.seek(0)
    err.seek(0)
    code = os.waitstatus_to_exitcode(status)
    del read_fd
    return Result(code if code >= 0 else None, -code if code < 0 else None, out.read(), err.read().decode(
        "utf-8", "replace"), seconds, rusage.ru_maxrss / 1024.0, timed_out)


def documented_statuses(man_page):
    """The exit statuses a tool's man page documents in EXIT STATUS."""
    text = open(man_page, encoding="utf-8").read()
    m = re.search(r"^# EXIT STATUS\n(.*?)(?=^# )", text, re.S | re.M)
    if not m:
        raise SystemExit(f"hostile: {man_page}: no EXIT STATUS section")
    section = m.group(1)
    found = {int(n) for n in re.findall(r"^\*(\d+)\*", section, re.M)}
    found |= {int(n) for n in re.findall(r"(?<![\w.*-])(\d{1,3}) (?:on|when|for|if)\b", section)}
    if not found:
        raise SystemExit(f"hostile: {man_page}: no exit status found in EXIT STATUS")
    return found


def options_of(help_text):
    """The options of a --help that take a value: (name, placeholder, choices)."""
    options = []
    for line in help_text.splitlines():
        m = re.match(r"^\s+(?:-\w,)?(--[\w-]+)(?:,-\w)?\s+(\S+)", line)
        if not m or m.group(2).startswith(("Print", "Display")):
            continue
        placeholder = m.group(2)
        if not re.match(r"^[A-Z][A-Z0-9_/]*(\|\w+)?([:=].*)?$", placeholder):
            continue  # a flag: the word after it is its description
        kind = re.split(r"[:=|]", placeholder)[0]
        rest = placeholder.partition(":")[2]
        choices = re.findall(r"[^{},=]+", rest.split("}")[0]) if rest.startswith("{") else None
        options.append((m.group(1), kind, choices))
    return options


# --- fixtures ---------------------------------------------------------------------------------

def write_binary(path, columns, rows, comments=(), stream_comments=()):
    """A binary stream (mo-log(5)), written here independently of the tools."""
    out = bytearray(b"\x89MOLOG\r\n")
    out += struct.pack("<III", 1, len(columns), len(comments))
    for s in list(comments) + list(columns):
        b = s.encode()
        out += struct.pack("<I", len(b)) + b
    for n, row in enumerate(rows):
        out += struct.pack("<%dd" % len(row), *row)
        if n == 1:
            for note in stream_comments:
                b = note.encode()
                out += struct.pack("<QQ", 0x7FF84D4F434D4E54, len(b)) + b + b"\0" * (-len(b) % 8)
    open(path, "wb").write(bytes(out))


def read_csv(path):
    lines = [l for l in open(path, encoding="utf-8").read().splitlines() if l and not l.startswith("#")]
    columns = lines[0].split(",")
    rows = [[float(v) for v in l.split(",")] for l in lines[1:]]
    return columns, rows


def write_csv(path, columns, rows, prefix=b""):
    text = ",".join(columns) + "\n" + "".join(",".join(repr(v) for v in row) + "\n" for row in rows)
    open(path, "wb").write(prefix + text.encode())


class Fixture:
    def __init__(self, args, work):
        self.args = args
        self.work = work
        self.inputs = os.path.join(work, "inputs")
        os.makedirs(self.inputs)
        src = args.source
        robot = os.path.join(src, "share", "momentum", "robots", "paper-arm")
        for name in os.listdir(robot):
            shutil.copy(os.path.join(robot, name), self.inputs)
        self.files = {
            "{profile}": os.path.join(self.inputs, "paper-arm.json"),
            "{dbc}": os.path.join(self.inputs, "paper-arm.dbc"),
        }
        self.tool_env = dict(os.environ)
        self.tool_env["PATH"] = args.bin + os.pathsep + self.tool_env.get("PATH", "")
        # A short simulated log with one collision, its residuals, its capture, truth and events.
        log = os.path.join(self.inputs, "log.csv")
        self.must([self.tool("mo-sim"), "-q", "-p", self.files["{profile}"], "--duration", "4", "--rate", "200",
                   "--seed", "1", "--collisions", "1", "--truth", os.path.join(self.inputs, "truth.csv"), "-o", log])
        residual = os.path.join(self.inputs, "residual.csv")
        self.must([self.tool("mo-observe"), "-q", "-p", self.files["{profile}"], log, "-o", residual])
        events = os.path.join(self.inputs, "events.csv")
        r = run([self.tool("mo-detect"), "-q", "--threshold", "30", residual, "-o", events], self.work,
                self.args.limit, env=self.tool_env)
        if r.status not in (0, 1):
            raise SystemExit(f"hostile: set-up: mo-detect failed: {r.stderr}")
        capture = os.path.join(self.inputs, "capture.log")
        r = run([self.tool("mo-sim"), "-q", "-p", self.files["{profile}"], "--duration", "0.5", "--blend", "0.1",
                 "--rate", "100", "--seed", "1", "--candump", "--dbc", self.files["{dbc}"]], self.work, self.args.limit,
                env=self.tool_env)
        if r.status != 0:
            raise SystemExit(f"hostile: set-up: mo-sim --candump failed: {r.stderr}")
        open(capture, "wb").write(r.stdout)
        self.files.update({"{log}": log, "{residual}": residual, "{capture}": capture,
                           "{truth}": os.path.join(self.inputs, "truth.csv"), "{events}": events})
        self.log_columns, self.log_rows = read_csv(log)
        self.res_columns, self.res_rows = read_csv(residual)
        self.derived = {}

    def tool(self, name):
        return os.path.join(self.args.bin, name)

    def must(self, argv):
        r = run(argv, self.work, self.args.limit, env=self.tool_env)
        if r.status != 0:
            raise SystemExit(f"hostile: set-up: {' '.join(argv)}: status {r.status}: {r.stderr}")

    def profile_variant(self, kind):
        """A hostile copy of the profile, beside it (its URDF is found the same way): its path."""
        key = ("{profile}", kind)
        if key not in self.derived:
            text = open(self.files["{profile}"], "rb").read()
            path = os.path.join(self.inputs, f"profile-{kind}.json")
            if kind == "bom":
                text = b"\xef\xbb\xbf" + text
            else:
                brace = text.rindex(b"}")
                text = text[:brace] + b',\n  "x_deep": ' + b"[" * 30000 + b"]" * 30000 + b"\n}\n"
            open(path, "wb").write(text)
            self.derived[key] = path
        return self.derived[key]

    def variant(self, placeholder, kind):
        """A hostile copy of a stream input, made once: its path."""
        key = (placeholder, kind)
        if key in self.derived:
            return self.derived[key]
        if placeholder == "{log}":
            columns, rows = self.log_columns, self.log_rows
        else:
            columns, rows = self.res_columns, self.res_rows
        base = os.path.basename(self.files[placeholder]).split(".")[0]
        path = os.path.join(self.inputs, f"{base}-{kind}")
        if kind == "truncated.bin":
            write_binary(path, columns, rows)
            size = os.path.getsize(path)
            with open(path, "r+b") as f:
                f.truncate(size - 8 * len(columns) // 2 - 3)
        elif kind == "bom.csv":
            write_csv(path, columns, rows, prefix=b"\xef\xbb\xbf")
        elif kind == "huge-line.csv":
            text = open(self.files[placeholder], "rb").read().split(b"\n")
            text.insert(len(text) // 2, b"1," * (1 << 20))
            open(path, "wb").write(b"\n".join(text))
        elif kind == "nan-span.csv":
            t = columns.index("t")
            half = len(rows) // 2
            nan_rows = [[v if k == t or n < half else float("nan") for k, v in enumerate(row)]
                        for n, row in enumerate(rows)]
            write_csv(path, columns, nan_rows)
        elif kind == "clock-step.csv":
            # The log, then the log again from its start: a second log appended to a first.
            write_csv(path, columns, rows + rows)
        elif kind == "injection.bin":
            write_binary(path, columns, rows, comments=["header note\n666,666", "t"],
                         stream_comments=["a note\n666,666,666"])
        else:
            raise ValueError(kind)
        self.derived[key] = path
        return path


# --- cases ------------------------------------------------------------------------------------

class Case:
    def __init__(self, tool, name, argv, hostile=None, expect_error=False, check=None, close_stdin=False,
                 stdin_bytes=None):
        self.tool = tool          # the recipe's name ("mo-detect --pass")
        self.name = name          # "crash/output-is-folder"
        self.argv = argv
        self.hostile = hostile    # the hostile path an error message must name
        self.expect_error = expect_error
        self.check = check        # extra property: f(result) -> problem or None
        self.close_stdin = close_stdin
        self.stdin_bytes = stdin_bytes


def substitute(argv, files, out):
    result = []
    for a in argv:
        for key, value in files.items():
            a = a.replace(key, value)
        a = a.replace("{out_png}", out + ".png").replace("{out}", out)
        result.append(a)
    return result


def cases_for(fixture, recipe_name, recipe, help_text, counter):
    """Every hostile case for one tool."""
    tool = recipe_name.split()[0]
    exe = fixture.tool(tool)
    work = fixture.work

    def out_path():
        counter[0] += 1
        return os.path.join(work, "out", f"{counter[0]}")

    def argv(files=None, extra=(), replace_output=None):
        f = dict(fixture.files)
        f.update(files or {})
        args = substitute(recipe["argv"], f, out_path())
        if replace_output is not None and recipe.get("output"):
            i = args.index(recipe["output"])
            args[i + 1] = replace_output
        extra = list(extra)
        if len(extra) == 2 and extra[0] in args:  # an option the recipe gives: its value replaced
            args[args.index(extra[0]) + 1] = extra[1]
            extra = []
        return [exe] + args + extra

    cases = []
    clean_status = {}
    # crash: outputs that cannot be opened
    if recipe.get("output"):
        missing = os.path.join(work, "no-such-folder", "out.csv")
        folder = os.path.join(work, "a-folder")
        loop = os.path.join(work, "loop-a")
        for name, path in (("output-missing-folder", missing), ("output-is-folder", folder),
                           ("output-symlink-loop", loop)):
            cases.append(Case(recipe_name, "crash/" + name, argv(replace_output=path), hostile=path,
                              expect_error=True))
    # the recipe itself: it must run, and what the hostile variants are compared with
    clean_argv = argv()

    def clean_check(r, key=recipe_name, a=clean_argv):
        clean_status[key] = r.status
        clean_status[key + " rows"] = data_rows(output_of(a, recipe))
        ok = recipe.get("ok", (0,))
        return None if r.status in ok else f"the recipe does not run: status {r.status}, not {ok}"
    cases.append(Case(recipe_name, "crash/clean", clean_argv, check=clean_check))
    stream = recipe.get("stream")
    if stream:
        truncated = fixture.variant(stream, "truncated.bin")
        cases.append(Case(recipe_name, "crash/truncated-binary-record", argv({stream: truncated}), hostile=truncated,
                          check=lambda r, p=truncated: None if p in r.stderr else f"stderr does not name {p}"))
        bom = fixture.variant(stream, "bom.csv")

        def same_as_clean(r, key=recipe_name):
            return None if r.status == clean_status.get(key, r.status) else \
                f"status {r.status} with a byte order mark, {clean_status.get(key)} without"
        cases.append(Case(recipe_name, "crash/byte-order-mark", argv({stream: bom}), hostile=bom, check=same_as_clean))
        huge = fixture.variant(stream, "huge-line.csv")
        cases.append(Case(recipe_name, "crash/huge-line", argv({stream: huge}), hostile=huge,
                          check=lambda r, p=huge: None if p in r.stderr else f"stderr does not name {p}"))
        # blind
        if recipe.get("judges"):
            for kind in ("nan-span.csv", "clock-step.csv"):
                path = fixture.variant(stream, kind)
                def said_so(r, p=path):
                    return None if p in r.stderr else f"says nothing about {os.path.basename(p)} on stderr"
                cases.append(Case(recipe_name, "blind/" + kind.split(".")[0], argv({stream: path}), hostile=path,
                                  check=said_so))
            if recipe_name == "mo-detect":
                # The log twice, the clock stepping back between: the collision is found twice.
                step_argv = argv({stream: fixture.variant(stream, "clock-step.csv")})

                def found_twice(r, a=step_argv, key=recipe_name):
                    rows, clean = data_rows(output_of(a, recipe)), clean_status.get(key + " rows")
                    return None if clean and rows == 2 * clean else \
                        f"{rows} event rows after a clock step back, {clean} in the log alone (twice that expected)"
                cases.append(Case(recipe_name, "blind/clock-step-events", step_argv, check=found_twice))
        # data loss: the output is the input
        if recipe.get("output"):
            copy = os.path.join(work, "victims", f"{counter[0]}-{os.path.basename(fixture.files[stream])}")
            shutil.copy(fixture.files[stream], copy)
            kept = digest_file(copy)
            cases.append(Case(recipe_name, "data-loss/output-is-input", argv({stream: copy}, replace_output=copy),
                              hostile=copy, expect_error=True,
                              check=lambda r, c=copy, k=kept: None if digest_file(c) == k else f"{c} changed"))
        # injection: a line break in a binary stream's comments and column names
        inj = fixture.variant(stream, "injection.bin")
        out = out_path()
        cases.append(Case(recipe_name, "injection/csv-comment", argv({stream: inj}, replace_output=out) +
                          ["--output-format", "csv"] if "--output-format" in help_text else
                          argv({stream: inj}, replace_output=out),
                          check=lambda r, o=out: injected_rows(o, r)))
    # hang: standard input closed, the input it reads (stream or other) left out of the command
    stdin_input = stream or recipe.get("stdin")
    if stdin_input:
        cases.append(Case(recipe_name, "hang/stdin-closed", [a for a in argv() if a != fixture.files[stdin_input]],
                          close_stdin=True))
    # crash: a profile with a byte order mark (as some editors save it), and one with an
    # unknown key nested 30,000 deep (a recursive parser or destructor overflows its stack)
    if "{profile}" in recipe["argv"]:
        bom_profile = fixture.profile_variant("bom")
        cases.append(Case(recipe_name, "crash/profile-byte-order-mark", argv({"{profile}": bom_profile}),
                          hostile=bom_profile, check=lambda r, key=recipe_name: None if r.status == clean_status.get(
                              key, r.status) else f"status {r.status} with a byte order mark, "
                              f"{clean_status.get(key)} without"))
        deep = fixture.profile_variant("deep")
        cases.append(Case(recipe_name, "crash/profile-nested-30000-deep", argv({"{profile}": deep}), hostile=deep))
    # injection: free text and output names holding a line break and a gnuplot command
    marker = os.path.join(work, "INJECTED")
    payload = f"x\"\n!touch {marker}\nprint \"x"
    for option, kind, choices in options_of(help_text):
        if kind == "TEXT" and not choices and any(w in option for w in ("title", "label", "name")):
            cases.append(Case(recipe_name, f"injection/{option}", argv(extra=[option, payload]),
                              check=lambda r: f"ran a command: {marker} exists" if os.path.exists(marker) else None))
    if recipe_name == "mo-plot":
        name = os.path.join(work, "out", f"x'\n!touch {marker}\n'.png")
        cases.append(Case(recipe_name, "injection/output-name", argv(replace_output=name),
                          check=lambda r: f"ran a command: {marker} exists" if os.path.exists(marker) else None))
    # resource: absurd values of every option that takes a value (not files, commands, choices)
    for option, kind, choices in options_of(help_text):
        if choices or kind in ("FILE", "DIR", "CMD", "PATH") or option in ("--output-format",):
            continue
        for value in ABSURD + (RANGES if kind in ("LIST", "MIN", "A") else ()):
            if option in ("--profile", "--output"):
                continue
            cases.append(Case(recipe_name, f"resource/{option}={value}", argv(extra=[option, value])))
    return cases


# Numbers beyond double, beyond 64-bit integers, huge negative, not a number; and ranges of
# absurd extent (a column range of 20 million, a time window to 1e300).
ABSURD = ("1e999", "99999999999999999999", "-1e300", "nan")
RANGES = ("q1-20000000", "1-4000000000", "0:1e300")


def injected_rows(path, result):
    for p in (path, path + ".png"):
        if os.path.exists(p) and os.path.isfile(p):
            data = open(p, "rb").read()
            if data.startswith(b"\x89MOLOG"):
                return None
            if re.search(rb"^666,", data, re.M):
                return f"a comment's line break became a data row in {p}"
    if re.search(rb"^666,", result.stdout, re.M):
        return "a comment's line break became a data row on stdout"
    return None


def output_of(argv, recipe):
    return argv[argv.index(recipe["output"]) + 1] if recipe.get("output") in argv else None


def data_rows(path):
    """Rows of a CSV output (header and comments left out), or None."""
    if not path or not os.path.isfile(path):
        return None
    lines = [l for l in open(path, "rb").read().splitlines() if l and not l.startswith(b"#")]
    return max(len(lines) - 1, 0)


def digest_file(path):
    return hashlib.sha1(open(path, "rb").read()).hexdigest() if os.path.exists(path) else None


def digest(folder):
    sums = {}
    for root, _, names in os.walk(folder):
        for name in names:
            p = os.path.join(root, name)
            if os.path.islink(p) or not os.path.isfile(p):
                continue
            sums[p] = hashlib.sha1(open(p, "rb").read()).hexdigest()
    return sums


def judge(case, r, statuses, ok, fixture):
    """The problems of one run (empty: it passed)."""
    problems = []
    if r.timed_out:
        problems.append(f"still running after {r.limit:g} s (killed)")
    elif r.signal is not None:
        problems.append(f"killed by signal {r.signal} ({signal.Signals(r.signal).name})")
    elif r.status not in statuses:
        problems.append(f"exit status {r.status}, documented: {sorted(statuses)}")
    if SANITIZER.search(r.stderr):
        problems.append("sanitizer report: " + SANITIZER.search(r.stderr).group(0))
    if r.max_rss_mb > fixture.args.max_rss_mb:
        problems.append(f"{r.max_rss_mb:.0f} MB resident, limit {fixture.args.max_rss_mb} MB")
    error = r.status is not None and r.status not in ok
    if case.expect_error and not r.timed_out and r.signal is None and not error:
        problems.append(f"exit status {r.status}: expected an error")
    if error and case.hostile and case.hostile not in r.stderr and os.path.basename(case.hostile) not in r.stderr:
        problems.append(f"error without naming {case.hostile}: {r.stderr.strip()[:200]!r}")
    if case.check and not r.timed_out:
        problem = case.check(r)
        if problem:
            problems.append(problem)
    return problems


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--bin", required=True)
    ap.add_argument("--source", required=True)
    ap.add_argument("--tools", required=True, help="the build's tools, ;-separated (CMake's MOMENTUM_TOOLS)")
    ap.add_argument("--limit", type=float, default=30.0, help="seconds a run may take")
    ap.add_argument("--hang-limit", type=float, default=10.0,
                    help="seconds a run with standard input closed, or a known failure, may take")
    ap.add_argument("--max-rss-mb", type=float, default=1024.0, help="resident memory a run may take")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--only", default="", help="only cases whose tool or name contains this")
    ap.add_argument("-v", "--verbose", action="store_true")
    args = ap.parse_args()
    args.bin = os.path.abspath(args.bin)
    args.source = os.path.abspath(args.source)

    tools = [t for t in re.split(r"[;,]", args.tools) if t]
    # Programs, not the links that keep a former name working (mo-lugre-fit -> mo-friction-fit).
    built = sorted(n for n in os.listdir(args.bin) if n.startswith("mo-") and not os.path.islink(os.path.join(args.bin, n)))
    problems = []
    if sorted(tools) != built:
        problems.append(f"the build's tools {sorted(tools)} are not the programs in {args.bin}: {built}")
    for tool in tools:
        if tool not in RECIPES:
            problems.append(f"{tool}: no recipe in tests/hostile/run_hostile.py RECIPES: add how to run it on a "
                            "small input, so that it meets the hostile cases")
    work = tempfile.mkdtemp(prefix="momentum-hostile-")
    try:
        os.makedirs(os.path.join(work, "out"))
        os.makedirs(os.path.join(work, "a-folder"))
        os.makedirs(os.path.join(work, "victims"))
        os.symlink(os.path.join(work, "loop-b"), os.path.join(work, "loop-a"))
        os.symlink(os.path.join(work, "loop-a"), os.path.join(work, "loop-b"))
        fixture = Fixture(args, work)
        counter = [0]
        plan = []
        for recipe_name, recipe in RECIPES.items():
            tool = recipe_name.split()[0]
            if tool not in tools:
                continue
            help_text = run([fixture.tool(tool), "--help"], work, args.limit).stdout.decode()
            statuses = documented_statuses(os.path.join(args.source, "man", f"{tool}.1.scd"))
            ok = set(recipe.get("ok", (0,)))
            for case in cases_for(fixture, recipe_name, recipe, help_text, counter):
                if args.only and args.only not in recipe_name + " " + case.name:
                    continue
                plan.append((case, statuses, ok))
        before = digest(fixture.inputs)

        def execute(item):
            case, statuses, ok = item
            # A tool that reads a closed standard input has nothing to wait for; a known failure
            # need not wait out the whole limit either.
            known = (case.tool, case.name) in PENDING or (case.tool, case.name) in NEW_FINDINGS
            limit = args.hang_limit if known or case.name.startswith("hang/") else args.limit
            r = run(case.argv, work, limit, stdin_bytes=case.stdin_bytes, close_stdin=case.close_stdin,
                    env=fixture.tool_env)
            r.limit = limit
            return case, r, judge(case, r, statuses, ok, fixture)

        # The clean runs first: the byte-order-mark cases compare with them.
        clean = [p for p in plan if p[0].name == "crash/clean"]
        rest = [p for p in plan if p[0].name != "crash/clean"]
        # Cases that share a marker or an input run alone, after the others.
        serial = [p for p in rest if p[0].name.startswith(("injection/", "data-loss/"))]
        parallel = [p for p in rest if p not in serial]
        results = []
        with concurrent.futures.ThreadPoolExecutor(args.jobs) as pool:
            results += list(pool.map(execute, clean))
            results += list(pool.map(execute, parallel))
        for item in serial:
            marker = os.path.join(work, "INJECTED")
            if os.path.exists(marker):
                os.remove(marker)
            results.append(execute(item))
        after = digest(fixture.inputs)
        changed = sorted(p for p in before if after.get(p) != before[p])

        passed = skipped = 0
        pending_passed = []
        for case, r, found in results:
            key = (case.tool, case.name)
            for table, label in ((PENDING, "PENDING"), (NEW_FINDINGS, "NEW FINDING")):
                if key in table:
                    if found:
                        skipped += 1
                        print(f"SKIP {case.tool}: {case.name}: {label} ({table[key]}): {'; '.join(found)}")
                    else:
                        pending_passed.append((key, table[key]))
                    break
            else:
                table = None
            if table is not None:
                continue
            if found:
                problems.append(f"{case.tool}: {case.name}: {'; '.join(found)}\n    command: "
                                + " ".join(repr(a) if re.search(r"\s", a) else a for a in case.argv)
                                + (f"\n    stderr: {r.stderr.strip()[-400:]}" if r.stderr.strip() else ""))
            else:
                passed += 1
                if args.verbose:
                    print(f"ok   {case.tool}: {case.name} ({r.seconds:.2f} s, status {r.status})")
        for p in changed:
            problems.append(f"an input file changed: {p}")
        for key, why in pending_passed:
            print(f"NOTE {key[0]}: {key[1]}: passes now: remove it from PENDING or NEW_FINDINGS ({why})")
        print(f"hostile: {len(results)} runs of {len(tools)} tools: {passed} passed, {skipped} pending "
              f"(skipped), {len(problems)} problems")
        for p in problems:
            print("FAIL " + p)
        return 1 if problems else 0
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
