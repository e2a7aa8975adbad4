#!/usr/bin/env python3
"""Converts the truth of a MuJoCo campaign (../shared/reference/mujoco/README.md) to mo-sim's truth
format, so that mo-eval scores it like any campaign of mo-sim.

  mujoco-truth.py truth_coll.csv truth_coll_detail.json > truth.csv

Columns written: t_onset, t_end, link, clamp (1 for the obstacles, `sphere` and `box`: a
collision; 0 for `push`: a contact), px, py, pz (the push point in its link's frame, m; nan
for obstacles, whose detail gives no point), f_peak (N). A `# duration:` comment is not written:
give mo-eval --duration.
"""
import csv, json, sys


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: mujoco-truth.py TRUTH.csv DETAIL.json")
    with open(sys.argv[1]) as f:
        rows = list(csv.DictReader(f))
    with open(sys.argv[2]) as f:
        details = json.load(f)
    if len(rows) != len(details):
        sys.exit(f"mujoco-truth: {len(rows)} rows in {sys.argv[1]}, {len(details)} in {sys.argv[2]}")
    print("t_onset,t_end,link,clamp,px,py,pz,f_peak")
    for k, (row, detail) in enumerate(zip(rows, details), start=2):
        kind = row["kind"]
        if kind not in ("sphere", "box", "push"):
            sys.exit(f"mujoco-truth: {sys.argv[1]}:{k}: unknown kind '{kind}'")
        if abs(float(row["onset"]) - detail["onset"]) > 1e-3:
            sys.exit(f"mujoco-truth: {sys.argv[1]}:{k}: onset differs from the detail's")
        point = detail.get("point_local") if kind == "push" else None
        p = [f"{v:.6f}" for v in point] if point else ["nan"] * 3
        print(",".join([row["onset"], row["end"], row["link"], "0" if kind == "push" else "1", *p, row["peak_force_N"]]))


if __name__ == "__main__":
    main()
