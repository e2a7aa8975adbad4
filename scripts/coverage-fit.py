#!/usr/bin/env python3
"""Coverage of the uncertainties that mo-lugre-fit and mo-dynfit report (issue 15).

usage: coverage-fit.py [--seeds N] [--seed BASE] [--bin DIR] [--work DIR] [--jobs 1|2]
                       [--fitters lugre-fit,dynfit] [--truths lugre,stribeck]
                       [--require FITTER/TRUTH:K=SHARE ...] [--json FILE]

For N simulation seeds BASE, BASE+1, ... it simulates collision-free logs of the paper arm
(share/momentum/robots/paper-arm) with mo-sim, fits them, and compares every fitted parameter
that has a counterpart in the simulator's true friction or URDF with the truth:

  lugre-fit  the paper's motion at 125 Hz for 14 s (the recovery goldens' log), observed with
             mo-observe and fitted with mo-lugre-fit (default LuGre model, --skip 1). Compared:
             sigma2, tau_c, tau_s, w_s per joint, and sigma0, sigma1 when the fit calls them
             identifiable and off their bounds (a LuGre truth only: a Stribeck truth has no
             bristles); the predicted steady-state friction at a few speeds ("f@0.05" ...,
             rad/s), its uncertainty propagated from the reported covariance and the signed
             systematic shifts.
  dynfit     the excitation (mo-sim --trajectory excite: the same motion for every seed, so that
             the base parameters are the same combinations) for 60 s (--dynfit-duration) at 1 kHz,
             fitted with mo-dynfit
             --torque-held with the true profile as the nominal one (the estimator is linear:
             the nominal model does not move the unprojected estimate). Compared: every base
             parameter (its direction applied to the URDF's standard parameters), and the
             Coulomb and viscous friction against tau_c and sigma2 of a Coulomb-viscous truth.

Truth models (the profile's simulation.friction): "lugre" is the paper arm's own LuGre friction
(paper's Table 1); "stribeck" is a static Coulomb-viscous friction with a Stribeck dip (tau_c
and tau_s of the paper's table swapped, so that the breakaway level tau_s is above the Coulomb
level, same w_s and sigma2), a model that neither fitter's own model is; "coulomb-viscous" the
paper's tau_c and sigma2 alone (mo-dynfit's own model; a control); "none" no friction.

z = (fitted - true) / reported uncertainty, the uncertainty being what the report calls
"uncertainty" (standard error and systematic shifts combined). The table gives per fitter and
truth model the share of parameter-seed pairs with |z| <= 1, 2, 3 (a calibrated Gaussian
uncertainty: 68.3, 95.4, 99.7%), the same for the standard error alone, and the number of pairs;
then per parameter the mean z (a bias shows as a mean far from 0: model error, not noise), the
RMS z (1 when calibrated) and the worst z with its seed.

--require FITTER/TRUTH:K=SHARE exits 1 when the share within K uncertainties is below SHARE
(e.g. lugre-fit/lugre:3=0.9). Every run is seeded: the same arguments give the same table.
"""
import argparse
import concurrent.futures
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE = os.path.dirname(HERE)
PROFILE = os.path.join(SOURCE, "share", "momentum", "robots", "paper-arm", "paper-arm.json")
CURVE_SPEEDS = [0.05, 0.1, 0.2, 0.4]
STATIC = ("sigma2", "tau_c", "tau_s", "w_s")


def load_json_with_comments(path):
    text = open(path, encoding="utf-8").read()
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    text = re.sub(r"^\s*//.*$", "", text, flags=re.M)
    return json.loads(text)


def truth_profile(model, work):
    """Writes the paper arm's profile with the TRUE friction `model` and returns its path."""
    profile = load_json_with_comments(PROFILE)
    profile["urdf"] = os.path.join(os.path.dirname(PROFILE), profile["urdf"])
    lugre = profile["simulation"]["friction"]["joints"]
    if model == "lugre":
        pass
    elif model == "stribeck":
        profile["simulation"]["friction"] = {
            "model": "stribeck",
            "joints": [{"sigma2": j["sigma2"], "tau_c": j["tau_s"], "tau_s": j["tau_c"], "w_s": j["w_s"]}
                       for j in lugre]}
    elif model == "none":
        del profile["simulation"]["friction"]
    elif model == "coulomb-viscous":
        profile["simulation"]["friction"] = {
            "model": "coulomb-viscous",
            "joints": [{"sigma2": j["sigma2"], "tau_c": j["tau_c"]} for j in lugre]}
    else:
        raise SystemExit(f"coverage-fit: unknown truth model '{model}'")
    path = os.path.join(work, f"truth-{model}.json")
    with open(path, "w", encoding="utf-8") as f:
        json.dump(profile, f, indent=1)
    return path, profile


# --- the URDF's standard parameters: the recovery check's reader, independent of the library ---

sys.path.insert(0, os.path.join(SOURCE, "tests", "cli", "mo-dynfit"))
from check_recovery import NAMES, standard_parameters as body_parameters  # noqa: E402


def standard_parameters(urdf_path):
    """{moving body: {"m": .., "mx": .., ..., "izz": ..}}, about the body (joint) origin."""
    return {body: dict(zip(NAMES, theta)) for body, theta in body_parameters(urdf_path).items()}


# --- running the tools ---

def run(cmd, **kw):
    p = subprocess.run(cmd, shell=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kw)
    return p.returncode, p.stderr


def tool(args, name):
    return os.path.join(args.bin, name)


def nice():
    return "nice -n 10 " if shutil.which("nice") else ""


def steady_friction(p, v):
    """LuGre's (and Stribeck's) steady-state friction at speed v > 0, and its gradient in
    (sigma2, tau_c, tau_s, w_s)."""
    e = math.exp(-(v / p["w_s"]) ** 2)
    f = p["tau_c"] + (p["tau_s"] - p["tau_c"]) * e + p["sigma2"] * v
    grad = {"sigma2": v, "tau_c": 1.0 - e, "tau_s": e,
            "w_s": (p["tau_s"] - p["tau_c"]) * e * 2.0 * v * v / p["w_s"] ** 3}
    return f, grad


def fitted_report(args, cmd, report, scratch, what):
    """Runs cmd, which writes the JSON report `report`, and returns the report; the scratch file
    goes, and the report too unless --keep."""
    status, err = run(cmd)
    if not os.path.exists(report):
        raise RuntimeError(f"{what}: exit {status}: {err.strip()}")
    fit = json.load(open(report))
    os.remove(scratch)
    if not args.keep:
        os.remove(report)
    return fit


def lugre_fit_seed(args, truth, profile_path, profile, seed, work):
    obs = os.path.join(work, f"lugre-{truth}-{seed}.csv")
    report = os.path.join(work, f"lugre-{truth}-{seed}.json")
    n = nice()
    cmd = (f"{n}{tool(args, 'mo-sim')} -q -p {profile_path} --rate 125 --duration 14 --seed {seed} {args.sim_options} | "
           f"{n}{tool(args, 'mo-observe')} -q -p {profile_path} > {obs} && "
           f"{n}{tool(args, 'mo-lugre-fit')} -q -p {profile_path} --skip 1 --no-static --threads 1 "
           f"--seed {seed} {args.fit_options} {obs} --report {report}")
    fit = fitted_report(args, cmd, report, obs, f"lugre-fit seed {seed} ({truth})")
    true_joints = profile["simulation"]["friction"]["joints"]
    rows = []
    for entry in fit["joints"]:
        j = entry["joint"]
        params = entry["fit"]["parameters"]
        true = true_joints[j - 1]
        names = list(STATIC) + (["sigma0", "sigma1"] if truth == "lugre" else [])
        for name in names:
            p = params[name]
            if name not in true or p["uncertainty"] is None or not p["free"]:
                continue
            if name in ("sigma0", "sigma1") and (not p["identifiable"] or p["at_bound"] is not None):
                continue  # flagged: the report does not claim a number
            rows.append((f"j{j}.{name}", p["value"] - true[name], p["uncertainty"], p["standard_error"]))
        # The predicted steady-state friction, with the uncertainty propagated: the standard
        # errors through the correlation matrix, each systematic shift as the signed vector it is.
        free = [n for n in STATIC if params[n]["free"] and params[n]["standard_error"] is not None]
        corr = entry["fit"].get("correlation") or {}
        order = corr.get("parameters", [])
        if len(free) < 4 or any(a not in order for a in free):
            continue
        corr = corr["matrix"]
        truth_static = {k: true[k] for k in STATIC if k in true}
        if "tau_s" not in truth_static:  # Coulomb-viscous truth
            truth_static.update(tau_s=true["tau_c"], w_s=1.0)
        fitted = {k: params[k]["value"] for k in STATIC}
        for v in CURVE_SPEEDS:
            f, grad = steady_friction(fitted, v)
            ft, _ = steady_friction(truth_static, v)
            var = 0.0
            for a in free:
                for b in free:
                    r = corr[order.index(a)][order.index(b)]
                    if r is None:
                        r = 0.0
                    var += grad[a] * grad[b] * r * params[a]["standard_error"] * params[b]["standard_error"]
            se = math.sqrt(max(var, 0.0))
            total = var
            for part in ("discretization_shift", "velocity_noise_shift"):
                s = sum(grad[a] * (params[a].get(part) or 0.0) for a in free)
                total += s * s
            rows.append((f"j{j}.f@{v:g}", f - ft, math.sqrt(max(total, 0.0)), se))
    return rows


def dynfit_seed(args, truth, profile_path, profile, seed, work):
    log = os.path.join(work, f"dyn-{truth}-{seed}.csv")
    report = os.path.join(work, f"dyn-{truth}-{seed}.json")
    n = nice()
    cmd = (f"{n}{tool(args, 'mo-sim')} -q -p {profile_path} --trajectory excite --duration {args.dynfit_duration:g} --seed {seed} {args.sim_options} "
           f"-o {log} && {n}{tool(args, 'mo-dynfit')} -q -p {profile_path} --torque-held --seed {seed} {args.fit_options} {log} "
           f"--report {report}")
    fit = fitted_report(args, cmd, report, log, f"dynfit seed {seed} ({truth})")
    theta = standard_parameters(profile["urdf"])
    rows = []
    for k, base in enumerate(fit["base"]):
        true_value = 0.0
        for key, w in base["direction"].items():
            body, name = key.rsplit(".", 1)
            true_value += w * theta[body][name]
        # Base parameters are numbered by singular value (the report's order), largest first.
        rows.append((f"b{k + 1}", base["value"] - true_value, base["uncertainty"], base["standard_error"]))
    fr = fit.get("friction")
    sim = profile["simulation"].get("friction", {"model": "coulomb-viscous",
                                                 "joints": [{"tau_c": 0.0, "sigma2": 0.0}] * len(fr["coulomb"])})
    if fr and sim["model"] == "coulomb-viscous":
        for j, true in enumerate(sim["joints"]):
            for name, truth_name in (("coulomb", "tau_c"), ("viscous", "sigma2")):
                se = fr[f"{name}_se"][j]
                unc = fr.get(f"{name}_uncertainty", fr[f"{name}_se"])[j]  # older reports: SE only
                rows.append((f"j{j + 1}.{name}", fr[name][j] - true[truth_name], unc, se))
    return rows


FITTERS = {"lugre-fit": lugre_fit_seed, "dynfit": dynfit_seed}


def share(zs, k):
    return sum(1 for z in zs if abs(z) <= k) / len(zs) if zs else float("nan")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0] + " See the top of this file.",
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=20, help="number of seeds (default 20)")
    ap.add_argument("--seed", type=int, default=1, help="first seed (default 1)")
    ap.add_argument("--bin", default=os.path.join(SOURCE, "build", "bin"), help="the built tools")
    ap.add_argument("--work", help="working folder (default: a temporary one, removed)")
    ap.add_argument("--keep", action="store_true", help="keep the reports in the working folder")
    ap.add_argument("--jobs", type=int, default=1, help="seeds run at once (default 1)")
    ap.add_argument("--fitters", default="lugre-fit,dynfit", help="lugre-fit and/or dynfit (default both)")
    ap.add_argument("--truths", default="lugre,stribeck",
                    help="true friction models: lugre, stribeck, coulomb-viscous, none (default lugre,stribeck)")
    ap.add_argument("--dynfit-duration", type=float, default=60.0, help="mo-dynfit's log, s (default 60)")
    ap.add_argument("--sim-options", default="", help="more options for mo-sim (e.g. --velocity-noise 0)")
    ap.add_argument("--fit-options", default="", help="more options for the fitters")
    ap.add_argument("--per-parameter", action="store_true", help="the per-parameter table (default when --seeds >= 8)")
    ap.add_argument("--require", action="append", default=[], metavar="FITTER/TRUTH:K=SHARE",
                    help="exit 1 when the share within K uncertainties is below SHARE (0..1)")
    ap.add_argument("--json", help="write every z to FILE")
    args = ap.parse_args()
    fitters = [f for f in args.fitters.split(",") if f]
    truths = [t for t in args.truths.split(",") if t]
    for f in fitters:
        if f not in FITTERS:
            ap.error(f"unknown fitter '{f}'")
    work = args.work or tempfile.mkdtemp(prefix="coverage-fit.")
    os.makedirs(work, exist_ok=True)
    try:
        profiles = {t: truth_profile(t, work) for t in truths}
        jobs = [(f, t, args.seed + i) for f in fitters for t in truths for i in range(args.seeds)]
        results = {}
        with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
            futures = {pool.submit(FITTERS[f], args, t, *profiles[t], s, work): (f, t, s) for f, t, s in jobs}
            for fut in concurrent.futures.as_completed(futures):
                results[futures[fut]] = fut.result()
    finally:
        if not args.work:
            shutil.rmtree(work, ignore_errors=True)

    # Gather per fitter and truth, in seed order (reproducible).
    table = {}
    for f, t, s in jobs:
        for name, error, unc, se in results[(f, t, s)]:
            table.setdefault((f, t), []).append((name, s, error, unc, se))
    print(f"coverage over seeds {args.seed}..{args.seed + args.seeds - 1} "
          f"(Gaussian: 68.3 / 95.4 / 99.7%)")
    print(f"{'fitter':10} {'truth':16} {'pairs':>5}  {'uncertainty 1/2/3':>20}  {'SE alone 1/2/3':>20}  {'worst |z|':>9}")
    failed = False
    shares = {}
    for (f, t), rows in table.items():
        zu = [e / u if u and u > 0 else math.inf for _, _, e, u, _ in rows]
        zs = [e / se if se and se > 0 else math.inf for _, _, e, _, se in rows]
        shares[(f, t)] = {k: share(zu, k) for k in (1, 2, 3)}
        worst = max(abs(z) for z in zu)
        print(f"{f:10} {t:16} {len(rows):5}  "
              + " ".join(f"{100 * share(zu, k):6.1f}" for k in (1, 2, 3)) + "  "
              + " ".join(f"{100 * share(zs, k):6.1f}" for k in (1, 2, 3)) + f"  {worst:9.2f}")
    if args.per_parameter or args.seeds >= 8:
        for (f, t), rows in table.items():
            print(f"\n{f} on {t} truth: per parameter, z = (fitted - true) / uncertainty")
            print(f"  {'parameter':34} {'n':>3} {'mean z':>7} {'rms z':>7} {'worst z':>8} {'seed':>5}  "
                  f"{'mean err':>10} {'mean unc':>10}")
            names = []
            for name, *_ in rows:
                if name not in names:
                    names.append(name)
            for name in names:
                mine = [(s, e, u) for n, s, e, u, _ in rows if n == name]
                z = [(e / u, s) for s, e, u in mine]
                mean = sum(v for v, _ in z) / len(z)
                rms = math.sqrt(sum(v * v for v, _ in z) / len(z))
                wz, ws = max(z, key=lambda vs: abs(vs[0]))
                me = sum(e for _, e, _ in mine) / len(mine)
                mu = sum(u for _, _, u in mine) / len(mine)
                print(f"  {name:34} {len(z):3} {mean:7.2f} {rms:7.2f} {wz:8.2f} {ws:5}  {me:10.3g} {mu:10.3g}")
    for req in args.require:
        m = re.fullmatch(r"([\w-]+)/([\w-]+):([123])=([0-9.]+)", req)
        if not m:
            ap.error(f"cannot read --require '{req}'")
        key = (m.group(1), m.group(2))
        got = shares.get(key, {}).get(int(m.group(3)), float("nan"))
        ok = got >= float(m.group(4))
        print(f"require {req}: {100 * got:.1f}% {'ok' if ok else 'FAILED'}")
        failed = failed or not ok
    if args.json:
        with open(args.json, "w", encoding="utf-8") as out:
            json.dump({f"{f}/{t}": [{"parameter": n, "seed": s, "error": e, "uncertainty": u, "standard_error": se}
                                    for n, s, e, u, se in rows] for (f, t), rows in table.items()}, out, indent=1)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
