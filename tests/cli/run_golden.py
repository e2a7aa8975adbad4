#!/usr/bin/env python3
"""Runs one golden command-line case (Miller/zstd style).

A case is a folder holding `cmd` (one bash command line), and optionally `stdin`, `expout`,
`experr`, `status` (expected exit status, default 0; the paths of tests/data and of the source
tree are written $DATA and $SRC in the expected files) and `tolerance`. The command runs with
cwd = the case folder, the built tools first on PATH, and DATA / SRC naming tests/data and the
source tree. Outputs are compared token by token: numbers within their tolerance, everything
else exactly. Run with --update to write the expected files from the current output (then
review them by hand).

Tolerance per kind of number. A CSV header line (names separated by commas) names the fields
of the rows below it that have as many fields. Times (a column named t, t_*, *_t, onset, end,
time or *_time) are compared absolutely: |a - b| <= time tolerance (default 1e-9 s), because a
relative tolerance on Unix-epoch times (1.7e9 s) would let 0.9 s through. Every other number
is compared relatively: |a - b| <= value tolerance * max(|a|, |b|) (default 1e-9). The file
`tolerance` holds a bare number (the value tolerance, as before) and/or lines `time X` and
`value X`.
"""
import argparse
import math
import os
import re
import subprocess
import sys

NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*(?:[eE][-+]?\d+)?|\.\d+(?:[eE][-+]?\d+)?|inf|nan)")
TOKEN = re.compile(r"[-+]?(?:\d+\.?\d*(?:[eE][-+]?\d+)?|\.\d+(?:[eE][-+]?\d+)?)|\s+|[^\s\d.+-]+|.")


def tokens(text):
    return TOKEN.findall(text)


TIME_COLUMN = re.compile(r"^(t|t_\w+|\w+_t|onset|end|time|\w+_time)$")
HEADER_NAME = re.compile(r"^[A-Za-z_][\w.\[\]-]*$")


class Tolerance:
    def __init__(self, value=1e-9, time=1e-9):
        self.value = value
        self.time = time

    @staticmethod
    def parse(text):
        tol = Tolerance()
        for line in text.splitlines():
            parts = line.split()
            if not parts or parts[0].startswith("#"):
                continue
            if len(parts) == 1:
                tol.value = float(parts[0])
            elif parts[0] in ("time", "value") and len(parts) == 2:
                setattr(tol, parts[0], float(parts[1]))
            else:
                raise ValueError(f"tolerance: cannot read '{line}'")
        return tol


def same_number(a, b, tol, absolute=False):
    try:
        x, y = float(a), float(b)
    except ValueError:
        return a == b
    if math.isnan(x) or math.isnan(y):
        return math.isnan(x) and math.isnan(y)
    if math.isinf(x) or math.isinf(y):
        return x == y
    if absolute:
        return abs(x - y) <= tol
    return abs(x - y) <= tol * max(abs(x), abs(y)) or abs(x - y) <= 1e-300


def csv_header(line):
    """The column names when `line` is a CSV header (two or more names, no number), else None."""
    fields = [f.strip() for f in line.split(",")]
    if len(fields) < 2 or not all(HEADER_NAME.match(f) for f in fields):
        return None
    return fields


def same_line(expected, actual, columns, tol):
    """Token by token; inside a CSV row under a header, time fields compare absolutely."""
    if columns and expected.count(",") + 1 == len(columns) and actual.count(",") + 1 == len(columns):
        fe, fa = expected.split(","), actual.split(",")
        return all(same_line(x, y, None, Tolerance(tol.value, tol.time)) if not TIME_COLUMN.match(name)
                   else same_tokens(x, y, tol.time, True)
                   for name, x, y in zip(columns, fe, fa))
    return same_tokens(expected, actual, tol.value, False)


def same_tokens(expected, actual, tol, absolute):
    te, ta = tokens(expected), tokens(actual)
    return len(te) == len(ta) and all(
        x == y or (NUMBER.fullmatch(x) and NUMBER.fullmatch(y) and same_number(x, y, tol, absolute))
        for x, y in zip(te, ta))


def compare(name, expected, actual, tol):
    if expected == actual:
        return True
    el, al = expected.splitlines(), actual.splitlines()
    if len(el) == len(al):
        bad = None
        columns = None
        for i, (e, a) in enumerate(zip(el, al)):
            header = csv_header(e)
            if header is not None and e == a:
                columns = header
            if not same_line(e, a, columns, tol):
                bad = i
                break
        if bad is None:
            return True
        print(f"{name}: line {bad + 1} differs\n  expected: {el[bad]}\n  actual:   {al[bad]}")
    else:
        print(f"{name}: {len(al)} lines, expected {len(el)}")
        for i, (e, a) in enumerate(zip(el, al)):
            if e != a:
                print(f"  first difference at line {i + 1}\n  expected: {e}\n  actual:   {a}")
                break
    return False


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--bin", required=True)
    parser.add_argument("--data", required=True)
    parser.add_argument("--source", required=True)
    parser.add_argument("--update", action="store_true")
    parser.add_argument("case")
    args = parser.parse_args()
    case = args.case
    read = lambda f: open(os.path.join(case, f), encoding="utf-8", errors="replace").read()
    exists = lambda f: os.path.exists(os.path.join(case, f))
    env = dict(os.environ)
    env["PATH"] = args.bin + os.pathsep + env.get("PATH", "")
    env["DATA"] = args.data
    env["SRC"] = args.source
    env["LC_ALL"] = "C"
    stdin = open(os.path.join(case, "stdin"), "rb") if exists("stdin") else subprocess.DEVNULL
    proc = subprocess.run(["bash", "-c", read("cmd")], cwd=case, env=env, stdin=stdin,
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, timeout=900)
    # Paths of this checkout are written as $DATA and $SRC, so expected files are portable.
    def portable(text):
        return text.replace(args.data, "$DATA").replace(args.source, "$SRC")
    out = portable(proc.stdout.decode("utf-8", "replace"))
    err = portable(proc.stderr.decode("utf-8", "replace"))
    status = int(read("status").strip()) if exists("status") else 0
    tol = Tolerance.parse(read("tolerance")) if exists("tolerance") else Tolerance()
    if args.update:
        open(os.path.join(case, "expout"), "w").write(out)
        open(os.path.join(case, "experr"), "w").write(err)
        if proc.returncode:
            open(os.path.join(case, "status"), "w").write(f"{proc.returncode}\n")
        return 0
    ok = True
    if proc.returncode != status:
        print(f"exit status {proc.returncode}, expected {status}")
        ok = False
    if exists("expout") and not compare("stdout", read("expout"), out, tol):
        ok = False
    if exists("experr") and not compare("stderr", read("experr"), err, tol):
        ok = False
    if not ok:
        print("---- stdout ----\n" + out[-3000:] + "\n---- stderr ----\n" + err[-3000:])
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
