#!/usr/bin/env python3
"""check_seeds.py REF OTHER...: every report's fit of each joint must agree with REF's (another
seed, or an input that differs in the tenth digit) within their reported uncertainties: for
every free parameter, |value - ref| <= 3 x the larger one-sigma uncertainty of the two (the
reference's when the other has none: a fit in another basin often has none). Prints one line per
report."""
import json
import math
import sys


def joints(path):
    return {j["joint"]: j["fit"]["parameters"] for j in json.load(open(path, encoding="utf-8"))["joints"]}


reference = joints(sys.argv[1])
status = 0
for path, label in zip(sys.argv[2:], sys.argv[2:]):
    worst = []
    for joint, parameters in joints(path).items():
        for name, p in sorted(parameters.items()):
            r = reference[joint][name]
            if not p.get("free"):
                continue
            spread = [u for u in (p.get("uncertainty"), r.get("uncertainty")) if u is not None and math.isfinite(u)]
            sigma = max(spread) if spread else 0.0
            if abs(p["value"] - r["value"]) > 3 * sigma:
                worst.append(f"joint {joint} {name} {p['value']:.6g} vs {r['value']:.6g} +- {sigma:.2g}")
    name = path.rsplit("/", 1)[-1].removesuffix(".json")
    print(f"{name}: " + ("agrees with the reference within 3 uncertainties" if not worst else "DIFFERS: " + "; ".join(worst)))
    status |= bool(worst)
sys.exit(status)
