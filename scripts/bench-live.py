#!/usr/bin/env python3
"""Live latency of the suite's stages, through real pipes into real processes.

    scripts/bench-live.py [--bin build/bin] [-n 2000]

Each measurement starts the tool once and drives it through its standard input and output
(pipes, as in `candump -L can0 | mo-can2csv ... | mo-detect ...`). The driver writes the rows
that lead up to the one that matters, waits 1 ms (so that the tool is idle in its read, as live
between two control cycles), writes that row, takes the time, and polls the tool's output until
the line it causes arrives, N times:

  cat                  a row through cat: the pipes', the scheduler's and this driver's own cost
  mo-detect            from the row that crosses the threshold to its onset line
                       (--threshold, no identification)
  mo-detect identify   the same with contact identification (the paper arm's chain and q
                       columns): the onset line, and the identified line that follows it
  mo-can2csv           from a control cycle's last CAN frame (candump -L text; SYNC and 12
                       TPDOs of a 6-joint arm, 125 Hz) to the cycle's row; when no row comes in
                       the rest of the 8 ms period, the next SYNC is sent, as the bus would (a
                       build that closes a cycle only at the next SYNC: one period late)

Prints median, 99th percentile and maximum in microseconds, and the load of the machine
(1-minute load average, cores) before and after: the numbers are only as quiet as the cores.
"""
import argparse
import os
import select
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
PAUSE = 0.001  # s before the timed row: the tool waits in its read, as between two live cycles
SPACING = 0.0002  # s between the untimed rows that lead up to it


def sleep(seconds):
    end = time.perf_counter() + seconds
    while True:
        left = end - time.perf_counter()
        if left <= 0:
            return
        time.sleep(min(left, 0.0001))


class Tool:
    """A process fed through a pipe; lines of its output stamped when their bytes arrived."""

    nice = 0  # niceness of the tools (--tool-nice)

    def __init__(self, command):
        if Tool.nice and command[0] != "cat":
            command = ["nice", "-n", str(Tool.nice)] + command
        self.process = subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, bufsize=0)
        self.fd_in = self.process.stdin.fileno()
        self.fd_out = self.process.stdout.fileno()
        self.poll = select.poll()
        self.poll.register(self.fd_out, select.POLLIN)
        self.pending = b""
        self.lines = []  # (arrival ns, line) not yet taken

    def write(self, data):
        os.write(self.fd_in, data)

    def line(self, wanted, timeout=5.0, quiet=None):
        """The first line for which wanted(line) holds, with the time its bytes arrived (ns).
        quiet: (seconds, action) to run once when nothing came for that long."""
        deadline = time.perf_counter() + timeout
        quiet_until = None
        while True:
            while self.lines:
                stamp, line = self.lines.pop(0)
                if wanted(line):
                    return stamp, line
            if quiet:
                if quiet_until is None:
                    quiet_until = time.perf_counter() + quiet[0]
                left = quiet_until - time.perf_counter()
                if left <= 0 or not self.poll.poll(max(1, int(left * 1000))):
                    quiet[1]()
                    quiet = None
                    continue
            left = deadline - time.perf_counter()
            if left <= 0 or not self.poll.poll(max(1, int(left * 1000))):
                sys.exit(f"bench-live: no line from {self.process.args[0]} within {timeout} s")
            chunk = os.read(self.fd_out, 65536)
            now = time.perf_counter_ns()
            if not chunk:
                sys.exit(f"bench-live: {self.process.args[0]} ended early (status {self.process.wait()})")
            self.pending += chunk
            *complete, self.pending = self.pending.split(b"\n")
            self.lines.extend((now, l) for l in complete)

    def close(self):
        self.process.stdin.close()
        self.process.stdout.read()
        return self.process.wait()


def summary(label, latencies_ns):
    us = sorted(x / 1000.0 for x in latencies_ns)
    q = lambda p: us[min(len(us) - 1, int(p * (len(us) - 1) + 0.5))]
    print(f"{label:<34} median {q(0.5):8.1f} us   p99 {q(0.99):8.1f} us   max {us[-1]:8.1f} us   (n={len(us)})")


def bench_cat(n):
    tool = Tool(["cat"])
    latencies = []
    for k in range(n):
        sleep(PAUSE)
        sent = time.perf_counter_ns()
        tool.write(b"%d,0\n" % k)
        stamp, _ = tool.line(lambda l: True)
        latencies.append(stamp - sent)
    tool.close()
    summary("cat (pipes and driver alone)", latencies)


def bench_detect(bin_dir, n, identify):
    # Three joints (the paper arm); q fixed away from singular poses. Per trial: a ramp of mu1
    # and mu2 (a contact on link 2) from inside the band to over the 5 Nm threshold, timed on
    # the row that crosses it, then a quiet row that ends the event (--hold 0).
    profile = os.path.join(HERE, "..", "share", "momentum", "robots", "paper-arm", "paper-arm.json")
    command = [os.path.join(bin_dir, "mo-detect"), "-q", "--threshold", "5", "--hold", "0", "--aftermath", "0",
               "--stall", "0"]
    if identify:
        command += ["-p", profile]
    tool = Tool(command)
    tool.write(b"t,q1,q2,q3,mu1,mu2,mu3\n")
    t = 0.0
    ramp = [0.5, 1.5, 2.5, 3.5, 4.5]  # under the threshold: the run that gives the onset estimate
    onset, identified = [], []

    def row(mu):
        nonlocal t
        t += 0.001
        return b"%.3f,0.3,-0.6,0.9,%g,%g,0.1\n" % (t, mu, 0.8 * mu)

    for k in range(50):  # quiet rows: the contact window's history before the first event
        tool.write(row(0.2))
    _, header = tool.line(lambda l: l.startswith(b"t_onset_estimate,"))
    force = header.split(b",").index(b"f") if identify else None
    for k in range(n):
        for mu in ramp:
            tool.write(row(mu))
            sleep(SPACING)
        sleep(PAUSE)
        crossing = row(12.0)
        sent = time.perf_counter_ns()
        tool.write(crossing)
        stamp, line = tool.line(lambda l: b",onset," in l)
        onset.append(stamp - sent)
        if identify:
            # A build before the identified row (issue 27) fitted the contact into the onset row.
            if not line.split(b",")[force]:
                stamp, _ = tool.line(lambda l: b",identified," in l)
            identified.append(stamp - sent)
        tool.write(row(0.2))
        tool.line(lambda l: b",end," in l)
    status = tool.close()
    if status not in (0, 1):
        sys.exit(f"bench-live: mo-detect exited with status {status}")
    if identify:
        summary("mo-detect identify: row -> onset", onset)
        summary("mo-detect identify: row -> identified", identified)
    else:
        summary("mo-detect: row -> onset line", onset)


DBC = "".join(
    f"BO_ {0x180 + j} Joint{j}_TPDO1: 8 Drive{j}\n"
    f" SG_ q{j} : 0|32@1- (1E-006,0) [-10|10] \"rad\" Host\n"
    f" SG_ dq{j} : 32|32@1- (1E-005,0) [-10|10] \"rad/s\" Host\n"
    f"BO_ {0x280 + j} Joint{j}_TPDO2: 4 Drive{j}\n"
    f" SG_ i{j} : 0|16@1- (0.001,0) [-30|30] \"A\" Host\n"
    f" SG_ tau_m{j} : 23|16@0- (0.01,0) [-300|300] \"Nm\" Host\n"
    for j in range(1, 7))


def bench_can(bin_dir, n, work):
    dbc = os.path.join(work, "arm.dbc")
    with open(dbc, "w") as f:
        f.write(DBC)
    tool = Tool([os.path.join(bin_dir, "mo-can2csv"), "-q", "--dbc", dbc])
    tool.line(lambda l: l.startswith(b"t,"))
    latencies = []
    t0 = 1700000000 * 1000000  # us
    synced = set()  # cycles whose SYNC went out early: a build that waits for it (before issue 27)
    sync = lambda t: b"(%d.%06d) can0 080#\n" % divmod(t, 1000000)

    def next_sync(t):
        # The bus's next SYNC, a period after this cycle's: what a tool that closes cycles only
        # at their boundary waits for. Sent once nothing came for the rest of the period.
        synced.add(t + 8000)
        tool.write(sync(t + 8000))

    for k in range(n):
        t = t0 + 8000 * k  # 125 Hz
        frames = [] if t in synced else [sync(t)]
        for j in range(1, 7):
            frames.append(b"(%d.%06d) can0 %03X#%08X%08X\n" % (*divmod(t + 100 * j, 1000000), 0x180 + j, k, j))
            frames.append(b"(%d.%06d) can0 %03X#%04X%04X\n" % (*divmod(t + 100 * j + 50, 1000000), 0x280 + j, k & 0xFFFF, j))
        for frame in frames[:-1]:
            tool.write(frame)
            sleep(SPACING / 2)
        sleep(PAUSE)
        sent = time.perf_counter_ns()
        tool.write(frames[-1])
        rest = 0.008 - PAUSE - 12 * SPACING / 2
        stamp, _ = tool.line(lambda l: l[:1].isdigit(), quiet=(rest, lambda: next_sync(t)))
        latencies.append(stamp - sent)
    status = tool.close()
    if status != 0:
        sys.exit(f"bench-live: mo-can2csv exited with status {status}")
    summary("mo-can2csv: last frame -> row", latencies)


def load():
    with open("/proc/loadavg") as f:
        return f"load average {f.read().split()[0]} on {os.cpu_count()} cores"


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--bin", default=os.path.join(HERE, "..", "build", "bin"))
    parser.add_argument("-n", type=int, default=2000, help="timed rows per measurement (2000)")
    parser.add_argument("--only", choices=["cat", "detect", "identify", "can"], action="append")
    parser.add_argument("--tool-nice", type=int, default=0,
                        help="run the tools at this niceness: on a busy machine the driver, like a real consumer "
                             "of the onset line, then gets a core before the tool's identification")
    args = parser.parse_args()
    Tool.nice = args.tool_nice
    only = set(args.only or ["cat", "detect", "identify", "can"])
    print(f"bench-live: {args.n} timed rows each, {PAUSE * 1e3:g} ms idle before each; {load()}"
          + (f"; tools at nice {args.tool_nice}" if args.tool_nice else ""))
    with tempfile.TemporaryDirectory() as work:
        if "cat" in only:
            bench_cat(args.n)
        if "detect" in only:
            bench_detect(args.bin, args.n, identify=False)
        if "identify" in only:
            bench_detect(args.bin, args.n, identify=True)
        if "can" in only:
            bench_can(args.bin, args.n, work)
    print(f"bench-live: after: {load()}")


if __name__ == "__main__":
    main()
