#!/usr/bin/env python3
"""check_thinned.py FULL THINNED: the fit on windows thinned from a long log (--max-samples)
must agree with the fit on every sample: each parameter the data determine within 2 of the
thinned fit's reported uncertainties, and the thinned fit must really have been thinned. Prints
one line per joint (the largest |z|) and exits 1 on a disagreement."""
import json
import sys

full, thinned = (json.load(open(p, encoding="utf-8")) for p in sys.argv[1:3])
ok = True
for a, b in zip(full["joints"], thinned["joints"]):
    kept, total = b["fit"]["metrics"]["samples"], a["fit"]["metrics"]["samples"]
    if not kept < total / 2:
        print(f"joint {a['joint']}: NOT THINNED ({kept} of {total} samples)")
        ok = False
    worst, name = 0.0, ""
    for k, pa in a["fit"]["parameters"].items():
        pb = b["fit"]["parameters"][k]
        if not (pa["identifiable"] and pb["identifiable"]) or pa.get("at_bound") or pb.get("at_bound"):
            continue
        z = abs(pb["value"] - pa["value"]) / pb["uncertainty"]
        if z > worst:
            worst, name = z, k
    ok = ok and worst <= 2
    print(f"joint {a['joint']}: the thinned fit agrees with the full one within 2 uncertainties"
          if worst <= 2 else f"joint {a['joint']}: {name} off by {worst:.2f} uncertainties")
sys.exit(0 if ok else 1)
