#!/usr/bin/env python3
"""Runs `imukit identify` on every BROAD trial in ../shared/data/broad (the command of issue 8,
one trial at a time) and prints the docs/validation.md table: RMSE of simulated against measured
accelerometer and gyroscope before and after identification, and the identified parameters with
their standard errors.

usage: scripts/identify_broad_table.py IMUKIT_BINARY [DATA_DIR] [OUT_DIR]
"""
import glob
import json
import os
import subprocess
import sys
import resource

import numpy as np

imukit = sys.argv[1]
data = sys.argv[2] if len(sys.argv) > 2 else os.path.join(os.path.dirname(__file__), "..", "..", "shared", "data")
out_dir = sys.argv[3] if len(sys.argv) > 3 else "/tmp/imukit_identify_broad"
os.makedirs(out_dir, exist_ok=True)

rows = []
trials = sorted(glob.glob(os.path.join(data, "broad", "*.csv")))
if not trials:
    sys.exit(f"no BROAD trials in {os.path.join(data, 'broad')} (give the shared data folder)")
for trial in trials:
    name = os.path.splitext(os.path.basename(trial))[0]
    out = os.path.join(out_dir, name + ".placement.json")
    if os.path.exists(out):
        os.remove(out)  # an earlier run's file is no answer of this one
    start = resource.getrusage(resource.RUSAGE_CHILDREN)
    r = subprocess.run([imukit, "identify", "--imu", trial, "--columns", "t,ax,ay,az,gx,gy,gz,_,_,_,_,_,_,_,_,_,_,_",
                        "--pose", trial, "--columns", "t,_,_,_,_,_,_,_,_,_,qw,qx,qy,qz,px,py,pz,_",
                        "--gaps", "qw,qx,qy,qz,px,py,pz", "-o", out], capture_output=True, text=True)
    # CPU seconds of the command (reading the file included): the shared machine's wall clock
    # says more about its load than about imukit.
    end = resource.getrusage(resource.RUSAGE_CHILDREN)
    wall = (end.ru_utime - start.ru_utime) + (end.ru_stime - start.ru_stime)
    # Exit 1 with the JSON written: a parameter the trial cannot observe (named in the table).
    if r.returncode not in (0, 1) or not os.path.exists(out):
        sys.exit(f"{name}: exit {r.returncode}: {r.stderr.strip()}")
    j = json.load(open(out))
    p = {e["name"]: e for e in j["parameters"]}

    def pm(name, scale, digits):
        e = p[name]
        if not e["observable"]:
            return "unobservable"
        return f"{e['value'] * scale:.{digits}f} ± {e['std_error'] * scale:.{digits}f}"

    # Independent check from the rest phase before the motion (t < 20 s, IMU still): the mean
    # gyro is the gyro bias; the mean of accel - R_world_imu^T (0, 0, 9.80665) with the optical
    # orientation is the accelerometer bias (to the optical rotation's accuracy, ~0.1 deg ~ 0.02 m/s^2).
    d = np.genfromtxt(trial, delimiter=",", skip_header=1)
    rest = (d[:, 0] < 20.0) & np.all(np.isfinite(d[:, 10:14]), axis=1)
    q = d[rest, 10:14] / np.linalg.norm(d[rest, 10:14], axis=1)[:, None]
    w, x, y, z = q.T
    # Third row of R_world_imu = world z in IMU axes.
    up = np.column_stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)])
    rest_ba = np.mean(d[rest, 1:4] - 9.80665 * up, axis=0)
    rest_bg = np.mean(d[rest, 4:7], axis=0)
    f = j["fit"]
    rows.append((name, f["samples_used"], f["rms_before"]["accel_mps2"], f["rms_after"]["accel_mps2"],
                 f["rms_before"]["gyro_radps"], f["rms_after"]["gyro_radps"], wall,
                 pm("time_offset", 1e3, 3),
                 " / ".join(pm(f"position.{a}", 1e3, 1) for a in "xyz"),
                 " / ".join(pm(f"rotation.{a}", 57.29577951308232, 3) for a in "xyz"),
                 " / ".join(pm(f"accel_bias.{a}", 1.0, 3) for a in "xyz"),
                 " / ".join(pm(f"gyro_bias.{a}", 1e3, 2) for a in "xyz"), j["unobservable"],
                 " / ".join(f"{v:.3f}" for v in rest_ba), " / ".join(f"{v * 1e3:.2f}" for v in rest_bg),
                 int(rest.sum())))

print("| trial | samples | acc RMSE before → after m/s² | gyro RMSE before → after rad/s | identify CPU s |")
print("|---|---|---|---|---|")
for r in rows:
    print(f"| {r[0]} | {r[1]} | {r[2]:.3f} → {r[3]:.3f} | {r[4]:.4f} → {r[5]:.4f} | {r[6]:.1f} |")
print()
print("| trial | time offset ms | lever arm x / y / z mm | rotation x / y / z deg | accel bias x / y / z m/s² | gyro bias x / y / z mrad/s |")
print("|---|---|---|---|---|---|")
for r in rows:
    print(f"| {r[0]} | {r[7]} | {r[8]} | {r[9]} | {r[10]} | {r[11]} |")
print()
print("| trial | rest samples | accel bias at rest x / y / z m/s² | gyro bias at rest x / y / z mrad/s |")
print("|---|---|---|---|")
for r in rows:
    print(f"| {r[0]} | {r[15]} | {r[13]} | {r[14]} |")
