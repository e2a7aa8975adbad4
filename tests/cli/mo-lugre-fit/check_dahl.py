#!/usr/bin/env python3
"""Checks a Dahl fit (mo-lugre-fit --model dahl) on simulated data against the simulator's truth.

  check_dahl.py TRUTH_PROFILE REPORT_JSON FITTED_PROFILE

TRUTH_PROFILE holds the true Dahl friction in simulation.friction (dahl_profile.py writes it),
REPORT_JSON is the fit's --report, FITTED_PROFILE the profile it wrote. Per joint, one line per
claim, "ok" or the reason it fails; exits 1 on a failure:
  model      the report and the fitted profile say "dahl", with the Dahl parameters only
  sliding    sigma2 and tau_c within three reported uncertainties of the truth, and that
             uncertainty under 2% of the truth (the data determine them)
  bristles   sigma0 within three uncertainties of the truth, or flagged (not identifiable, or on
             a bound: the bristles settle within microradians, faster than the sampling)
"""
import json
import re
import sys


def load(path):
    text = open(path, encoding="utf-8").read()
    return json.loads(re.sub(r"^\s*//.*$", "", text, flags=re.M))


def main():
    truth = load(sys.argv[1])["simulation"]["friction"]["joints"]
    report = json.load(open(sys.argv[2], encoding="utf-8"))
    fitted = load(sys.argv[3])["friction"]
    failed = False

    def claim(joint, what, problems):
        nonlocal failed
        failed = failed or bool(problems)
        print(f"joint {joint} {what}: " + ("; ".join(problems) if problems else "ok"))

    for entry in report["joints"]:
        j = entry["joint"]
        true = truth[j - 1]
        params = entry["fit"]["parameters"]
        problems = []
        if report["model"] != "dahl" or fitted["model"] != "dahl":
            problems.append(f"model {report['model']} / {fitted['model']}")
        written = set(fitted["joints"][j - 1]) - {"covariance"}
        if written != {"sigma0", "sigma2", "tau_c"}:
            problems.append(f"profile joint holds {sorted(written)}")
        claim(j, "model", problems)

        problems = []
        for name in ("sigma2", "tau_c"):
            p = params[name]
            error = abs(p["value"] - true[name])
            if not (p["uncertainty"] is not None and error <= 3 * p["uncertainty"]):
                problems.append(f"{name} {p['value']:.6g} +- {p['uncertainty']} is {error:.3g} off {true[name]}")
            elif p["uncertainty"] > 0.02 * true[name]:
                problems.append(f"{name} uncertainty {p['uncertainty']:.3g} is over 2% of {true[name]}")
        claim(j, "sliding", problems)

        p = params["sigma0"]
        flagged = not p["identifiable"] or p["at_bound"] is not None
        error = abs(p["value"] - true["sigma0"])
        ok = flagged or (p["uncertainty"] is not None and error <= 3 * p["uncertainty"])
        claim(j, "bristles", [] if ok else [f"sigma0 {p['value']:.6g} +- {p['uncertainty']} is {error:.3g} off and not flagged"])
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
