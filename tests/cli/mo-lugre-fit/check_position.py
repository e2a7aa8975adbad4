#!/usr/bin/env python3
"""Checks mo-lugre-fit's position-dependence warning against the simulated model error.

  check_position.py REPORT_JSON STDERR_FILE AFFECTED

AFFECTED: comma-separated joints whose model is wrong in the simulation (empty: none). Per joint
prints "warned" or "not warned", and "ok" or the reason it fails: the report's
residual_split.position_dependent and the stderr warning ("joint N: ... mo-dynfit") must be
present exactly for the affected joints. Exits 1 on a failure. The fractions go to stderr.
"""
import json
import sys


def main():
    report = json.load(open(sys.argv[1], encoding="utf-8"))
    stderr = open(sys.argv[2], encoding="utf-8").read()
    affected = {int(j) for j in sys.argv[3].split(",") if j}
    failed = False
    for joint in report["joints"]:
        n = joint["joint"]
        split = joint["residual_split"]
        print("joint %d: position fraction %.3f, velocity fraction %.3f, explained rms %.4f Nm, r rms %.3f Nm"
              % (n, split["position_fraction"], split["velocity_fraction"], split["explained_rms"], split["signal_rms"]),
              file=sys.stderr)
        flagged = bool(split["position_dependent"])
        warned = any(line.startswith("mo-lugre-fit: warning: joint %d:" % n) and "mo-dynfit" in line
                     for line in stderr.splitlines())
        expected = n in affected
        problems = []
        if flagged != expected:
            problems.append("report says position_dependent=%s" % flagged)
        if warned != expected:
            problems.append("warning %s on stderr" % ("present" if warned else "missing"))
        print("joint %d %s: %s" % (n, "warned" if expected else "not warned", "; ".join(problems) or "ok"))
        failed = failed or bool(problems)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
