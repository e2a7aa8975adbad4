#!/usr/bin/env python3
"""Compares mo-calibrate reports (-n) of the same check log observed with three profiles that
differ only in the inertial model: the nominal (wrong) URDF, the URDF corrected by mo-dynfit from
another log, and the TRUE URDF (the reference). Passes when, per joint, the corrected threshold
is within 3% of the true model's, and the nominal one is higher than the corrected one by more
than 1 Nm on at least one joint (the model error the correction removed)."""
import sys


def thresholds(path):
    out = {}
    header = None
    for line in open(path):
        if line.startswith("#") or not line.strip():
            continue
        cells = line.split()
        if cells[0] == "signal":
            header = cells
            continue
        out[int(cells[header.index("joint")])] = float(cells[header.index("threshold")])
    return out


nominal, corrected, true = (thresholds(p) for p in sys.argv[1:4])
ok = True
dropped = False
for j in sorted(true):
    close = abs(corrected[j] - true[j]) <= 0.03 * true[j]
    dropped = dropped or nominal[j] - corrected[j] > 1.0
    print(f"joint {j}: threshold nominal {nominal[j]:.3f} -> corrected {corrected[j]:.3f} Nm; "
          f"true model {true[j]:.3f} Nm{'' if close else '   <-- not at the true model'}")
    ok = ok and close
if not dropped:
    print("no threshold dropped by more than 1 Nm")
ok = ok and dropped
sys.exit(0 if ok else 1)
