#!/usr/bin/env python3
"""Prints what a golden case checks in a profile written by mo-lugre-fit: the friction model,
the parameter names per joint, and the provenance entries (tool, logs' count, model, method)."""
import json
import re
import sys

# Profiles keep their comments (// and /* */) through updates: drop them outside strings.
text = open(sys.argv[1], encoding="utf-8").read()
profile = json.loads(re.sub(r'("(?:\\.|[^"\\])*")|//[^\n]*|/\*.*?\*/', lambda m: m.group(1) or "", text, flags=re.S))
friction = profile["friction"]
print("friction", friction["model"], friction.get("update", "-"), len(friction["joints"]), "joints")
for j, entry in enumerate(friction["joints"], 1):
    covariance = entry.pop("covariance", None)
    ok = all(isinstance(v, (int, float)) and v == v for v in entry.values())
    if covariance is not None:  # the steady-state parameters' covariance: named, square, finite
        names, matrix = covariance["parameters"], covariance["matrix"]
        ok = ok and len(matrix) == len(names) and all(len(r) == len(names) and all(x == x for x in r) for r in matrix)
    print(f"  joint {j}:", ",".join(sorted(entry)), "finite" if ok else "NOT FINITE",
          "covariance of " + ",".join(covariance["parameters"]) if covariance else "no covariance")
for p in profile.get("provenance", []):
    d = p["details"]
    print("provenance", p["tool"], len(d["logs"]), "log", d["model"], d["method"],
          "rms", "all finite" if all(x["rms"] is not None for x in d["joints"]) else "missing")
print("urdf", profile["urdf"])
