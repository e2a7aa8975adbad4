#!/usr/bin/env python3
"""Writes the same short CANopen capture of a 2-joint arm (arm2.dbc) in every text format
candump prints, following can-utils' lib.c (sprint_canframe, sprint_long_canframe) and
candump.c character by character, plus python-can's log variant; and the rows mo-can2csv must
make of it (`*.expected.csv`), computed here from the values put into the frames.

Run from anywhere: python3 make_captures.py (writes next to itself).
"""
import datetime
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))
T0_US = 1700000000 * 1000000
CYCLES = 6
PERIOD_US = 1000

ERR_FLAG, EFF_FLAG, RTR_FLAG = 0x20000000, 0x80000000, 0x40000000


class Frame:
    def __init__(self, t_us, can_id, data=b"", fd=False, flags=0, rtr_len=None, len8_dlc=0):
        self.t_us, self.can_id, self.data, self.fd, self.flags = t_us, can_id, bytes(data), fd, flags
        self.rtr_len, self.len8_dlc = rtr_len, len8_dlc


def values(k):
    """Physical values of cycle k (raw integers, so that the expected rows are exact)."""
    return {
        "q1": 100000 + 1234 * k, "dq1": -2500 + 700 * k, "i1": 1500 - 250 * k,
        "q2": -300000 + 999 * k, "dq2": 4000 - 333 * k, "i2": -800 + 77 * k,
        "tau_m1": 1234 - 100 * k, "tau_m2": -4321 + 55 * k,
    }


SCALE = {"q1": 1e-06, "dq1": 1e-05, "i1": 0.001, "q2": 1e-06, "dq2": 1e-05, "i2": 0.001,
         "tau_m1": 0.01, "tau_m2": 0.01}
COLUMNS = ["q1", "q2", "dq1", "dq2", "i1", "i2", "tau_m1", "tau_m2"]
MISSING = {(3, "i2")}  # Joint2_TPDO2 is lost in cycle 3


def frames():
    out = [Frame(T0_US - 500, 0x181, struct.pack("<ii", 1, 2))]  # before the first SYNC
    for k in range(CYCLES):
        t = T0_US + k * PERIOD_US
        v = values(k)
        out.append(Frame(t, 0x080))
        out.append(Frame(t + 120, 0x181, struct.pack("<ii", v["q1"], v["dq1"])))
        out.append(Frame(t + 180, 0x281, struct.pack("<h", v["i1"])))
        out.append(Frame(t + 240, 0x182, struct.pack(">ii", v["q2"], v["dq2"])))
        if (k, "i2") not in MISSING:
            out.append(Frame(t + 300, 0x282, struct.pack(">h", v["i2"])))
        out.append(Frame(t + 360, 0x780 | EFF_FLAG, bytes(8) + struct.pack("<hh", v["tau_m1"], v["tau_m2"]),
                         fd=True, flags=0x5))
        if k == 1:
            out.append(Frame(t + 500, 0x1ABCDEF0 | EFF_FLAG, b"\x41\x42\x43"))  # not in the DBC
        if k == 2:
            out.append(Frame(t + 600, 0x701, rtr_len=1))
        if k == 4:
            out.append(Frame(t + 700, ERR_FLAG | 0x4, b"\x00\x04\x00\x00\x00\x00\x00\x00"))
        if k == 5:
            out.append(Frame(t + 800, 0x123, bytes(range(0x31, 0x39)), len8_dlc=0xE))  # not in the DBC
    return out


def id_text(f, long_view=False, indent=False):
    if f.can_id & ERR_FLAG:
        return "%08X" % (f.can_id & 0x3FFFFFFF)
    if f.can_id & EFF_FLAG:
        return "%08X" % (f.can_id & 0x1FFFFFFF)
    return ("     " if indent else "") + "%03X" % f.can_id


def sprint_canframe(f, sep=False):
    s = id_text(f) + "#"
    if f.rtr_len is not None:
        return s + "R" + ("%d" % f.rtr_len if f.rtr_len else "")
    if f.fd:
        s += "#%X" % f.flags
        if sep and f.data:
            s += "."
    s += ("." if sep else "").join("%02X" % b for b in f.data)
    if not f.fd and len(f.data) == 8 and f.len8_dlc > 8:
        s += "_%X" % f.len8_dlc
    return s


def sprint_long_canframe(f, ascii_view=False, swap=False, binary=False, len8=False, indent=False):
    buf = id_text(f, True, indent)
    n = len(f.data) if f.rtr_len is None else f.rtr_len
    buf = buf.ljust(10 if (indent or len(buf) == 8) else 5)
    if not f.fd:
        if len8:
            dlc = f.len8_dlc if (n == 8 and f.len8_dlc > 8) else n
            buf += " {%X} " % dlc
        else:
            buf += " [%d] " % n
        if f.rtr_len is not None:
            return buf + " remote request"
    else:
        buf += "[%02d] " % n
    if binary:
        dlen = 9
        items = ["{:08b}".format(b) for b in f.data]
    else:
        dlen = 3
        items = ["%02X" % b for b in f.data]
    if swap:
        buf += (" " + "`".join(reversed(items))) if items else ""
    else:
        buf += "".join(" " + x for x in items)
    if n > 8:
        return buf
    if f.can_id & ERR_FLAG:
        buf += "ERRORFRAME".rjust(dlen * (8 - n) + 13)
    elif ascii_view:
        text = "".join(chr(b) if 0x1F < b < 0x7F else "." for b in (reversed(f.data) if swap else f.data))
        q = "`" if swap else "'"
        buf += q.rjust(dlen * (8 - n) + 4) + text + q
    return buf


def stamp(mode, f, state):
    t = f.t_us
    if mode == "a":
        return "(%010d.%06d) " % (t // 1000000, t % 1000000)
    if mode == "A":
        d = datetime.datetime(1970, 1, 1) + datetime.timedelta(seconds=t // 1000000)
        return "(%s.%06d) " % (d.strftime("%Y-%m-%d %H:%M:%S"), t % 1000000)
    if mode and mode in "dz":
        if state.get("last") is None:
            state["last"] = t
        diff = max(0, t - state["last"])
        if mode == "d":
            state["last"] = t
        return "(%03d.%06d) " % (diff // 1000000, diff % 1000000)
    return ""


def default_format(mode="", ascii_view=False, extra=False, swap=False, binary=False, len8=False):
    lines, state, indent = [], {}, False
    for f in frames():
        line = " " + stamp(mode, f, state) + " " + "can0"
        if extra:
            line += "  RX %s" % ["- -", "B -", "- E", "B E"][f.flags & 3]
        line += "  "
        if f.can_id & EFF_FLAG:
            indent = True  # candump: once an EFF frame was seen, indent SFF ids
        line += sprint_long_canframe(f, ascii_view, swap, binary, len8, indent and not f.can_id & (EFF_FLAG | ERR_FLAG))
        lines.append(line)
    return "\n".join(lines) + "\n"


def log_format(sep=False, python=False, nine=False, dropcount=False):
    lines = []
    for i, f in enumerate(frames()):
        t = f.t_us
        if python:
            lines.append("(%f) vcan0 %s R" % ((t - T0_US) / 1e6 + 12.5, sprint_canframe(f)))
            continue
        ts = "(%010d.%06d000)" % (t // 1000000, t % 1000000) if nine else "(%010d.%06d)" % (t // 1000000, t % 1000000)
        lines.append("%s can0 %s" % (ts, sprint_canframe(f, sep)))
        if dropcount and i == 10:
            lines.append("DROPCOUNT: dropped 2 CAN frames on 'can0' socket (total drops 2)")
    return "\n".join(lines) + "\n"


def expected(t_of_cycle):
    rows = ["t," + ",".join(COLUMNS)]
    for k in range(CYCLES):
        v = values(k)
        cells = [t_of_cycle(k)]
        for c in COLUMNS:
            cells.append("nan" if (k, c) in MISSING else repr(v[c] * SCALE[c]))
        rows.append(",".join(cells))
    return "\n".join(rows) + "\n"


def main():
    captures = {
        "log.log": log_format(),
        "log-sep-ns-dropcount.log": log_format(sep=True, nine=True, dropcount=True),
        "python-can.log": log_format(python=True),
        "default.txt": default_format(),
        "default-ta.txt": default_format("a"),
        "default-tA.txt": default_format("A"),
        "default-td.txt": default_format("d"),
        "default-tz.txt": default_format("z"),
        "default-ta-a-x.txt": default_format("a", ascii_view=True, extra=True),
        "default-ta-S-8.txt": default_format("a", swap=True, len8=True),
        "default-ta-i.txt": default_format("a", binary=True),
    }
    for name, text in captures.items():
        with open(os.path.join(HERE, name), "w") as out:
            out.write(text)
    absolute = lambda k: "%d.%06d" % ((T0_US + k * PERIOD_US) // 1000000, (T0_US + k * PERIOD_US) % 1000000)
    relative = lambda k: repr((500 + k * PERIOD_US) / 1e6)  # the first frame is 500 us before SYNC 0
    with open(os.path.join(HERE, "absolute.expected.csv"), "w") as out:
        out.write(expected(absolute))
    with open(os.path.join(HERE, "relative.expected.csv"), "w") as out:
        out.write(expected(relative))
    with open(os.path.join(HERE, "untimed.expected.csv"), "w") as out:
        out.write(expected(lambda k: "nan"))
    with open(os.path.join(HERE, "python-can.expected.csv"), "w") as out:
        out.write(expected(lambda k: repr(12.5 + k * PERIOD_US / 1e6)))


if __name__ == "__main__":
    main()
