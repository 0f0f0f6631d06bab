#!/usr/bin/env python3
"""Writes a recording with `imukit convert` (zstd chunks) and has the MCAP project's own reader
check it (node/check_mcap.mjs): schemas, channels, message counts, a decoded sample, CRCs and
the summary indexes.

usage: mcap_independent_check.py IMUKIT_BINARY
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile

imukit = sys.argv[1]
here = os.path.dirname(os.path.abspath(__file__))
node_dir = os.path.join(here, "node")
if not os.path.isdir(os.path.join(node_dir, "node_modules", "@mcap", "core")):
    print("FAIL: tests/capture/node/node_modules is missing: run scripts/setup.sh (npm ci)")
    sys.exit(1)
node = shutil.which("node")
if node is None:
    print("FAIL: node is not installed: run scripts/setup.sh")
    sys.exit(1)

with tempfile.TemporaryDirectory() as tmp:
    csv = os.path.join(tmp, "wrist.csv")
    rows = []
    with open(csv, "w") as f:
        f.write("#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
                "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]\n")
        for i in range(3000):  # 3 s at 1 kHz: 12 chunks of 250 ms
            t = 1_700_000_000_000_000_000 + i * 1_000_000
            g = [0.001 * i, -0.5 + 1e-4 * i, 0.125]
            a = [0.1, -0.2 * (i % 7), 9.80665]
            rows.append((t, g, a))
            f.write(f"{t},{g[0]!r},{g[1]!r},{g[2]!r},{a[0]!r},{a[1]!r},{a[2]!r}\n")
    mcap = os.path.join(tmp, "wrist.mcap")
    r = subprocess.run([imukit, "convert", csv, "-o", mcap], capture_output=True, text=True)
    if r.returncode != 0:
        print(f"FAIL: imukit convert: {r.stderr}")
        sys.exit(1)
    expected = {
        "channels": {"/imu/wrist": 3000},
        "first": {"topic": "/imu/wrist", "log_time_ns": rows[0][0],
                  "angular_velocity": rows[0][1], "linear_acceleration": rows[0][2]},
    }
    exp_path = os.path.join(tmp, "expected.json")
    with open(exp_path, "w") as f:
        json.dump(expected, f)
    r = subprocess.run([node, os.path.join(node_dir, "check_mcap.mjs"), mcap, exp_path],
                       capture_output=True, text=True, cwd=node_dir)
    print(r.stdout, end="")
    print(r.stderr, end="", file=sys.stderr)
    sys.exit(r.returncode)
