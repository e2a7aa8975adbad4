#!/usr/bin/env python3
"""Checks a mo-dynfit report against the TRUE arm the log was simulated from.

usage: check_recovery.py TRUE_URDF FIT_REPORT TRUTH_REPORT [--sigmas 3] [--velocity-noise SIGMA]

The true standard parameters are computed here, independently of the library, from the URDF's
<inertial> elements (links on fixed joints merged into their moving parent; every origin in
these test URDFs has rpy 0, which is asserted). Each identified base combination must lie
within SIGMAS reported uncertainties of the truth (the uncertainty covers the noise, the velocity
noise's bias and the friction-model term; scripts/coverage-fit.py measures how often it holds
over many seeds). TRUTH_REPORT is mo-dynfit's report with the
TRUE profile as its nominal model (nothing to correct): its "before" RMS is the noise floor of the
filtered equation with the true model and the same friction model; the corrected model's
held-out RMS must fall to within 15% of it, and the nominal model's must be well above it.
"""
import json
import sys
import xml.etree.ElementTree as ET


def vec(text):
    return [float(x) for x in (text or "0 0 0").split()]


def standard_parameters(urdf_path):
    root = ET.parse(urdf_path).getroot()
    links = {l.get("name"): l for l in root.findall("link")}
    joints = root.findall("joint")
    parent_of = {j.find("child").get("link"): j for j in joints}
    bodies = {}   # moving body name -> [m, mx, my, mz, ixx, ixy, ixz, iyy, iyz, izz]
    order = []
    for name, link in links.items():
        # walk up through fixed joints to the moving body, summing offsets (rpy 0)
        offset = [0.0, 0.0, 0.0]
        body = name
        while body in parent_of and parent_of[body].get("type") == "fixed":
            j = parent_of[body]
            origin = j.find("origin")
            if origin is not None:
                assert vec(origin.get("rpy")) == [0, 0, 0]
                offset = [a + b for a, b in zip(offset, vec(origin.get("xyz")))]
            body = j.find("parent").get("link")
        if body not in parent_of:
            continue  # the fixed base
        inertial = link.find("inertial")
        if inertial is None:
            continue
        origin = inertial.find("origin")
        c = [0.0, 0.0, 0.0]
        if origin is not None:
            assert vec(origin.get("rpy")) == [0, 0, 0]
            c = vec(origin.get("xyz"))
        c = [a + b for a, b in zip(c, offset)]
        m = float(inertial.find("mass").get("value"))
        i = inertial.find("inertia")
        I = {k: float(i.get(k)) for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
        cc = sum(x * x for x in c)
        origin_inertia = [
            I["ixx"] + m * (cc - c[0] * c[0]), I["ixy"] - m * c[0] * c[1], I["ixz"] - m * c[0] * c[2],
            I["iyy"] + m * (cc - c[1] * c[1]), I["iyz"] - m * c[1] * c[2], I["izz"] + m * (cc - c[2] * c[2])]
        theta = [m, m * c[0], m * c[1], m * c[2]] + origin_inertia
        if body not in bodies:
            bodies[body] = [0.0] * 10
            order.append(body)
        bodies[body] = [a + b for a, b in zip(bodies[body], theta)]
    return bodies


NAMES = ["m", "mx", "my", "mz", "ixx", "ixy", "ixz", "iyy", "iyz", "izz"]


def main():
    args = sys.argv[1:]
    sigmas = 3.0
    if "--sigmas" in args:
        k = args.index("--sigmas")
        sigmas = float(args[k + 1])
        del args[k:k + 2]
    velocity_noise = None
    if "--velocity-noise" in args:
        k = args.index("--velocity-noise")
        velocity_noise = float(args[k + 1])
        del args[k:k + 2]
    urdf, fit_path, truth_path = args
    theta = standard_parameters(urdf)
    fit = json.load(open(fit_path))
    truth_fit = json.load(open(truth_path))
    ok = True
    worst = 0.0
    for k, base in enumerate(fit["base"]):
        true_value = 0.0
        for key, w in base["direction"].items():
            body, name = key.rsplit(".", 1)
            true_value += w * theta[body][NAMES.index(name)]
        se = base.get("uncertainty", base["standard_error"])
        z = (base["value"] - true_value) / se
        worst = max(worst, abs(z))
        inside = abs(base["value"] - true_value) <= sigmas * se
        flag = "" if inside else "   <-- outside"
        print(f"b{k + 1:<2} nominal {base['nominal']:11.5g}  fitted {base['value']:11.5g} +- {se:9.3g}"
              f"  true {true_value:11.5g}  z {z:6.2f}{flag}")
        if not inside:
            ok = False
    print(f"{len(fit['base'])} base parameters, largest |z| {worst:.2f} (allowed {sigmas})")
    if velocity_noise is not None:
        # The level the simulator added, estimated by mo-dynfit from the velocities alone.
        levels = fit["velocity_noise"]["per_joint"]
        good = all(abs(v / velocity_noise - 1) < 0.15 for v in levels)
        print(f"velocity noise estimated {' '.join(f'{v:.4g}' for v in levels)} rad/s, simulated {velocity_noise}"
              f"{'' if good else '   <-- off by more than 15%'}")
        ok = ok and good
    # What the data do not determine may move only as far as physics needs: an unexcited
    # inertia entry stays within its body's nominal inertia trace of the nominal value (the
    # alternating projection this replaced had put 1.02 kg m^2 on a 0.022 kg m^2 waist).
    traces = {}
    for e in fit["parameters"]:
        if e["name"] in ("ixx", "iyy", "izz"):
            traces[e["body"]] = traces.get(e["body"], 0.0) + e["nominal"]
    drift = 0.0
    for e in fit["parameters"]:
        if e["excitation"] == "not excited" and e["name"].startswith("i"):
            drift = max(drift, abs(e["value"] - e["nominal"]) / traces[e["body"]])
    print(f"unexcited inertia entries moved by at most {drift:.3f} of their body's nominal inertia trace")
    if drift > 1.0:
        print("   <-- an unexcited parameter moved further than physics needs")
        ok = False
    floor = truth_fit["rms_before"]
    for j, (before, after, noise) in enumerate(zip(fit["rms_before"], fit["rms_after"], floor)):
        good = after <= 1.15 * noise and before > 3 * noise
        print(f"joint {j + 1}: held-out RMS nominal {before:.4f} -> corrected {after:.4f} Nm; "
              f"true model {noise:.4f} Nm{'' if good else '   <-- not at the noise floor'}")
        ok = ok and good
    if not fit["held_out"]:
        print("no held-out data")
        ok = False
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
