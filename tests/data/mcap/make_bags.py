#!/usr/bin/env python3
"""Writes the ROS 2 bag fixtures of tests/data/mcap/ with the MCAP project's own Python writer.

The numbers come from a short mo-sim run (0.6 s at 250 Hz) of the paper arm (share/momentum/robots/paper-arm),
written first as joint_states.csv (t, q1-3, dq1-3, tau_m1-3: the reference the tests compare
the read-back bags with), then as sensor_msgs/msg/JointState messages on /joint_states:

  uncompressed.mcap  chunks without compression
  zstd.mcap          zstd chunks
  lz4.mcap           lz4 chunks
  gripper.mcap       zstd, a fourth joint (a gripper finger) among the arm's in every message
  two_topics.mcap    /joint_states and /follower/joint_states (the same arm 10 ms later) and a
                     std_msgs/msg/String topic
  truncated.mcap     uncompressed.mcap cut off inside its third chunk (a recorder killed)

Every message after the first lists the joints in a shuffled order (seeded), as a driver that
builds JointState from a map does; the first is in chain order (waist, shoulder, elbow), so that
a reader without a profile takes the chain's order from it. Stamps are Unix times from
1764000000 s (header.stamp); log_time is the stamp plus 1 ms. Chunks are kept small (4 KiB) so
that every bag has several.

Run from the source tree after building mo-sim (CI does not: the fixtures are committed):
  python3 -m venv /tmp/mcapvenv && /tmp/mcapvenv/bin/pip install mcap mcap-ros2-support
  /tmp/mcapvenv/bin/python tests/data/mcap/make_bags.py build/tools/mo-sim
"""
import csv
import io
import os
import random
import subprocess
import sys

from mcap.reader import make_reader
from mcap.writer import CompressionType
from mcap_ros2.writer import Writer

HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE = os.path.normpath(os.path.join(HERE, "..", "..", ".."))
PROFILE = os.path.join(SOURCE, "share", "momentum", "robots", "paper-arm", "paper-arm.json")
JOINTS = ["waist", "shoulder", "elbow"]  # the URDF's chain, root to tip
K_I = [11.0, 11.0, 6.0]  # the profile's torque constants, Nm/A: effort = k_i * current
EPOCH = 1764000000
CHUNK = 4096

JOINT_STATE = """std_msgs/Header header
string[] name
float64[] position
float64[] velocity
float64[] effort
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
"""


def simulate(mo_sim):
    """Rows (t, q[3], dq[3], i[3]) of 0.6 s of the paper trajectory at 250 Hz."""
    out = subprocess.run([mo_sim, "-p", PROFILE, "--trajectory", "paper", "--duration", "0.6", "--blend", "0.1", "--rate", "250",
                          "--seed", "7", "--output-format", "csv"], check=True, capture_output=True, text=True).stdout
    lines = [l for l in out.splitlines() if l and not l.startswith("#")]
    header = lines[0].split(",")
    rows = []
    for line in lines[1:]:
        v = dict(zip(header, map(float, line.split(","))))
        rows.append((v["t"], [v[f"q{j}"] for j in (1, 2, 3)], [v[f"dq{j}"] for j in (1, 2, 3)],
                     [v[f"i{j}"] for j in (1, 2, 3)]))
    return rows


def stamps(t):
    ns = round(t * 1e9)
    return EPOCH + ns // 10**9, ns % 10**9


def messages(rows, seed, extra_joint=False, delay_ns=0):
    """(stamp sec, nanosec, log_time, message) per row; joints shuffled after the first."""
    rng = random.Random(seed)
    for k, (t, q, dq, i) in enumerate(rows):
        sec, nanosec = stamps(t + delay_ns * 1e-9)
        joints = [(JOINTS[j], q[j], dq[j], K_I[j] * i[j]) for j in range(3)]
        if extra_joint:
            joints.append(("gripper_finger_joint", 0.02, 0.0, 1.5))
        if k > 0:
            rng.shuffle(joints)
        msg = {
            "header": {"stamp": {"sec": sec, "nanosec": nanosec}, "frame_id": "base_link"},
            "name": [j[0] for j in joints],
            "position": [j[1] for j in joints],
            "velocity": [j[2] for j in joints],
            "effort": [j[3] for j in joints],
        }
        yield sec, nanosec, (sec * 10**9 + nanosec) + 1_000_000, msg


def write_bag(path, rows, compression, seed, extra_joint=False, two_topics=False):
    with open(path, "wb") as f:
        writer = Writer(f, chunk_size=CHUNK, compression=compression)
        schema = writer.register_msgdef("sensor_msgs/msg/JointState", JOINT_STATE)
        text = writer.register_msgdef("std_msgs/msg/String", "string data\n") if two_topics else None
        follower = messages(rows, seed + 1, delay_ns=10_000_000) if two_topics else None
        for n, (_, _, log_time, msg) in enumerate(messages(rows, seed, extra_joint)):
            writer.write_message("/joint_states", schema, msg, log_time=log_time, sequence=n)
            if two_topics:
                _, _, follower_time, follower_msg = next(follower)
                writer.write_message("/follower/joint_states", schema, follower_msg, log_time=follower_time, sequence=n)
                if n % 10 == 0:
                    writer.write_message("/chatter", text, {"data": f"row {n}"}, log_time=log_time, sequence=n)
        writer.finish()


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: make_bags.py PATH-TO-mo-sim")
    rows = simulate(sys.argv[1])
    with open(os.path.join(HERE, "joint_states.csv"), "w", newline="") as f:
        f.write("# the numbers of the bags in this folder (make_bags.py): mo-sim -p paper-arm.json --trajectory paper"
                " --duration 0.6 --blend 0.1 --rate 250 --seed 7; t from header.stamp, tau_m = k_i * i\n")
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["t", "q1", "q2", "q3", "dq1", "dq2", "dq3", "tau_m1", "tau_m2", "tau_m3"])
        for t, q, dq, i in rows:
            sec, nanosec = stamps(t)
            w.writerow([repr(float(sec) + nanosec * 1e-9)] + [repr(x) for x in q + dq] +
                       [repr(K_I[j] * i[j]) for j in range(3)])
    write_bag(os.path.join(HERE, "uncompressed.mcap"), rows, CompressionType.NONE, seed=1)
    write_bag(os.path.join(HERE, "zstd.mcap"), rows, CompressionType.ZSTD, seed=2)
    write_bag(os.path.join(HERE, "lz4.mcap"), rows, CompressionType.LZ4, seed=3)
    write_bag(os.path.join(HERE, "gripper.mcap"), rows, CompressionType.ZSTD, seed=4, extra_joint=True)
    write_bag(os.path.join(HERE, "two_topics.mcap"), rows, CompressionType.ZSTD, seed=5, two_topics=True)
    # Cut inside the third chunk: the first two chunks and the third's complete messages are good.
    path = os.path.join(HERE, "uncompressed.mcap")
    with open(path, "rb") as f:
        chunks = sorted(make_reader(f).get_summary().chunk_indexes, key=lambda c: c.chunk_start_offset)
    data = open(path, "rb").read()
    cut = chunks[2].chunk_start_offset + chunks[2].chunk_length // 2
    open(os.path.join(HERE, "truncated.mcap"), "wb").write(data[:cut])


if __name__ == "__main__":
    main()
