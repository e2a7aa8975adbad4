#!/usr/bin/env python3
"""From a log to a plot with momentum's Python package (pip install ./python).

    log_to_plot.py PROFILE LOG OUTPUT [--threshold NM] [--signal mu|r]

Observes the log (mo-observe's residuals), detects collisions with the profile's thresholds
(mo-detect; --threshold for constant ones when the profile has none) and plots each joint's
residual against time with its threshold and the events, to OUTPUT (PNG, SVG or PDF by its
suffix). Without matplotlib, or with --numbers, it writes the numbers instead: the residual
columns as a CSV stream at OUTPUT with the suffix .csv. Either way it prints one line per
event: its number, the detection time, the isolated link and the joints that fired.

Example (the paper arm, simulated; mo-sim and mo-calibrate come with the tools):
    mo-sim -p paper-arm.json --seed 5 --collisions 4 --duration 20 -o hits.csv
    log_to_plot.py calibrated.json hits.csv hits.png
"""
import argparse
import pathlib
import sys

import numpy as np

import momentum


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("profile")
    parser.add_argument("log")
    parser.add_argument("output")
    parser.add_argument("--threshold", type=float, help="constant threshold, Nm (default: the profile's)")
    parser.add_argument("--signal", choices=("mu", "r"), help="residual judged (default: mu when there is one)")
    parser.add_argument("--numbers", action="store_true", help="write the numbers, not a plot")
    args = parser.parse_args(argv)

    profile = momentum.Profile(args.profile)
    observed = momentum.observe(profile, momentum.read(args.log))
    signal = args.signal or ("mu" if "mu1" in observed.columns else "r")
    events = momentum.detect(profile, observed, signal=signal, threshold=args.threshold)
    onsets = [e for e in events if e["kind"] == "onset"]
    for e in onsets:
        joints = ",".join(map(str, e["joints"]))
        print(f"event {e['event']}: t = {e['t_detect']:.3f} s, link {e['link']}, joints {joints}")
    print(f"{len(onsets)} event{'' if len(onsets) == 1 else 's'} in {observed.rows} rows")

    names = [f"{signal}{j}" for j in range(1, profile.joints + 1)]
    try:
        if args.numbers:
            raise ImportError("--numbers")
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        output = pathlib.Path(args.output).with_suffix(".csv")
        momentum.write(output, {"t": observed["t"], **{n: observed[n] for n in names}})
        print(f"numbers written to {output}")
        return 0

    thresholds = profile.thresholds(signal)
    figure, axes = plt.subplots(len(names), 1, sharex=True, figsize=(9, 2.2 * len(names)))
    for j, (ax, name) in enumerate(zip(np.atleast_1d(axes), names)):
        ax.plot(observed["t"], observed[name], lw=0.6, label=name)
        level = args.threshold if args.threshold is not None else (
            thresholds["joints"][j]["moving"] if thresholds else None)
        if level is not None:
            ax.axhline(level, color="tab:red", lw=0.8, ls="--")
            ax.axhline(-level, color="tab:red", lw=0.8, ls="--")
        for e in onsets:
            ax.axvline(e["t_detect"], color="tab:orange", lw=0.8)
        ax.set_ylabel(f"{name} (Nm)")
    np.atleast_1d(axes)[-1].set_xlabel("t (s)")
    figure.suptitle(f"{pathlib.Path(args.log).name}: {len(onsets)} events")
    figure.tight_layout()
    figure.savefig(args.output)
    print(f"plot written to {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
