#!/bin/sh
# Bring a controller's CSV export into the suite and observe it (man 7 momentum, "Logs from a
# robot controller"). The export, controller-export.csv beside this script, is what a typical
# controller writes for the three-joint paper arm (share/momentum/robots/paper-arm):
#
#   no header; one row per 8 ms cycle with, in this order:
#   time        controller ticks of 1 ms since power-on
#   q1..q3      joint positions, degrees
#   dq1..dq3    joint velocities, degrees/s
#   i1..i3      motor currents, per mille of the drives' 5 A rated current; drive 2 reports
#               its current with the opposite sign (its motor is mounted the other way)
#   status      a drive status word (not needed: dropped)
#
# and, as real logs do, a row written twice and a row written early.
#
# Usage: import-controller-export.sh [EXPORT [PROFILE]] > observed.csv
#   EXPORT   the export (default: controller-export.csv beside this script)
#   PROFILE  the robot profile (default: the paper arm's)
# Needs mo-cat and mo-observe on PATH. Warnings (the repaired rows, gaps) go to stderr.
set -eu
here=$(dirname "$0")
export_file=${1:-$here/controller-export.csv}
profile=${2:-$here/../robots/paper-arm/paper-arm.json}

# 1. Name the columns (_ drops one), shift time to start at 0 (on the integer ticks, exactly),
#    drop the duplicate and the early row, then scale: ticks to s, degrees to rad, per mille of
#    5 A to A (0.005), and flip drive 2's current.
# 2. Observe: residuals r1..r3 (and the profile's friction compensation, if it has one).
mo-cat --names t,q1-3,dq1-3,i1-3,_ --zero-time --repair \
    --scale t=0.001 \
    --scale q1-3,dq1-3=0.0174532925199433 \
    --scale i1-3=0.005 --scale i2=-1 \
    "$export_file" |
  mo-observe -p "$profile"
