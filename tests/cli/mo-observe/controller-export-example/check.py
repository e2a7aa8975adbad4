#!/usr/bin/env python3
"""Checks what share/momentum/examples/import-controller-export.sh recovered from the example
export against the simulated log the export was made from (tests/data/streams/
controller-export-original.csv, mo-sim, known scaling): every value within the export's
rounding, the two faulty rows gone, and the residuals equal to those of the original log within
what the rounding of the currents can move them."""
import math
import os
import subprocess
import sys

DATA = os.environ["DATA"]
SRC = os.environ["SRC"]
DEG = math.pi / 180


def table(text):
    lines = [l for l in text.splitlines() if l and not l.startswith("#")]
    header = lines[0].split(",")
    return header, [[float(x) for x in l.split(",")] for l in lines[1:]]


recovered_header, recovered = table(open(sys.argv[1]).read())
original_text = open(f"{DATA}/streams/controller-export-original.csv").read()
original_header, original = table(original_text)
# The row written early (t = 1.448 s) is dropped by --repair: the original without it.
kept = [row for row in original if abs(row[0] - 1.448) > 1e-9]
print(f"rows: {len(recovered)} recovered, {len(original)} simulated, {len(kept)} expected")

# Export rounding: positions 1e-4 deg, velocities 1e-3 deg/s, currents 1 per mille of 5 A.
half_step = {"t": 1e-12, "q": 0.5e-4 * DEG, "dq": 0.5e-3 * DEG, "i": 0.5 * 0.005}
for prefix, bound in half_step.items():
    columns = [c for c in original_header if c.rstrip("0123456789") == prefix]
    worst = max(abs(a[recovered_header.index(c)] - b[original_header.index(c)])
                for a, b in zip(recovered, kept) for c in columns)
    print(f"{','.join(columns)} within the export's rounding ({bound:.3g}): "
          f"{'yes' if worst <= bound * (1 + 1e-9) + 1e-15 else 'NO (%g)' % worst}")

# Residuals of the original log (without the early row) through the same observer. The current
# rounding (<= 2.5 mA, k_i <= 11 Nm/A: 0.0275 Nm) passes through the observer's filter, whose
# gain is at most 1.05 for the paper arm's second order; the velocity rounding adds < 0.002 Nm.
profile = f"{SRC}/share/momentum/robots/paper-arm/paper-arm.json"
lines = [l for l in original_text.splitlines() if not l.startswith("#")]
reference_text = "\n".join([lines[0]] + [l for l, row in zip(lines[1:], original) if row in kept]) + "\n"
reference = subprocess.run(["mo-observe", "-q", "-p", profile], input=reference_text,
                           capture_output=True, text=True, check=True).stdout
reference_header, reference_rows = table(reference)
bound = 0.0275 * 1.05 + 0.002
worst = max(abs(a[recovered_header.index(f"r{j}")] - b[reference_header.index(f"r{j}")])
            for a, b in zip(recovered, reference_rows) for j in (1, 2, 3))
largest = max(abs(b[reference_header.index(f"r{j}")]) for b in reference_rows for j in (1, 2, 3))
print(f"r1-3 within {bound:.3g} Nm of the original's: {'yes' if worst <= bound else 'NO (%g)' % worst}")
print(f"worst {worst:.3g} Nm, largest |r| {largest:.3g} Nm", file=sys.stderr)
