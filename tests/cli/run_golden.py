#!/usr/bin/env python3
"""Runs one golden command-line case (Miller/zstd style).

A case is a folder holding `cmd` (one bash command line), and optionally `stdin`, `expout`,
`experr`, `status` (expected exit status, default 0; the paths of tests/data and of the source
tree are written $DATA and $SRC in the expected files) and `tolerance` (relative tolerance for
numbers, default 1e-9). The command runs with cwd = the case folder, the built tools first on
PATH, and DATA / SRC naming tests/data and the source tree. Outputs are compared token by
token: numbers within the tolerance, everything else exactly. Run with --update to write the
expected files from the current output (then review them by hand).
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


def same_number(a, b, tol):
    try:
        x, y = float(a), float(b)
    except ValueError:
        return a == b
    if math.isnan(x) or math.isnan(y):
        return math.isnan(x) and math.isnan(y)
    if math.isinf(x) or math.isinf(y):
        return x == y
    return abs(x - y) <= tol * max(abs(x), abs(y)) or abs(x - y) <= 1e-300


def compare(name, expected, actual, tol):
    if expected == actual:
        return True
    el, al = expected.splitlines(), actual.splitlines()
    if len(el) == len(al):
        bad = None
        for i, (e, a) in enumerate(zip(el, al)):
            te, ta = tokens(e), tokens(a)
            if len(te) != len(ta) or not all(
                x == y or (NUMBER.fullmatch(x) and NUMBER.fullmatch(y) and same_number(x, y, tol))
                for x, y in zip(te, ta)
            ):
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
    tol = float(read("tolerance").strip()) if exists("tolerance") else 1e-9
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
