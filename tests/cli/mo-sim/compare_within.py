#!/usr/bin/env python3
"""Compares two sample streams column by column: prints, per column prefix given as PREFIX=TOL,
whether every value agrees within TOL (absolute), and the row counts."""
import csv
import sys


def read(path):
    rows = [r for r in csv.reader(l for l in open(path) if not l.startswith("#"))]
    return rows[0], [[float(x) for x in r] for r in rows[1:]]


ha, a = read(sys.argv[1])
hb, b = read(sys.argv[2])
print(f"rows {len(a)} and {len(b)}")
for spec in sys.argv[3:]:
    prefix, tol = spec.split("=")
    tol = float(tol)
    cols = [c for c in ha if c.rstrip("0123456789") == prefix]
    worst = max(abs(ra[ha.index(c)] - rb[hb.index(c)]) for ra, rb in zip(a, b) for c in cols)
    print(f"{','.join(cols)} within {tol:g}: {'yes' if worst <= tol else 'NO (%g)' % worst}")
