#!/usr/bin/env python3
"""End-to-end checks of `imukit convert` and `imukit info` through the real binary, with NumPy
(Debian's python3-numpy) as an independent reader of the .npy files imukit writes.

usage: cli_io_test.py IMUKIT_BINARY
"""
import os
import subprocess
import sys
import tempfile

import numpy as np

from checks import Checks

IMUKIT = sys.argv[1]
check = Checks()


def run(*args):
    return subprocess.run([IMUKIT, *args], capture_output=True, text=True)


with tempfile.TemporaryDirectory() as tmp:
    # A 200 Hz stream in g and deg/s with blank separators and a header row.
    src = os.path.join(tmp, "log.txt")
    rng = np.random.default_rng(3)
    t = 1700000000.0 + np.arange(500) * 0.005
    acc_g = rng.normal(0, 0.01, (500, 3)) + [0, 0, 1]
    gyr_dps = rng.normal(0, 0.5, (500, 3))
    with open(src, "w") as f:
        f.write("time ax ay az gx gy gz\n")
        for i in range(500):
            f.write(f"{1700000000 + i // 200}.{(i % 200) * 5:03d} "
                    + " ".join(repr(v) for v in acc_g[i]) + " "
                    + " ".join(repr(v) for v in gyr_dps[i]) + "\n")

    out_npy = os.path.join(tmp, "imu.npy")
    r = run("convert", src, "--columns", "t,ax,ay,az,gx,gy,gz", "--accel-unit", "g",
            "--gyro-unit", "deg/s", "-o", out_npy)
    check(r.returncode == 0, f"convert to .npy exits 0 ({r.stderr.strip()})")
    x = np.load(out_npy)
    ts = np.load(os.path.join(tmp, "imu_t.npy"))
    check(x.dtype == np.float64 and x.shape == (500, 6), f"X is float64 (500, 6): {x.dtype} {x.shape}")
    check(ts.dtype == np.int64 and ts.shape == (500,), "t is int64 (500,)")
    check(ts[0] == 1700000000 * 10**9 and ts[499] == 1700000000 * 10**9 + 499 * 5000000,
          "time stamps exact to the nanosecond")
    check(np.array_equal(x[:, 0:3], acc_g * 9.80665), "accelerometer converted from g exactly")
    check(np.array_equal(x[:, 3:6], gyr_dps * (np.pi / 180.0)), "gyroscope converted from deg/s exactly")

    out_csv = os.path.join(tmp, "imu0.csv")
    r = run("convert", src, "--columns", "t,ax,ay,az,gx,gy,gz", "-o", out_csv)
    check(r.returncode == 0, "convert to EuRoC CSV exits 0")
    rows = np.loadtxt(out_csv, delimiter=",", skiprows=1)
    check(rows.shape == (500, 7), "EuRoC CSV has 500 rows of 7 columns")
    check(np.array_equal(rows[:, 4:7], acc_g) and np.array_equal(rows[:, 1:4], gyr_dps),
          "EuRoC CSV holds gyro then accel, values round-trip exactly")

    r = run("info", out_csv)
    check(r.returncode == 0 and "200.0000 Hz" in r.stdout and "uniformly sampled" in r.stdout,
          "info reports the measured 200 Hz rate")

    bad = os.path.join(tmp, "bad.txt")
    with open(bad, "w") as f:
        f.write("0 1 2 3\n0.005 1 x 3\n")
    r = run("info", bad, "--columns", "t,ax,ay,az")
    check(r.returncode == 1, f"bad input exits 1 (got {r.returncode})")
    lines = r.stderr.strip().splitlines()
    check(len(lines) == 1 and f"{bad}:2:9: column 3 (ay): 'x' is not a number" in lines[0],
          f"bad input gives one line naming file:line:column ({r.stderr.strip()})")

    r = run("info", bad)
    check(r.returncode == 2 and "--columns" in r.stderr, "a file without a column map says how to give one (usage, exit 2)")
    r = run("convert", out_csv, "-o", os.path.join(tmp, "x.bin"))
    check(r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1 and "OUT.mcap" in r.stderr,
          "unknown output format is a one-line usage error (exit 2)")

    # MCAP round trip: CSV -> MCAP -> CSV keeps every value bit for bit.
    out_mcap = os.path.join(tmp, "imu0.mcap")
    r = run("convert", out_csv, "-o", out_mcap)
    check(r.returncode == 0, f"convert to MCAP exits 0 ({r.stderr.strip()})")
    back_dir = os.path.join(tmp, "back")
    r = run("convert", out_mcap, "-o", back_dir)
    check(r.returncode == 0, "convert MCAP to a folder exits 0")
    with open(out_csv) as a, open(os.path.join(back_dir, "imu0.csv")) as b:
        check(a.read() == b.read(), "CSV -> MCAP -> CSV is byte-identical")

    # A recording cut short: read to its last complete chunk with a note, then recovered.
    with open(out_mcap, "rb") as f:
        data = f.read()
    cut = os.path.join(tmp, "cut.mcap")
    with open(cut, "wb") as f:
        f.write(data[: len(data) // 2])
    r = run("info", cut)
    check(r.returncode == 0 and "the file ends at byte" in r.stderr and "--recover" in r.stderr,
          "a cut MCAP file is read with a note, not an error")
    fixed = os.path.join(tmp, "fixed.mcap")
    r = run("convert", "--recover", cut, "-o", fixed)
    check(r.returncode == 0, "convert --recover exits 0")
    r = run("info", fixed)
    check(r.returncode == 0 and "the file ends" not in r.stderr, "the recovered file is complete")

check.finish()
