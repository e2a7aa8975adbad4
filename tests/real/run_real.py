#!/usr/bin/env python3
"""The real UR10e development set, end to end, as a new user runs it (README, "A real robot").

Identify friction on the collision-free log (mo-lugre-fit), then for each log with pushes:
calibrate (mo-calibrate) on data that exclude that log -- the collision-free log and the stretches
of the *other* push log that lie away from its marked contacts (from 1 s after a marked end to
0.5 s before the next onset) -- and detect (mo-detect) on the whole log. Score against the marks:
a contact is detected when an event's t_detect lies in [onset - 0.5 s, end + 2 s]; an event
outside every such window is a false alarm; the delay is t_detect - onset of the first event in
the window.

  run_real.py --bin BUILD/bin --data tests/data/real-ur10e --work DIR [--check]

With --check: exit 1 unless every contact is detected, no event is a false alarm and the median
delay is under 150 ms (issue: real robots).
"""
import argparse, csv, os, statistics, subprocess, sys

BEFORE, AFTER, SETTLE = 0.5, 2.0, 1.0
FIT_OPTIONS = []  # the search box comes from the robot and the data (mo-lugre-fit(1))


def read_rows(path):
    with open(path) as f:
        lines = [l for l in f if not l.startswith("#")]
    return lines[0], lines[1:]


def marks(path):
    with open(path) as f:
        return [tuple(map(float, r)) for r in list(csv.reader(f))[1:]]


def cut(log, keep, out):
    """Writes the rows of `log` whose time satisfies keep(t) as separate streams (one per run)."""
    header, rows = read_rows(log)
    pieces, current = [], []
    for r in rows:
        if keep(float(r.split(",", 1)[0])):
            current.append(r)
        elif current:
            pieces.append(current)
            current = []
    if current:
        pieces.append(current)
    paths = []
    for k, piece in enumerate(pieces):
        if len(piece) < 100:  # under a second: nothing to calibrate on
            continue
        p = f"{out}-{k}.csv"
        with open(p, "w") as f:
            f.write(header)
            f.writelines(piece)
        paths.append(p)
    return paths


def contact_free(intervals):
    return lambda t: all(not (a - BEFORE <= t <= b + SETTLE) for a, b in intervals)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", required=True)
    ap.add_argument("--data", required=True)
    ap.add_argument("--work", required=True)
    ap.add_argument("--check", action="store_true")
    a = ap.parse_args()
    tool = lambda name: os.path.join(a.bin, name)
    os.makedirs(a.work, exist_ok=True)
    w = lambda name: os.path.join(a.work, name)
    profile = os.path.join(a.data, "profile.json")
    free = os.path.join(a.data, "logs", "no_torque.csv")
    pushed = {"ur-static": None, "link4": None}
    for name in pushed:
        pushed[name] = marks(os.path.join(a.data, "truth", f"{name}.truth.csv"))

    # Friction from the collision-free log, through the profile's observer.
    with open(w("free.obs.csv"), "w") as f:
        subprocess.run([tool("mo-observe"), "-q", "-p", profile, free], stdout=f, check=True)
    fit = subprocess.run([tool("mo-lugre-fit"), "-q", "-p", profile, "--skip", "0.1", "-o", w("fitted.json")] + FIT_OPTIONS + [
                          w("free.obs.csv")], capture_output=True, text=True)
    if fit.returncode != 0:
        sys.exit(f"run_real: mo-lugre-fit failed:\n{fit.stderr}")

    table, delays, ok = [], [], True
    for name, intervals in pushed.items():
        others = [o for o in pushed if o != name]
        streams = [free]
        for o in others:
            streams += cut(os.path.join(a.data, "logs", f"{o}.csv"), contact_free(pushed[o]), w(f"cal-{o}"))
        observed = []
        for s in streams:
            out = w(os.path.basename(s).replace(".csv", ".cal.obs.csv"))
            with open(out, "w") as f:
                subprocess.run([tool("mo-observe"), "-q", "-p", w("fitted.json"), s], stdout=f, check=True)
            observed.append(out)
        calibrated = w(f"calibrated-for-{name}.json")
        cal = subprocess.run([tool("mo-calibrate"), "-p", w("fitted.json"), "-o", calibrated, "--skip", "0.1"] + observed,
                             capture_output=True, text=True)
        if cal.returncode != 0:
            sys.exit(f"run_real: mo-calibrate failed:\n{cal.stderr}")
        with open(w(f"calibration-for-{name}.txt"), "w") as f:
            f.write(cal.stdout + cal.stderr)
        log = os.path.join(a.data, "logs", f"{name}.csv")
        with open(w(f"{name}.obs.csv"), "w") as f:
            subprocess.run([tool("mo-observe"), "-q", "-p", calibrated, log], stdout=f, check=True)
        det = subprocess.run([tool("mo-detect"), "-q", "-p", calibrated, "--skip", "0.1", w(f"{name}.obs.csv")],
                             capture_output=True, text=True)
        if det.returncode not in (0, 1):
            sys.exit(f"run_real: mo-detect failed:\n{det.stderr}")
        with open(w(f"{name}.events.csv"), "w") as f:
            f.write(det.stdout)
        onsets = [r for r in csv.DictReader(l for l in det.stdout.splitlines() if not l.startswith("#"))
                  if r["kind"] == "onset"]
        found, false_alarms, log_delays = 0, 0, []
        for onset, end in intervals:
            inside = [float(e["t_detect"]) for e in onsets if onset - BEFORE <= float(e["t_detect"]) <= end + AFTER]
            if inside:
                found += 1
                log_delays.append(min(inside) - onset)
        for e in onsets:
            t = float(e["t_detect"])
            if not any(a0 - BEFORE <= t <= b0 + AFTER for a0, b0 in intervals):
                false_alarms += 1
        delays += log_delays
        table.append((name, len(intervals), found, false_alarms, len(onsets), log_delays))
        ok = ok and found == len(intervals) and false_alarms == 0

    print(f"{'log':<10} {'contacts':>8} {'detected':>8} {'false':>6} {'events':>6}  delays (ms)")
    for name, n, found, fa, events, d in table:
        print(f"{name:<10} {n:>8} {found:>8} {fa:>6} {events:>6}  {' '.join(f'{1000 * x:.0f}' for x in d)}")
    median = statistics.median(delays) if delays else float("nan")
    print(f"median delay {1000 * median:.0f} ms over {len(delays)} detected contacts")
    ok = ok and median < 0.150
    if a.check and not ok:
        print("run_real: FAILED: every contact detected, no false alarm, median delay under 150 ms", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
