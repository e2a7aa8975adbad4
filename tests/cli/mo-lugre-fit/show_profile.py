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
    ok = all(isinstance(v, (int, float)) and v == v for v in entry.values())
    print(f"  joint {j}:", ",".join(sorted(entry)), "finite" if ok else "NOT FINITE")
for p in profile.get("provenance", []):
    d = p["details"]
    print("provenance", p["tool"], len(d["logs"]), "log", d["model"], d["method"],
          "rms", "all finite" if all(x["rms"] is not None for x in d["joints"]) else "missing")
print("urdf", profile["urdf"])
