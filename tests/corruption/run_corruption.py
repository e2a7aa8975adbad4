#!/usr/bin/env python3
"""Corruption test: one fault at a time in good logs, and every tool must give the clean output
except the rows next to the fault, with the same collision events.

Good logs: a simulated run of the paper arm with collisions (mo-sim, seeded) as CSV, the same
as binary (mo-cat --output-format bin), and the drives' frames as a candump capture
(mo-sim --candump). Faults, one at a time, in the middle of the log: a corrupt future time, a
corrupt past time, a clock step back by 10 s (the rest of the log continues from the new time),
a NaN time, a truncated binary record (the end of the file), a UTF-8 byte order mark, a garbage
line (with NUL and binary bytes), a missing newline at the end.

Tools: mo-cat --repair, mo-observe, mo-detect (events), mo-calibrate -n (thresholds), and for
the capture mo-can2csv (then mo-observe and mo-detect). Rows are matched by their index in the
clean log; the rows allowed to differ are the faulty row and its neighbours (one each side) and,
for the observer its settling time: 0.2 s after a missing row, then residuals within 1 mNm
(it integrated over the longer step); 0.5 s after a restart (at a clock step, which the physics
needs, or an incomplete cycle of a capture), then within 0.5 Nm, a twelfth of the detection
threshold (r starts again from 0 and converges slowly). Times after a clock step are compared with
the step added back. Events must be the same (times mapped the same way), and thresholds within
0.5%. The table printed at the end gives, per log and fault, the rows that differ per tool.

Then the blind classes of issue 26 (run_blind_classes, below): a clock step back past the log's
start, a NaN span and a stopped (cut) input in each log kind, with mo-detect's events on the
good rows the same as on the clean log, and each fault reported as a blind span.

usage: run_corruption.py --bin BUILD/tools --source SRC
"""
import argparse
import math
import os
import shutil
import subprocess
import sys
import tempfile

FAULT_ROW = 700      # data row (0-based) the fault is put at
STEP = -3.0          # clock step, s (the capture's times stay positive)
SETTLE_S = 1.0       # observer settling time after a restart, s
RATE = 125


def run(cmd, stdin=None, env=None, ok=(0, 1)):
    proc = subprocess.run(cmd, shell=True, input=stdin, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    if proc.returncode not in ok:
        raise RuntimeError(f"{cmd}: exit {proc.returncode}\n{proc.stderr.decode(errors='replace')[-2000:]}")
    return proc.stdout, proc.stderr.decode(errors="replace"), proc.returncode


def parse_csv(data):
    """(header, rows as lists of floats) of a CSV stream; comments dropped."""
    header, rows = None, []
    for line in data.decode(errors="replace").splitlines():
        if not line or line.startswith("#"):
            continue
        if header is None:
            header = line.split(",")
            continue
        rows.append([float(x) for x in line.split(",")])
    return header, rows


def parse_events(data):
    lines = [l for l in data.decode().splitlines() if l and not l.startswith("#")]
    header = lines[0].split(",")
    return header, [l.split(",") for l in lines[1:]]


class Fault:
    def __init__(self, name, logs):
        self.name = name
        self.logs = logs  # which of csv, bin, candump it applies to


FAULTS = [
    Fault("future time", ("csv", "bin", "candump")),
    Fault("past time", ("csv", "bin", "candump")),
    Fault("clock step", ("csv", "bin", "candump")),
    Fault("NaN time", ("csv", "bin")),
    Fault("truncated record", ("bin",)),
    Fault("BOM", ("csv", "candump")),
    Fault("garbage line", ("csv", "candump")),
    Fault("no final newline", ("csv", "candump")),
]


def corrupt_csv(text, fault):
    """The CSV log with the fault, and the clean data rows it touches (indices)."""
    lines = text.split("\n")
    first = next(i for i, l in enumerate(lines) if l and not l.startswith("#")) + 1  # first data line
    k = first + FAULT_ROW
    touched = {FAULT_ROW}
    fields = lines[k].split(",")
    if fault == "future time":
        fields[0] = "1e9"
        lines[k] = ",".join(fields)
    elif fault == "past time":
        fields[0] = "0.5"
        lines[k] = ",".join(fields)
    elif fault == "NaN time":
        fields[0] = "nan"
        lines[k] = ",".join(fields)
    elif fault == "clock step":
        for i in range(k, len(lines)):
            if lines[i] and not lines[i].startswith("#"):
                f = lines[i].split(",")
                f[0] = repr(float(f[0]) + STEP)
                lines[i] = ",".join(f)
        touched = set()
    elif fault == "BOM":
        lines[0] = "\ufeff" + lines[0]
        touched = set()
    elif fault == "garbage line":
        lines.insert(k, "garb\x00age\x01\udcff,,,")
        touched = set()
    elif fault == "no final newline":
        while lines and lines[-1] == "":
            lines.pop()
        return "\n".join(lines), set()
    return "\n".join(lines), touched


def corrupt_candump(text, fault):
    """The capture with the fault, and the approximate clean row it touches."""
    lines = text.split("\n")
    frames = [i for i, l in enumerate(lines) if l.startswith("(")]
    per_row = max(1, len(frames) // max(1, ROWS))
    k = frames[min(len(frames) - 1, FAULT_ROW * per_row + 1)]
    touched = {FAULT_ROW - 1, FAULT_ROW, FAULT_ROW + 1}
    stamp_end = lines[k].index(")")
    stamp = float(lines[k][1:stamp_end])
    if fault == "future time":
        lines[k] = "(1000000000.000000" + lines[k][stamp_end:]
    elif fault == "past time":
        lines[k] = "(%.6f" % (stamp - 1000.0) + lines[k][stamp_end:]
    elif fault == "clock step":
        for i in frames:
            if i >= k:
                e = lines[i].index(")")
                lines[i] = "(%.6f" % (float(lines[i][1:e]) + STEP) + lines[i][e:]
    elif fault == "BOM":
        lines[0] = "\ufeff" + lines[0]
        touched = set()
    elif fault == "garbage line":
        lines.insert(k, "garb\x00age\x01\udcff")
        touched = set()
    elif fault == "no final newline":
        while lines and lines[-1] == "":
            lines.pop()
        return "\n".join(lines), set()
    return "\n".join(lines), touched


ROWS = 0


def compare_streams(clean, dirty, touched, fault, settle_rows, tolerance, time_col="t"):
    """Rows of `clean` that `dirty` does not reproduce, outside the allowed ones; and the count
    of rows that differ at all."""
    header, rows = clean
    dheader, drows = dirty
    if header != dheader:
        return [f"header differs: {dheader[:5]}..."], 0
    it = header.index(time_col)
    shift = STEP if fault == "clock step" else 0.0
    start = FAULT_ROW if fault == "clock step" else None
    # Map clean rows to their expected times in the dirty output.
    def expected_time(i):
        return rows[i][it] + (shift if start is not None and i >= start else 0.0)
    # Rows after a clock step are looked up among the rows after it (their times repeat
    # earlier ones); others among all rows.
    step_at = next((j for j in range(1, len(drows)) if drows[j][it] < drows[j - 1][it]), len(drows))
    before, after = {}, {}
    for j, r in enumerate(drows):
        (after if j >= step_at else before).setdefault(round(r[it], 6), r)
    allowed = set()
    for k in touched:
        allowed |= set(range(k - 1, k + 2 + settle_rows))
    if fault == "clock step":
        allowed |= set(range(FAULT_ROW - 1, FAULT_ROW + settle_rows))
    if fault == "truncated record":
        allowed |= {len(rows) - 1}
    problems, differing = [], 0
    for i, row in enumerate(rows):
        got = (after if start is not None and i >= start else before).get(round(expected_time(i), 6))
        same = got is not None and all(
            (math.isnan(a) and math.isnan(b)) or abs(a - b) <= tolerance + 1e-12 * abs(a)
            for j, (a, b) in enumerate(zip(row, got)) if j != it)
        if not same:
            differing += 1
            if i not in allowed:
                problems.append(f"row {i} (t={row[it]}) {'missing' if got is None else 'differs'}")
    extra = len(drows) - (len(rows) - differing)
    if extra > len(allowed) + 2:
        problems.append(f"{extra} rows that the clean log does not have")
    return problems[:3], differing


def split_at_clock_step(clean, dirty):
    """At a clock step the detector starts again as on a new log (mo-detect(1)): an event open
    at the step ends on the last row before it (ended_by clock_step) and, the residual still over
    the threshold, a new one opens after it. Returns the clean and dirty events with each such
    pair checked and replaced by the one clean event (its onset row, and the end row of the part
    after the step), and the problems found."""
    h, rows = clean
    dh, drows = dirty
    if h != dh or not any(r[h.index("ended_by")] == "clock_step" for r in drows):
        return clean, dirty, []
    kind, ended, t_end = h.index("kind"), h.index("ended_by"), h.index("t_end")
    out, problems, i = [], [], 0
    while i < len(drows):
        r = drows[i]
        if r[kind] == "end" and r[ended] == "clock_step":
            # The onset of the part after the step, and its end: the clean event's end.
            nxt = [k for k in range(i + 1, len(drows)) if drows[k][kind] == "end"]
            if not nxt:
                problems.append("no event after the clock step")
                break
            end = list(drows[nxt[0]])
            out.append(end)
            i = nxt[0] + 1
            continue
        out.append(r)
        i += 1
    # Event numbers shift by one per split: compare them by order instead. An end row's link,
    # joints and peaks cover only the part after the step, and its onset times are the new
    # part's: compare its t_end (and the onset rows in full).
    blank = [h.index("event")] + [j for j, name in enumerate(h)
                                  if name.startswith("peak") or name in ("link", "joints", "t_onset_estimate", "t_detect")]
    for rows_ in (rows, out):
        for r in rows_:
            for j in blank if r[kind] == "end" else [h.index("event")]:
                r[j] = ""
    return (h, rows), (dh, out), problems


def compare_events(clean, dirty, fault):
    problems_split = []
    if fault == "clock step":
        clean, dirty, problems_split = split_at_clock_step(clean, dirty)
        if problems_split:
            return problems_split
    h, rows = clean
    dh, drows = dirty
    if h != dh or len(rows) != len(drows):
        return [f"{len(drows)} events, clean {len(rows)}"]
    # Times after a clock step come back with the step; compare with it added back.
    times = [i for i, name in enumerate(h) if name.startswith("t_")]
    problems = []
    step_at = CLEAN_T[FAULT_ROW] if fault == "clock step" else None
    for a, b in zip(rows, drows):
        for j, (x, y) in enumerate(zip(a, b)):
            if j in times and x and y:
                fx, fy = float(x), float(y)
                if step_at is not None and fx >= step_at:
                    fy -= STEP
                if abs(fx - fy) > 1.01 / RATE:  # the same sample, or the next one
                    problems.append(f"event {a[h.index('event')]}: {h[j]} {y} instead of {x}")
            elif h[j].startswith("peak") and x and y:
                if abs(float(x) - float(y)) > 0.01 * abs(float(x)):
                    problems.append(f"event {a[h.index('event')]}: {h[j]} {y} instead of {x}")
            elif x != y and h[j] != "ended_by":
                problems.append(f"event {a[h.index('event')]}: {h[j]} {y} instead of {x}")
    return problems[:3]


def thresholds(report):
    out = {}
    for line in report.decode().splitlines():
        parts = line.split()
        if len(parts) >= 3 and parts[0] in ("r1", "r2", "r3", "r4", "r5", "r6", "r") or line.startswith("threshold"):
            out[line.split()[0]] = line
    return out


# ---- Blind classes (issue 26): mo-detect must say where it could not judge -----------------
#
# Three faults that leave the detector unable to judge for a while, in each log kind: a clock
# step back past the log's start (a controller clock reset: the rows before the fault ran 100 s
# ahead), a NaN span (the residuals of a CSV or binary stream, or a drive's frames missing from
# a capture, which mo-can2csv writes as nan) and a stopped input (the file cut in the middle of
# a row). mo-detect runs on the residual streams directly (so that the faults reach it as they
# are), and on the capture through mo-can2csv and mo-observe. Required: the events of the good
# rows the same as on the clean log (times after a step mapped back), none lost after a clock
# step (before, the start-up skip was measured from the first log's first time, and nothing
# after the step was detected), and each fault reported on standard error as a blind span with
# its times.

BLIND_THRESHOLD = "--signal r --threshold 16"  # r carries the unmodelled friction (up to 15 Nm)
BLIND_SKIP = 0.5                               # mo-detect --skip, s
BLIND_SHIFT = 100.0                            # the first log's clock ran this far ahead, s
BLIND_STEP_ROW = 375                           # rows (0-based) at 125 Hz: t = 3 s
BLIND_NAN_ROWS = (500, 560)                    # t = 4 to 4.48 s
BLIND_CUT_ROW = 1250                           # t = 10 s
BLIND_SETTLE = 1.0                             # observer settling after a restart (capture), s


def blind_events(data):
    """Event rows (lists of fields) of mo-detect's CSV."""
    return parse_events(data)


def blind_expected(clean_rows, header, window, cut=None):
    """The clean events that the fault cannot touch: none overlapping `window` (t0, t1), and with
    a cut, those ended before it."""
    it_on, it_end = header.index("t_onset_estimate"), header.index("t_end")
    ids = header.index("event")
    spans = {}
    for r in clean_rows:
        spans.setdefault(r[ids], [float(r[it_on]), None])
        if r[header.index("kind")] == "end":
            spans[r[ids]][1] = float(r[it_end])
    keep = []
    for r in clean_rows:
        t0, t1 = spans[r[ids]]
        if t1 is not None and window and t1 >= window[0] - 0.2 and t0 <= window[1] + 0.2:
            continue
        if cut is not None and (t1 is None or t1 >= cut - 0.2):
            continue
        keep.append(r)
    return keep


def blind_compare(header, expected, got, shift_before=None, restarted=False):
    """Problems between the expected clean events and those got (times before `shift_before`,
    on the clean time line, come back shifted by BLIND_SHIFT); event numbers may differ.
    `restarted`: the observer started again before these events (a capture's clock step or
    drive dropout), and its residuals are not the clean ones for seconds after (measured on
    the paper arm's capture, 3 s after the restart: peaks 4 to 12% off, releases 0.06 to
    0.08 s off, a joint more or less crossing): the same events are then the same detections
    (count, link, t_detect within two samples, onset estimate within 0.05 s); joints, peaks
    and t_end are not compared."""
    if len(expected) != len(got):
        return [f"{len(got)} event rows, expected {len(expected)}: " + "; ".join(",".join(r[:8]) for r in got)]
    problems = []
    for a, b in zip(expected, got):
        for j, name in enumerate(header):
            if name in ("event", "ended_by"):
                continue
            if restarted and (name in ("joints", "t_end") or name.startswith("peak")):
                continue
            x, y = a[j], b[j]
            if name.startswith("t_") and x and y:
                fy = float(y)
                if shift_before is not None and float(x) < shift_before:
                    fy -= BLIND_SHIFT
                limit = 1.01 / RATE
                if restarted:
                    limit = 0.05 if name == "t_onset_estimate" else 2.01 / RATE
                if abs(float(x) - fy) > limit:
                    problems.append(f"{name} {y} instead of {x}")
            elif name.startswith("peak") and x and y:
                if abs(float(x) - float(y)) > (0.1 if restarted else 0.01) * abs(float(x)):
                    problems.append(f"{name} {y} instead of {x}")
            elif x != y:
                problems.append(f"{name} {y} instead of {x}")
    return problems[:3]


def blind_csv_fault(text, fault):
    """A residual CSV stream with a blind fault; returns (text, window of clean times, cut time)."""
    lines = text.split("\n")
    data = [i for i, l in enumerate(lines) if l and not l.startswith("#")][1:]
    header = lines[data[0] - 1].split(",") if not lines[data[0] - 1].startswith("#") else None
    times = [float(lines[i].split(",")[0]) for i in data]
    if fault == "clock step back":
        for i in data[:BLIND_STEP_ROW]:
            f = lines[i].split(",")
            f[0] = repr(float(f[0]) + BLIND_SHIFT)
            lines[i] = ",".join(f)
        t = times[BLIND_STEP_ROW]
        return "\n".join(lines), (t, t + BLIND_SKIP), None, (t, t + BLIND_SKIP)
    if fault == "NaN span":
        cols = [j for j, name in enumerate(header) if name.startswith("r")]
        for i in data[BLIND_NAN_ROWS[0]:BLIND_NAN_ROWS[1]]:
            f = lines[i].split(",")
            for j in cols:
                f[j] = "nan"
            lines[i] = ",".join(f)
        a, b = times[BLIND_NAN_ROWS[0]], times[BLIND_NAN_ROWS[1]]
        return "\n".join(lines), (a, b), None, (a, b)
    if fault == "stopped input":
        k = data[BLIND_CUT_ROW]
        cut = lines[k][: len(lines[k]) // 2]  # the row cut in its middle, and nothing after it
        t = times[BLIND_CUT_ROW - 1]
        return "\n".join(lines[:k] + [cut]), None, times[BLIND_CUT_ROW], (t, t)
    raise ValueError(fault)


def blind_capture_fault(text, fault, clean_times):
    """The capture with a blind fault; returns (text, window, cut time, None): the reported times
    come from mo-can2csv's rows, so they are not checked exactly."""
    lines = text.split("\n")
    frames = [i for i, l in enumerate(lines) if l.startswith("(")]
    def stamp(i):
        return float(lines[i][1:lines[i].index(")")])
    if fault == "clock step back":
        t = clean_times[BLIND_STEP_ROW]
        for i in frames:
            if stamp(i) < t - 0.5 / RATE:
                e = lines[i].index(")")
                lines[i] = "(%.6f" % (stamp(i) + BLIND_SHIFT) + lines[i][e:]
        return "\n".join(lines), (t, t + max(BLIND_SKIP, BLIND_SETTLE)), None, None
    if fault == "NaN span":
        # Drive 2 stops answering: its position and current frames are missing for a while.
        a, b = clean_times[BLIND_NAN_ROWS[0]], clean_times[BLIND_NAN_ROWS[1]]
        keep = [l for i, l in enumerate(lines)
                if not (l.startswith("(") and a - 0.5 / RATE <= stamp(i) < b - 0.5 / RATE
                        and l.split()[2].split("#")[0] in ("182", "282"))]
        return "\n".join(keep), (a, b + BLIND_SETTLE), None, None
    if fault == "stopped input":
        t = clean_times[BLIND_CUT_ROW]
        k = next(i for i in frames if stamp(i) >= t)
        return "\n".join(lines[:k] + [lines[k][: len(lines[k]) // 2]]), None, t, None
    raise ValueError(fault)


BLIND_FAULTS = ("clock step back", "NaN span", "stopped input")
BLIND_CAUSES = {"clock step back": "clock step back", "NaN span": "residuals not finite",
                "stopped input": "input stopped"}


def run_blind_classes(work, env, write, to_binary, clean_observed_csv, capture, profile, dbc, clean_times):
    """The blind classes in every log kind; returns (table rows, failures)."""
    detect = f"mo-detect {BLIND_THRESHOLD} --skip {BLIND_SKIP}"
    text = open(clean_observed_csv, encoding="utf-8", errors="surrogateescape").read()
    clean_bin = to_binary(clean_observed_csv)
    clean = {"csv": run(f"{detect} {clean_observed_csv}", env=env)[0],
             "bin": run(f"{detect} {clean_bin}", env=env)[0]}
    clean_capture = write("blind-clean.log", capture)
    decoded = write("blind-clean.decoded.csv", run(f"mo-can2csv -q --dbc {dbc} {clean_capture}", env=env)[0])
    observed = write("blind-clean.observed.csv", run(f"mo-observe -q -p {profile} --output-format csv {decoded}", env=env)[0])
    clean["candump"] = run(f"{detect} {observed}", env=env)[0]
    header, rows = blind_events(clean["csv"])
    if len([r for r in rows if r[header.index("kind")] == "onset"]) < 2:
        return [("csv", "blind classes", [("mo-detect", "FAIL")])], 1
    table, failures = [], 0
    for fault in BLIND_FAULTS:
        for log in ("csv", "bin", "candump"):
            name = f"blind-{fault.replace(' ', '-')}-{log}"
            if log == "candump":
                dirty, window, cut, reported = blind_capture_fault(capture, fault, clean_times)
                path = write(name + ".log", dirty)
                dec, dec_err, _ = run(f"mo-can2csv --dbc {dbc} {path}", env=env)
                dec_path = write(name + ".decoded.csv", dec)
                obs = run(f"mo-observe -q -p {profile} --output-format csv {dec_path}", env=env)[0]
                stream = write(name + ".observed.csv", obs)
            else:
                dirty, window, cut, reported = blind_csv_fault(text, fault)
                stream = write(name + ".csv", dirty)
                if log == "bin" and fault == "stopped input":
                    # The clean binary stream cut in the middle of the same record.
                    whole = open(clean_bin, "rb").read()
                    record = 8 * len(header_columns(text))
                    rows_total = len([l for l in text.split("\n") if l and not l.startswith("#")]) - 1
                    start = len(whole) - rows_total * record
                    stream = write(name + ".bin", whole[: start + BLIND_CUT_ROW * record + record // 2])
                elif log == "bin":
                    stream = to_binary(stream)
                dec_err = ""
            out, err, status = run(f"{detect} {stream}", env=env, ok=(0, 1, 4))
            h, base = blind_events(clean[log])
            dh, got = blind_events(out)
            shift_before = clean_times[BLIND_STEP_ROW] if fault == "clock step back" else None
            problems = [] if h == dh else ["header differs"]
            restarted = log == "candump" and fault != "stopped input"
            problems += blind_compare(h, blind_expected(base, h, window, cut), got, shift_before, restarted)
            # After a clock step, every clean event after the skip is found again on the new log.
            if fault == "clock step back" and not any(float(r[h.index("t_detect")]) < BLIND_SHIFT for r in got):
                problems.append("no event after the clock step")
            cause = BLIND_CAUSES[fault]
            if log == "candump" and fault == "stopped input":
                # The capture's cut line is mo-can2csv's to report; the decoded stream is whole.
                if f"{path}:{dirty.count(chr(10)) + 1}:" not in dec_err:
                    problems.append(f"mo-can2csv did not report the cut line: {dec_err.strip()[-300:]}")
            elif f": {cause}" not in err:
                problems.append(f"no blind span '{cause}' reported: {err.strip()[-300:]}")
            elif reported is not None:
                a, b = reported
                exact = lambda x: repr(x)[:-2] if repr(x).endswith(".0") else repr(x)  # as mo-detect writes times
                want = f"at t={exact(a)}" if a == b else f"from t={exact(a)} to t="
                if want not in err:
                    problems.append(f"'{want}' not reported: {err.strip()[-300:]}")
            if fault == "NaN span" and status == 0:
                problems.append("exit 0 after a blind span longer than --max-blind")
            cell = "same events, told" if not problems else "FAIL"
            if problems:
                failures += 1
                print(f"{log} / {fault} / mo-detect: " + "; ".join(problems))
            table.append((log, fault, [("mo-detect", cell)]))
    return table, failures


def header_columns(text):
    for line in text.split("\n"):
        if line and not line.startswith("#"):
            return line.split(",")
    return []


CLEAN_T = []


def encoder_glitch_class(csv_text, capture, clean, tools_on, write, to_binary, decode):
    """The encoder glitch (issue 26): one row whose q2 reads 1e6 rad (in the capture, the
    largest value q2's signal holds, 25736 rad) in the CSV log, the binary log and the capture.
    mo-observe leaves the row out and bridges it (mo-observe(1), ROWS WHOSE SIGNALS DISAGREE),
    so every tool gives the clean output but for that row (and the observer's settling after a
    bridged row), and the events are the clean log's. Returns (table rows, failures)."""
    lines = csv_text.split("\n")
    first = next(i for i, l in enumerate(lines) if l and not l.startswith("#"))
    column = lines[first].split(",").index("q2")
    fields = lines[first + 1 + FAULT_ROW].split(",")
    fields[column] = "1e6"
    lines[first + 1 + FAULT_ROW] = ",".join(fields)
    glitched = "\n".join(lines)
    frames = capture.split("\n")
    syncs = [i for i, l in enumerate(frames) if l.startswith("(") and " 080#" in l]
    k = next(i for i in range(syncs[FAULT_ROW], len(frames)) if " 182#" in frames[i])
    head, data = frames[k].split("#")
    frames[k] = head + "#FFFFFF7F" + data[8:]  # q2: bytes 0-3, little-endian signed, at its largest
    paths = {"csv": write("fault-encoder-glitch.csv", glitched)}
    paths["bin"] = to_binary(paths["csv"])
    rows, failures = [], 0
    settle = int(SETTLE_S * RATE)
    for log in ("csv", "bin", "candump"):
        if log == "candump":
            decoded = decode(write("fault-encoder-glitch.log", "\n".join(frames)))
            outputs = {"mo-can2csv": decoded, **tools_on(write("fault-encoder-glitch.log.csv", decoded))}
            touched = {FAULT_ROW - 1, FAULT_ROW, FAULT_ROW + 1}
        else:
            outputs = tools_on(paths[log])
            touched = {FAULT_ROW}
        base = clean[log]
        cells = []
        for tool, data in outputs.items():
            if tool == "mo-detect":
                problems = compare_events(parse_events(base[tool]), parse_events(data), "encoder glitch")
                cell = "same events" if not problems else "FAIL"
            elif tool == "mo-calibrate":
                problems = [f"{x} instead of {y}" for x, y in zip(data.decode().splitlines(), base[tool].decode().splitlines())
                            if x.startswith("r") and x.split()[:3] == y.split()[:3] and len(x.split()) > 10
                            and abs(float(x.split()[10]) - float(y.split()[10])) > 0.01 * abs(float(y.split()[10]))]
                cell = "same thresholds" if not problems else "FAIL"
            else:
                observed = tool == "mo-observe"
                # Bridged across the row: the residual settles within 0.2 s to within 1 mNm.
                problems, differing = compare_streams(parse_csv(base[tool]), parse_csv(data), touched, "encoder glitch",
                                                      settle // 5 if observed else 1, 1e-3 if observed else 0.0)
                cell = f"{differing} rows differ" if not problems else "FAIL"
            if problems:
                failures += 1
                print(f"{log} / encoder glitch / {tool}: " + "; ".join(problems))
            cells.append((tool, cell))
        rows.append((log, "encoder glitch", cells))
    return rows, failures


def main():
    global ROWS, CLEAN_T
    parser = argparse.ArgumentParser()
    parser.add_argument("--bin", required=True)
    parser.add_argument("--source", required=True)
    parser.add_argument("--keep", action="store_true", help="keep the work folder")
    args = parser.parse_args()
    env = dict(os.environ)
    env["PATH"] = args.bin + os.pathsep + env.get("PATH", "")
    env["LC_ALL"] = "C"
    work = tempfile.mkdtemp(prefix="momentum-corruption-")
    robot = os.path.join(args.source, "share/momentum/robots/paper-arm")
    profile = os.path.join(robot, "paper-arm.json")
    dbc = os.path.join(robot, "paper-arm.dbc")
    sim = f"mo-sim -q -p {profile} --duration 16 --rate {RATE} --collisions 3 --seed 5"
    csv_text = run(sim, env=env, ok=(0,))[0].decode()
    capture = run(sim + f" --candump --dbc {dbc}", env=env, ok=(0,))[0].decode()
    ROWS = len(parse_csv(csv_text.encode())[1])
    CLEAN_T = [r[0] for r in parse_csv(csv_text.encode())[1]]
    threshold = "--signal r --threshold 6"

    def write(name, data):
        path = os.path.join(work, name)
        with open(path, "wb") as f:
            f.write(data.encode("utf-8", "surrogateescape") if isinstance(data, str) else data)
        return path

    def to_binary(csv_path):
        out = os.path.join(work, os.path.basename(csv_path) + ".bin")
        run(f"mo-cat --output-format bin {csv_path} > {out}", env=env)
        return out

    def tools_on(stream_path, observed=None):
        """Outputs of each tool on one stream (observed: a CSV file of mo-observe's output)."""
        out = {}
        out["mo-cat --repair"] = run(f"mo-cat -q --repair --output-format csv {stream_path}", env=env)[0]
        out["mo-observe"] = run(f"mo-observe -q -p {profile} --output-format csv {stream_path}", env=env)[0]
        obs = write(os.path.basename(stream_path) + ".observed.csv", out["mo-observe"])
        out["mo-detect"] = run(f"mo-detect -q {threshold} {obs}", env=env, ok=(0, 1))[0]
        # The paper's max rule: the rate rule extrapolates a tail from the handful of peaks in
        # 2 s of data, where a restart's transient (after a clock step) is one more peak.
        out["mo-calibrate"] = run(f"mo-calibrate -q -n --signal r --no-rest --rule max {obs}", env=env)[0]
        return out

    clean_csv = write("clean.csv", csv_text)
    clean = {"csv": tools_on(clean_csv), "bin": tools_on(to_binary(clean_csv))}
    clean_capture = write("clean.log", capture)
    decoded = run(f"mo-can2csv -q --dbc {dbc} {clean_capture}", env=env)[0]
    clean_decoded = write("clean.decoded.csv", decoded)
    clean["candump"] = {"mo-can2csv": decoded, **tools_on(clean_decoded)}
    clean_events = parse_events(clean["csv"]["mo-detect"])
    if len(clean_events[1]) < 2:
        print(f"the clean log has {len(clean_events[1])} events; the test needs collisions")
        return 1

    table = []
    failures = 0
    settle = int(SETTLE_S * RATE)
    for fault in FAULTS:
        for log in fault.logs:
            if log == "candump":
                text, touched = corrupt_candump(capture, fault.name)
                path = write(f"fault-{fault.name.replace(' ', '-')}.log", text)
                dec = run(f"mo-can2csv -q --dbc {dbc} {path}", env=env)[0]
                outputs = {"mo-can2csv": dec, **tools_on(write(os.path.basename(path) + ".csv", dec))}
                base = clean["candump"]
            else:
                if fault.name == "truncated record":
                    binary = open(to_binary(clean_csv), "rb").read()
                    path = write("fault-truncated.bin", binary[:-12])
                    touched = set()
                else:
                    text, touched = corrupt_csv(csv_text, fault.name)
                    path = write(f"fault-{fault.name.replace(' ', '-')}.csv", text)
                    if log == "bin":
                        path = to_binary(path)
                outputs = tools_on(path)
                base = clean[log]
            cells = []
            for tool, data in outputs.items():
                if tool == "mo-detect":
                    problems = compare_events(parse_events(base[tool]), parse_events(data), fault.name)
                    cell = "same events" if not problems else "FAIL"
                elif tool == "mo-calibrate":
                    a, b = base[tool].decode().splitlines(), data.decode().splitlines()
                    problems = []
                    for x, y in zip(a, b):
                        fx, fy = x.split(), y.split()
                        if x.startswith("r") and len(fx) > 10 and len(fy) > 10 and fx[:3] == fy[:3]:
                            u, v = float(fx[10]), float(fy[10])  # the threshold
                            if abs(u - v) > 0.01 * abs(u):
                                problems.append(f"{' '.join(fx[:3])}: threshold {v} instead of {u}")
                    cell = "same thresholds" if not problems else "FAIL"
                else:
                    observed = tool == "mo-observe"
                    # The observer integrates over the longer step where a row is missing: its
                    # residuals settle within 0.2 s, then agree within 1 mNm (measured: 0.28 mNm
                    # 0.2 s after, 0.13 mNm 4 s after). Where it restarts (a clock step, or a
                    # cycle of the capture left incomplete) r starts again from 0 and converges
                    # slowly (measured: 0.30 Nm 1 s after, 0.07 Nm 8 s after): within 0.5 Nm, a
                    # twelfth of the detection threshold, from 0.5 s on.
                    restart = observed and (fault.name == "clock step" or log == "candump")
                    problems, differing = compare_streams(
                        parse_csv(base[tool]), parse_csv(data), touched, fault.name,
                        (settle // 2 if restart else settle // 5) if observed else 1,
                        (0.5 if restart else 1e-3) if observed else 0.0)
                    cell = f"{differing} rows differ" if not problems else "FAIL"
                if problems:
                    failures += 1
                    print(f"{log} / {fault.name} / {tool}: " + "; ".join(problems))
                cells.append((tool, cell))
            table.append((log, fault.name, cells))
    glitch_rows, glitch_failures = encoder_glitch_class(
        csv_text, capture, clean, tools_on, write, to_binary,
        lambda path: run(f"mo-can2csv -q --dbc {dbc} {path}", env=env)[0])
    table += glitch_rows
    failures += glitch_failures
    blind_table, blind_failures = run_blind_classes(
        work, env, write, to_binary, write("blind-clean.observed-src.csv", clean["csv"]["mo-observe"]), capture,
        profile, dbc, CLEAN_T)
    table += blind_table
    failures += blind_failures
    width = max(len(f"{l} / {f}") for l, f, _ in table)
    tools = ["mo-can2csv", "mo-cat --repair", "mo-observe", "mo-detect", "mo-calibrate"]
    print(f"{'log / fault':<{width}}  " + "  ".join(f"{t:<17}" for t in tools))
    for log, fault, cells in table:
        row = dict(cells)
        print(f"{log + ' / ' + fault:<{width}}  " + "  ".join(f"{row.get(t, '-'):<17}" for t in tools))
    print(f"{ROWS} rows per log, fault at row {FAULT_ROW}; {len(clean_events[1])} events in the clean log")
    if not args.keep:
        shutil.rmtree(work)
    else:
        print(f"work folder: {work}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
