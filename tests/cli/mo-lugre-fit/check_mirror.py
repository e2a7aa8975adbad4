#!/usr/bin/env python3
"""Checks the mirror check of a mo-lugre-fit --report (the paper's ref. 37, its Table 2).

  check_mirror.py REPORT_JSON BOUND_NM MIN_FRACTION

Per joint prints one line, "ok" or the reason it fails, and exits 1 on a failure: the mirror
RMS (fitted friction against half the difference of the forward and mirrored motor torques) is
below BOUND_NM, and at least MIN_FRACTION of the paired samples were compared (the samples
near slow motion that the check leaves out must not hide the motion). The measured numbers go
to stderr for the record.
"""
import json
import math
import sys


def main():
    report = json.load(open(sys.argv[1], encoding="utf-8"))
    bound = float(sys.argv[2])
    min_fraction = float(sys.argv[3])
    failed = False
    for joint in report["joints"]:
        m = joint.get("mirror")
        name = "joint %d mirror" % joint["joint"]
        if not m:
            print(name + ": no mirror check in the report")
            failed = True
            continue
        rms = m["rms"]
        total = m["samples"] + m["excluded"]
        print("%s: rms %.4f Nm, max %.4f Nm, static rms %.4f Nm, %d of %d samples compared"
              % (name, rms, m["max_abs"], m.get("static_rms") or float("nan"), m["samples"], total),
              file=sys.stderr)
        problems = []
        if rms is None or not math.isfinite(rms) or not rms < bound:
            problems.append("rms %s Nm is not below %g Nm" % (rms, bound))
        if total == 0 or m["samples"] < min_fraction * total:
            problems.append("only %d of %d samples compared" % (m["samples"], total))
        print(name + ": " + ("; ".join(problems) if problems else "ok"))
        failed = failed or bool(problems)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
