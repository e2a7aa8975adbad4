#!/usr/bin/env python3
"""Writes a momentum stream (t, q1..6, dq1..6, i1..6) as UR's RTDE client records it.

usage: make_rtde_recording.py STREAM.csv PROFILE.json [T0] > robot_data.csv

The format is that of examples/record.py in UniversalRobots/RTDE_Python_Client_Library
(rtde/csv_writer.py): Python's csv module with delimiter " " (so lines end in CR LF), one
header line naming each output of the recipe, a VECTOR6D output VAR as VAR_0 .. VAR_5, numbers
as Python prints them. The recipe here:

  timestamp                 T0 + the stream's t (s since the controller started)
  actual_q, actual_qd       the stream's q, dq (rad, rad/s)
  actual_current            the stream's i (A)
  actual_current_as_torque  k_i[j] * i[j] with the profile's k_i: the controller's own
                            current-to-torque conversion (PolyScope 5.23 on), standing in with
                            the identified drive gains for UR's, which the log does not have
  robot_mode, safety_status, runtime_state, speed_scaling
                            constants of a running program (7, 1, 2, 1.0), to be passed through

Only the status constants and the torque column are made up; the rest is the log as it is.
"""
import csv
import json
import sys


def main():
    stream, profile = sys.argv[1], sys.argv[2]
    t0 = float(sys.argv[3]) if len(sys.argv) > 3 else 8123.456
    k_i = [joint["k_i"] for joint in json.load(open(profile))["joints"]]
    lines = [line for line in open(stream) if line.strip() and not line.startswith("#")]
    header = lines[0].strip().split(",")
    index = {name: k for k, name in enumerate(header)}
    names = (["timestamp"] + [f"actual_q_{j}" for j in range(6)] + [f"actual_qd_{j}" for j in range(6)] +
             [f"actual_current_{j}" for j in range(6)] + [f"actual_current_as_torque_{j}" for j in range(6)] +
             ["robot_mode", "safety_status", "runtime_state", "speed_scaling"])
    out = csv.writer(sys.stdout, delimiter=" ")
    out.writerow(names)
    for line in lines[1:]:
        v = [float(x) for x in line.strip().split(",")]
        col = lambda name: v[index[name]]
        row = [t0 + col("t")]
        row += [col(f"q{j}") for j in range(1, 7)]
        row += [col(f"dq{j}") for j in range(1, 7)]
        row += [col(f"i{j}") for j in range(1, 7)]
        row += [k_i[j - 1] * col(f"i{j}") for j in range(1, 7)]
        row += [7, 1, 2, 1.0]
        out.writerow(row)


if __name__ == "__main__":
    main()
