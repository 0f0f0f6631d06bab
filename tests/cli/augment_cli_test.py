#!/usr/bin/env python3
"""End-to-end checks of `imukit augment` through the real binary, read back with NumPy: a PPDA
dataset from a scene (shapes, dtypes, labels from segments, sub-policy indices, dataset.json), the
same bytes for 1 and 2 threads, identity batches equal to `imukit simulate`, an STDA dataset from
a recording, a JSON policy, the built-in grid listing (810 sub-policies), and one-line errors.

usage: augment_cli_test.py IMUKIT_BINARY
"""
import json
import os
import subprocess
import sys
import tempfile

import numpy as np
from checks import Checks, imukit_runner

IMUKIT = sys.argv[1]
check = Checks()

run = imukit_runner(IMUKIT)


with tempfile.TemporaryDirectory() as tmp:
    scene = {
        "schema": "imukit.scene/1",
        "motion": {"procedural": {"rate_hz": 50, "duration_s": 20, "seed": 3}},
        "simulation": {"seed": 7},
        "sensors": [{"name": "watch", "preset": "left_wrist_watch"},
                    {"name": "belt", "preset": "waist_belt"}],
    }
    spath = os.path.join(tmp, "scene.json")
    json.dump(scene, open(spath, "w"))
    labels = os.path.join(tmp, "labels.csv")
    with open(labels, "w") as f:
        f.write("start_s,end_s,label\n0,10,3\n10,20,5\n")

    r = run("augment", "--policy", "paper", "--list-sub-policies")
    lines = [l for l in r.stdout.splitlines() if l.strip()]
    check(r.returncode == 0 and lines[0].startswith("policy paper: 810 sub-policies") and len(lines) == 811,
          "the paper's grid lists 810 sub-policies")

    outs = {}
    for threads in ("1", "2"):
        out = os.path.join(tmp, "ppda" + threads)
        r = run("augment", "--scene", spath, "--policy", "paper", "--window", "50", "--stride", "25",
                "--count", "40", "--batch-size", "16", "--labels", labels, "--seed", "11",
                "--threads", threads, "-o", out)
        outs[threads] = out
        check(r.returncode == 0, f"PPDA dataset with {threads} thread(s)")
    X = np.load(os.path.join(outs["1"], "X.npy"))
    y = np.load(os.path.join(outs["1"], "y.npy"))
    sp = np.load(os.path.join(outs["1"], "sub_policy.npy"))
    meta = json.load(open(os.path.join(outs["1"], "dataset.json")))
    check(X.dtype == np.float32 and X.shape == (40, 50, 12), f"X is float32 (N, T, C) = {X.shape}")
    check(y.dtype == np.int64 and y.shape == (40,), "y is int64 (N)")
    check(np.all(np.isfinite(X)), "X is finite")
    # 20 s at 50 Hz = 1000 samples: windows start every 25 samples; 0..9 s are label 3, then 5.
    starts = np.arange(0, 1000 - 50 + 1, 25)
    base = np.where(starts + 25 <= 500, 3, 5)  # majority: the window's first half decides ties to 3
    expect = np.array([base[i % len(starts)] for i in range(40)])
    check(np.array_equal(y, expect), "labels are the majority of the segments in each window")
    check(np.all((sp >= 0) & (sp < 810)) and len(set(sp[:16])) == 1 and len(set(sp[16:32])) == 1,
          "one sub-policy index per batch of 16")
    check(meta["schema"] == "imukit.dataset/1" and meta["mode"] == "ppda" and meta["rate_hz"] == 50
          and meta["window"] == 50 and meta["stride"] == 25 and meta["sensors"] == ["watch", "belt"]
          and meta["channels"][:6] == ["watch.ax", "watch.ay", "watch.az", "watch.gx", "watch.gy", "watch.gz"]
          and meta["policy"]["builtin"] == "paper" and meta["seeds"]["seed"] == 11,
          "dataset.json: schema, mode, rate, window, stride, sensors, channels, policy, seed")
    same = all(open(os.path.join(outs["1"], f), "rb").read() == open(os.path.join(outs["2"], f), "rb").read()
               for f in ("X.npy", "y.npy", "sub_policy.npy"))
    check(same, "the same seed gives the same bytes with 1 and 2 threads")

    # Identity batches are the plain simulation: compare with `imukit simulate` (ideal sensors).
    ident = os.path.join(tmp, "ident")
    r = run("augment", "--scene", spath, "--identity-fraction", "1", "--window", "50", "--stride", "50",
            "-o", ident)
    sim_out = os.path.join(tmp, "sim")
    r2 = run("simulate", spath, "-o", sim_out, "--method", "spline")
    if r.returncode == 0 and r2.returncode == 0:
        Xi = np.load(os.path.join(ident, "X.npy"))
        d = np.loadtxt(os.path.join(sim_out, "watch.csv"), delimiter=",", comments="#")
        w = 5  # window 5 starts at sample 250: away from the ends (windows there slide by 3 frames)
        acc, gyr = d[250:300, 4:7], d[250:300, 1:4]
        err = max(np.max(np.abs(Xi[w, :, 0:3] - acc)), np.max(np.abs(Xi[w, :, 3:6] - gyr)))
        check(np.all(np.load(os.path.join(ident, "sub_policy.npy")) == -1) and err < 1e-4,
              f"identity batches equal `imukit simulate` (max diff {err:.2e}, float32)")
    else:
        check(False, "identity dataset and simulate ran")

    # STDA from a recording: the simulated CSV as input, a JSON policy with one sub-policy.
    pol = {"schema": "imukit.policy/1", "name": "jitter_only",
           "sub_policies": [{"hardware": {"accel_noise": 0.5, "gyro_noise": 0.05}}]}
    ppath = os.path.join(tmp, "policy.json")
    json.dump(pol, open(ppath, "w"))
    stda = os.path.join(tmp, "stda")
    r = run("augment", "--input", os.path.join(sim_out, "watch.csv"), "--policy", ppath, "--window", "50",
            "--stride", "50", "-o", stda)
    if r.returncode == 0:
        Xs = np.load(os.path.join(stda, "X.npy"))
        meta = json.load(open(os.path.join(stda, "dataset.json")))
        resid = Xs[5] - np.hstack([d[250:300, 4:7], d[250:300, 1:4]])
        check(Xs.shape == (20, 50, 6) and meta["mode"] == "stda" and abs(meta["rate_hz"] - 50) < 1e-9,
              f"STDA dataset from a recording {Xs.shape}")
        check(0.4 < resid[:, :3].std() < 0.6 and 0.04 < resid[:, 3:].std() < 0.06,
              f"jitter sigma per sensor type ({resid[:, :3].std():.3f} m/s^2, {resid[:, 3:].std():.4f} rad/s)")
    else:
        check(False, "STDA dataset from a recording")

    # Errors: one line, non-zero exit.
    bad = os.path.join(tmp, "bad.json")
    with open(bad, "w") as f:
        f.write('{"schema": "imukit.policy/1",\n "sub_policies": [{"speed": {"method": "warping", "knots": 2, "ratio": 0.5}}]}')
    r = run("augment", "--scene", spath, "--policy", bad, "-o", os.path.join(tmp, "x"))
    check(r.returncode != 0 and "sub_policies[0].speed.ratio" in r.stderr and len(r.stderr.strip().splitlines()) == 1,
          "a bad policy names the JSON path in one line")
    with open(bad, "w") as f:
        f.write('{"schema": "imukit.policy/1",\n  "builtin": paper}')
    r = run("augment", "--scene", spath, "--policy", bad, "-o", os.path.join(tmp, "x"))
    check(r.returncode != 0 and "bad.json:2:" in r.stderr, "a JSON syntax error names file:line")
    r = run("augment", "--scene", spath, "--window", "5000", "-o", os.path.join(tmp, "x"))
    check(r.returncode != 0 and "window" in r.stderr, "a window longer than the scene is refused")
    r = run("augment", "--policy", "paper", "-o", os.path.join(tmp, "x"))
    check(r.returncode != 0 and "--scene" in r.stderr, "no input is refused")
    # A recording whose times do not advance has no measured rate: the label file is not mapped
    # at a made-up rate, the same error as the dataset's (core/sampling.hpp measured_rate_hz).
    still = os.path.join(tmp, "still.csv")
    with open(os.path.join(sim_out, "watch.csv")) as f:
        head = [f.readline(), f.readline()]
    with open(still, "w") as f:
        f.writelines([head[0], head[1], head[1]])
    seg = os.path.join(tmp, "segments.csv")
    with open(seg, "w") as f:
        f.write("start_s,end_s,label\n0,1,3\n")
    r = run("augment", "--input", still, "--labels", seg, "-o", os.path.join(tmp, "x"))
    check(r.returncode == 1 and "still.csv: the time stamps do not advance" in r.stderr,
          "a recording whose times do not advance is refused before its labels are mapped")

check.finish()
