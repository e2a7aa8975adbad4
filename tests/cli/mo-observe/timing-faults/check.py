#!/usr/bin/env python3
"""Timing faults must not change the residual: a simulated log of the paper arm (mo-sim, 125 Hz,
sensor noise, LuGre friction, no contact) is observed clean and again with lost samples (mo-sim
--drop-rate), sampling jitter (--time-jitter), exact duplicate rows and rows written early
(edited in here). The reference is the clean log's residual; the tolerance is the noise level,
measured as the RMS difference between the residuals of the same log with and without sensor
noise. Prints the checks; the numbers go to stderr."""
import os
import subprocess
import sys

SRC = os.environ["SRC"]
PROFILE = f"{SRC}/share/momentum/robots/paper-arm/paper-arm.json"
SIM = ["mo-sim", "-q", "-p", PROFILE, "--duration", "12", "--rate", "125", "--seed", "11"]
OBSERVE = ["mo-observe", "-p", PROFILE, "--restart-column"]


def run(args, stdin=None, status=0):
    p = subprocess.run(args, input=stdin, capture_output=True, text=True)
    if p.returncode != status:
        sys.exit(f"{' '.join(args)}: exit {p.returncode}: {p.stderr}")
    return p.stdout, p.stderr


def table(text):
    lines = [l for l in text.splitlines() if l and not l.startswith("#")]
    header = lines[0].split(",")
    return header, [[float(x) for x in l.split(",")] for l in lines[1:]]


def observe(text, status=0):
    """Status 1 when rows out of time order were skipped (the rest is observed all the same)."""
    out, err = run(OBSERVE, text, status)
    header, rows = table(out)
    t, restart = header.index("t"), header.index("restart")
    r = [header.index(f"r{j}") for j in (1, 2, 3)]
    return [(row[t], [row[c] for c in r], row[restart]) for row in rows], err


def interpolate(series, t):
    """The clean residual at time t, linear between its samples (bisection)."""
    lo, hi = 0, len(series) - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if series[mid][0] <= t:
            lo = mid
        else:
            hi = mid
    (t0, r0, _), (t1, r1, _) = series[lo], series[hi]
    w = (t - t0) / (t1 - t0)
    return [a + w * (b - a) for a, b in zip(r0, r1)]


clean_text, _ = run(SIM)
noiseless_text, _ = run(SIM + ["--current-noise", "0", "--velocity-noise", "0", "--encoder-bits", "0"])
jitter_text, _ = run(SIM + ["--time-jitter", "0.0008"])
faulty_text, _ = run(SIM + ["--drop-rate", "0.05", "--time-jitter", "0.0008"])

# Edit the faulty log: every 97th data row is written twice, every 89th row is written early
# (moved before the two rows it overtakes).
lines = faulty_text.splitlines()
body_start = next(i for i, l in enumerate(lines) if not l.startswith("#")) + 1
head, body = lines[:body_start], lines[body_start:]
edited, duplicates, early = [], 0, 0
k = 0
while k < len(body):
    if k % 89 == 50 and k + 2 < len(body):
        edited += [body[k + 2], body[k], body[k + 1]]
        early += 1
        k += 3
        continue
    edited.append(body[k])
    if k % 97 == 30:
        edited.append(body[k])
        duplicates += 1
    k += 1
faulty_text = "\n".join(head + edited) + "\n"

clean, _ = observe(clean_text)
noiseless, _ = observe(noiseless_text)
jittered, _ = observe(jitter_text)
faulty, faulty_err = observe(faulty_text, status=1)

# Noise level per joint: RMS of the residual's change when the sensor noise is removed.
noise = [(sum((a[1][j] - b[1][j]) ** 2 for a, b in zip(clean, noiseless)) / len(clean)) ** 0.5
         for j in range(3)]
print(f"noise level (rms) r1..r3: {' '.join(f'{x:.3g}' for x in noise)}", file=sys.stderr)


def compare(series, name, settle):
    """|r - r_clean| over rows at least `settle` s after any fault (a gap > 1.5 periods; skipped
    rows make gaps too) and after the first second: its largest value and RMS relative to the
    noise level, per joint the worst; also the largest anywhere (faults included); restarts."""
    worst, square, used, last_fault = [0.0] * 3, [0.0] * 3, 0, -1.0
    anywhere = [0.0] * 3
    previous_t = None
    for t, r, restart in series:
        if previous_t is not None and t - previous_t > 1.5 / 125:
            last_fault = t
        previous_t = t
        if restart or t < 1.0:
            continue
        ref = interpolate(clean, t)
        anywhere = [max(w, abs(a - b)) for w, a, b in zip(anywhere, r, ref)]
        if t - last_fault < settle:
            continue
        used += 1
        worst = [max(w, abs(a - b)) for w, a, b in zip(worst, r, ref)]
        square = [s + (a - b) ** 2 for s, a, b in zip(square, r, ref)]
    restarts = sum(1 for _, _, restart in series[1:] if restart)
    peak = max(w / n for w, n in zip(worst, noise))
    rms = max((s / used) ** 0.5 / n for s, n in zip(square, noise))
    near = max(w / n for w, n in zip(anywhere, noise))
    print(f"{name}: {used} rows compared, worst |r - r_clean| {' '.join(f'{x:.3g}' for x in worst)} Nm: "
          f"peak {peak:.2f}, rms {rms:.2f}, peak near faults {near:.2f} x noise; restarts {restarts}",
          file=sys.stderr)
    return peak, rms, near, restarts


# "Within the noise": the difference's RMS below half the noise level and its peak below three
# times it (the noise band); near the faults, no spike: below five times it.
peak, rms, near, restarts = compare(jittered, "jitter", 0.0)
print(f"jitter only: within noise everywhere: {'yes' if rms <= 0.5 and peak <= 3 else 'NO'}; "
      f"restarts: {restarts}")
peak, rms, near, restarts = compare(faulty, "faults", 0.1)
print(f"drops, jitter, early and duplicate rows: within noise 0.1 s after a fault: "
      f"{'yes' if rms <= 0.5 and peak <= 3 else 'NO'}; no spike at the faults: "
      f"{'yes' if near <= 5 else 'NO'}; restarts: {restarts}")
# Skipped rows: exactly the duplicates and the early rows (not the rows they overtook).
skipped = next((l for l in faulty_err.splitlines() if "bad rows skipped:" in l), "")
expected = f"{duplicates + early} bad rows skipped: {duplicates} duplicate row, {early} time out of order"
print(f"skipped rows counted: {'yes' if expected in skipped else 'NO: ' + skipped}")
bridged = next((l for l in faulty_err.splitlines() if "bridged without a restart" in l), "")
print(f"gaps bridged: {'yes' if bridged else 'NO'}", file=sys.stdout)
print(bridged, file=sys.stderr)
