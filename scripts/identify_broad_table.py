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
import time

imukit = sys.argv[1]
data = sys.argv[2] if len(sys.argv) > 2 else os.path.join(os.path.dirname(__file__), "..", "..", "shared", "data")
out_dir = sys.argv[3] if len(sys.argv) > 3 else "/tmp/imukit_identify_broad"
os.makedirs(out_dir, exist_ok=True)

rows = []
for trial in sorted(glob.glob(os.path.join(data, "broad", "*.csv"))):
    name = os.path.splitext(os.path.basename(trial))[0]
    out = os.path.join(out_dir, name + ".placement.json")
    start = time.monotonic()
    r = subprocess.run([imukit, "identify", "--imu", trial, "--columns", "t,ax,ay,az,gx,gy,gz,_,_,_,_,_,_,_,_,_,_,_",
                        "--pose", trial, "--columns", "t,_,_,_,_,_,_,_,_,_,qw,qx,qy,qz,px,py,pz,_",
                        "--gaps", "qw,qx,qy,qz,px,py,pz", "-o", out], capture_output=True, text=True)
    wall = time.monotonic() - start
    if r.returncode not in (0, 2):
        sys.exit(f"{name}: {r.stderr.strip()}")
    j = json.load(open(out))
    p = {e["name"]: e for e in j["parameters"]}

    def pm(name, scale, digits):
        e = p[name]
        if not e["observable"]:
            return "unobservable"
        return f"{e['value'] * scale:.{digits}f} ± {e['std_error'] * scale:.{digits}f}"

    f = j["fit"]
    rows.append((name, f["samples_used"], f["rms_before"]["accel_mps2"], f["rms_after"]["accel_mps2"],
                 f["rms_before"]["gyro_radps"], f["rms_after"]["gyro_radps"], wall,
                 pm("time_offset", 1e3, 3),
                 " / ".join(pm(f"position.{a}", 1e3, 1) for a in "xyz"),
                 " / ".join(pm(f"rotation.{a}", 57.29577951308232, 3) for a in "xyz"),
                 " / ".join(pm(f"accel_bias.{a}", 1.0, 3) for a in "xyz"),
                 " / ".join(pm(f"gyro_bias.{a}", 1e3, 2) for a in "xyz"), j["unobservable"]))

print("| trial | samples | acc RMSE before → after m/s² | gyro RMSE before → after rad/s | identify s |")
print("|---|---|---|---|---|")
for r in rows:
    print(f"| {r[0]} | {r[1]} | {r[2]:.3f} → {r[3]:.3f} | {r[4]:.4f} → {r[5]:.4f} | {r[6]:.1f} |")
print()
print("| trial | time offset ms | lever arm x / y / z mm | rotation x / y / z deg | accel bias x / y / z m/s² | gyro bias x / y / z mrad/s |")
print("|---|---|---|---|---|---|")
for r in rows:
    print(f"| {r[0]} | {r[7]} | {r[8]} | {r[9]} | {r[10]} | {r[11]} |")
