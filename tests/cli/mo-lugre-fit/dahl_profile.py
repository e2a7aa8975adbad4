#!/usr/bin/env python3
"""Writes the paper arm's profile with Dahl friction as the simulator's truth.

  dahl_profile.py PAPER_ARM_PROFILE OUT

The truth (simulation.friction): Dahl with each joint's sigma2 and tau_c of the paper's Table 1
and bristle stiffnesses inside the default search box. The urdf path is made absolute.
"""
import json
import os
import re
import sys

source, out = sys.argv[1:3]
text = open(source, encoding="utf-8").read()
text = re.sub(r"^\s*//.*$", "", text, flags=re.M)
profile = json.loads(text)
profile["urdf"] = os.path.abspath(os.path.join(os.path.dirname(source), profile["urdf"]))
profile["simulation"]["friction"] = {
    "model": "dahl",
    "update": "exact",
    "joints": [
        {"sigma0": 70000.0, "sigma2": 6.4865, "tau_c": 7.8322},
        {"sigma0": 80000.0, "sigma2": 6.1838, "tau_c": 8.1855},
        {"sigma0": 90000.0, "sigma2": 5.3929, "tau_c": 7.0023},
    ],
}
json.dump(profile, open(out, "w", encoding="utf-8"), indent=1)
