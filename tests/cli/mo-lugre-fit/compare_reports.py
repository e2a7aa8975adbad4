#!/usr/bin/env python3
"""compare_reports.py A B C: A and B must hold bit-identical fits (same seed, other thread
count), C (another seed) a different one. Prints one line per claim."""
import json
import sys


def fitted(path):
    report = json.load(open(path, encoding="utf-8"))
    return [(j["joint"], name, p["value"]) for j in report["joints"]
            for name, p in sorted(j["fit"]["parameters"].items())], \
           [j["fit"]["evaluations"] for j in report["joints"]]


a, b, c = (fitted(p) for p in sys.argv[1:4])
# JSON numbers are written with 17 significant digits by nlohmann::json: equal text, equal bits.
print("same seed, 1 and 2 threads:", "identical" if a == b else "DIFFERENT")
print("another seed:", "different" if a[0] != c[0] else "IDENTICAL")
sys.exit(0 if a == b and a[0] != c[0] else 1)
