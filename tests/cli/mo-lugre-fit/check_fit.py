#!/usr/bin/env python3
"""Checks a mo-lugre-fit run on simulated data against the simulator's truth.

  check_fit.py TRUTH_PROFILE REPORT_JSON COMPENSATED_CSV --static-tolerance clean|noisy

TRUTH_PROFILE holds the true friction in simulation.friction (mo-sim's). REPORT_JSON is the
fit's --report. COMPENSATED_CSV is the observed log run through mo-observe with the fitted
profile: it has dq<j>, tau_f<j> (fitted friction) and tau_f_true<j> (mo-sim --with-truth-columns).

Per joint it prints one line per claim, "ok" or the reason it fails, and exits 1 on a failure:
  static     tau_c, tau_s, w_s, sigma2 within 2% of the truth (clean) or within three reported
             uncertainties of it (noisy)
  bristles   sigma0 and sigma1 within three uncertainties of the truth, or flagged (not
             identifiable, or on a bound)
  friction   the fitted friction matches the true friction, over the counted samples (faster
             than the report's min_speed, outside the settling time after slower ones), to the
             noise level: RMS difference below the fit's residual RMS plus 0.05 Nm (clean) or
             below 1.5 times the residual RMS (noisy)
"""
import csv
import json
import math
import re
import sys


def load_json_with_comments(path):
    text = open(path, encoding="utf-8").read()
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    text = re.sub(r"^\s*//.*$", "", text, flags=re.M)
    return json.loads(text)


def main():
    truth_path, report_path, csv_path = sys.argv[1:4]
    mode = sys.argv[sys.argv.index("--static-tolerance") + 1]
    truth = load_json_with_comments(truth_path)["simulation"]["friction"]["joints"]
    report = json.load(open(report_path, encoding="utf-8"))
    rows = [line for line in open(csv_path, encoding="utf-8") if not line.startswith("#")]
    reader = csv.reader(rows)
    header = next(reader)
    data = [[float(v) for v in row] for row in reader]
    col = {name: i for i, name in enumerate(header)}
    failed = False

    def claim(joint, what, problems):
        nonlocal failed
        if problems:
            failed = True
            print(f"joint {joint} {what}: " + "; ".join(problems))
        else:
            print(f"joint {joint} {what}: ok")

    for entry in report["joints"]:
        j = entry["joint"]
        true = truth[j - 1]
        fit = entry["fit"]
        params = fit["parameters"]
        problems = []
        for name in ("sigma2", "tau_c", "tau_s", "w_s"):
            p = params[name]
            error = abs(p["value"] - true[name])
            if mode == "clean":
                if error > 0.02 * true[name]:
                    problems.append(f"{name} {p['value']:.6g} is {100 * error / true[name]:.2f}% off {true[name]}")
            elif not (p["uncertainty"] is not None and error <= 3 * p["uncertainty"]):
                problems.append(f"{name} {p['value']:.6g} +- {p['uncertainty']} is {error:.3g} off {true[name]}")
        claim(j, "static", problems)

        problems = []
        for name in ("sigma0", "sigma1"):
            p = params[name]
            flagged = not p["identifiable"] or p["at_bound"] is not None
            error = abs(p["value"] - true[name])
            if not flagged and not (p["uncertainty"] is not None and error <= 3 * p["uncertainty"]):
                problems.append(f"{name} {p['value']:.6g} +- {p['uncertainty']} is {error:.3g} off {true[name]} and not flagged")
        claim(j, "bristles", problems)

        # Counted samples as the fitter chose them: speed above min_speed, and not within the
        # observer's settling time (3 / K1) after a slower sample.
        settle = 3.0 / entry["observer_gains"]["k1"]
        min_speed = entry["min_speed"] or 0.0
        last_slow = -math.inf
        total, count = 0.0, 0
        for row in data:
            t, dq = row[col["t"]], row[col[f"dq{j}"]]
            if abs(dq) < min_speed:
                last_slow = t
            if t - last_slow <= settle:
                continue
            d = row[col[f"tau_f{j}"]] - row[col[f"tau_f_true{j}"]]
            total += d * d
            count += 1
        rms = math.sqrt(total / count)
        fit_rms = fit["metrics"]["rms"]
        limit = fit_rms + 0.05 if mode == "clean" else 1.5 * fit_rms
        claim(j, "friction", [] if rms <= limit else [f"rms {rms:.4g} Nm against the truth, limit {limit:.4g} Nm"])
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
