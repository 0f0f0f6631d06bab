#!/usr/bin/env python3
"""Call overhead of the Python package: the same work called from Python and looped in C++.

For a batch of 256 windows (100 samples, 2 sensors = 12 channels):
  ppda  Augmenter.apply(sub-policy k, starts, seed, out=buffer) against PpdaAugmenter::apply
  stda  imukit.stda(x, spec, seed, out=x) on a float32 (256, 100, 12) array against apply_stda
and a 1-window PPDA call, where the fixed cost of the Python call shows most. The C++ side runs in
the same process and library build (imukit._imukit._bench), so the difference is the binding:
argument checks, array wrapping, the GIL hand-off. Medians of interleaved repeats (the machine is
shared: compare the ratio, not the absolute times).

    PYTHONPATH=build/release/python python3 python/bench/overhead.py [--repeats 30] [--threads 1]
"""
import argparse
import json
import statistics
import time

import numpy as np

import imukit
from imukit._imukit import _bench

SCENE = {
    "schema": "imukit.scene/1",
    "body": {"default_humanoid": {"height_m": 1.75}},
    "motion": {"procedural": {"rate_hz": 100, "duration_s": 60, "seed": 1}},
    "simulation": {"rate_hz": 50},
    "sensors": [{"name": "watch", "preset": "left_wrist_watch"},
                {"name": "phone", "preset": "right_front_pocket_phone"}],
}


def python_seconds(call, repeats):
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        call()
        out.append(time.perf_counter() - t0)
    return out


def compare(name, py_call, cpp_call, repeats, rows):
    py_call(), cpp_call(1)  # warm up (workspaces, caches)
    py, cpp = [], []
    for _ in range(repeats):  # interleaved, so load changes hit both sides alike
        py += python_seconds(py_call, 1)
        cpp += cpp_call(1)
    p, c = statistics.median(py), statistics.median(cpp)
    rows.append((name, p, c))
    print(f"{name:<34} python {1e3 * p:9.3f} ms   C++ {1e3 * c:9.3f} ms   "
          f"overhead {1e6 * (p - c):8.1f} us ({100 * (p / c - 1):+6.2f} %)")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=30)
    ap.add_argument("--threads", type=int, default=1, help="C++ threads for PPDA (same on both sides)")
    ap.add_argument("--sub-policy", type=int, default=417, help="index into the 'imukit' policy")
    args = ap.parse_args()

    scene = imukit.parse_scene(json.dumps(SCENE))
    aug = imukit.Augmenter(scene, window=100)
    policy = imukit.read_policy("imukit")
    k = args.sub_policy
    starts = np.resize(aug.window_starts(10), 256)
    buffer = np.empty((256, 100, aug.channels), np.float32)
    print(f"sub-policy {k}: {policy.describe()[k]}; {len(starts)} windows x 100 samples x {aug.channels} "
          f"channels, {args.threads} thread(s)")
    rows = []
    compare("ppda, 256 windows", lambda: aug.apply(k, starts, 5, policy=policy, out=buffer, threads=args.threads),
            lambda r: _bench.ppda_seconds(aug, policy, k, starts, 5, args.threads, r), args.repeats, rows)
    one = starts[:1].copy()
    buf1 = np.empty((1, 100, aug.channels), np.float32)
    compare("ppda, 1 window", lambda: aug.apply(k, one, 5, policy=policy, out=buf1, threads=1),
            lambda r: _bench.ppda_seconds(aug, policy, k, one, 5, 1, r), args.repeats, rows)
    x = aug.apply(0, starts, 1, policy=policy)
    for spec in (imukit.StdaSpec("magnitude_scaling", sigma=0.1), imukit.StdaSpec("time_warping", knots=2, ratio=1.5)):
        compare(f"stda {spec.method}, 256 windows", lambda: imukit.stda(x, spec, 5, out=x),
                lambda r: _bench.stda_seconds(x, spec, 5, r), args.repeats, rows)


if __name__ == "__main__":
    main()
