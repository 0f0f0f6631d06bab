#!/usr/bin/env python3
"""Overlapping Allan deviation in NumPy, the formula most tools use (phase from a cumulative
sum, second differences at lag m), timed per axis on the same tau grid as imukit's benchmark.
Run by bench_hwmodel (same run, same data, same grid), which passes the data as .npy.

usage: allan_numpy.py DATA.npy RATE_HZ M1,M2,...   (DATA shape (axes, n) float64)
prints one JSON line: wall and CPU seconds per axis (CPU time is what to compare on a shared
machine; NumPy runs single-threaded here), peak RSS, and the deviations of the first axis.
"""
import json
import resource
import sys
import time

import numpy as np


def oadev(y, rate, ms):
    tau0 = 1.0 / rate
    x = np.concatenate(([0.0], np.cumsum(y))) * tau0
    out = np.empty(len(ms))
    for i, m in enumerate(ms):
        d = x[2 * m:] - 2.0 * x[m:-m] + x[:-2 * m]
        out[i] = np.sqrt(np.sum(d * d) / (2.0 * len(d) * (m * tau0) ** 2))
    return out


data = np.load(sys.argv[1])
rate = float(sys.argv[2])
ms = [int(v) for v in sys.argv[3].split(",")]
times, cpu_times = [], []
first = None
for axis in range(data.shape[0]):
    y = np.ascontiguousarray(data[axis])
    t0, c0 = time.perf_counter(), time.process_time()
    dev = oadev(y, rate, ms)
    times.append(time.perf_counter() - t0)
    cpu_times.append(time.process_time() - c0)
    if first is None:
        first = dev
print(json.dumps({
    "seconds_per_axis": times,
    "cpu_seconds_per_axis": cpu_times,
    "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
    "adev_axis0": first.tolist(),
}))
