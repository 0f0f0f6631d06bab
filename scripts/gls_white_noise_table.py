#!/usr/bin/env python3
"""Fits the GLS noise model (`AllanResult.fit`, as `imukit characterize`) to pure white noise and
prints the docs/hwmodel.md table: per recording length, the mean chi^2 / dof, how many axes got a
term other than N detected (its 95 % interval excluding 0), the rms of (N_fit - N) / sigma_N, and
the fit's CPU time per axis. With a correct covariance chi^2 / dof is near 1, each of Q, B, K, R
is detected in about 2.5 % of the axes (one-sided), and the rms is near 1.

usage: PYTHONPATH=build/release/python scripts/gls_white_noise_table.py [SEEDS] [N ...]
  SEEDS recordings of 3 axes each (default 10, seeds 1000 on), N samples at 100 Hz (default
  300000 720000 3000000).
"""
import sys
import time

import numpy as np

import imukit

rate = 100.0
density = 1e-3
seeds = int(sys.argv[1]) if len(sys.argv) > 1 else 10
lengths = [int(x) for x in sys.argv[2:]] or [300000, 720000, 3000000]

print("| samples | taus | axes | chi^2/dof | Q | B | K | R | rms z(N) | fit CPU per axis |")
print("|---|---|---|---|---|---|---|---|---|---|")
for n in lengths:
    detected = {k: 0 for k in "QBKR"}
    chi2, z, cpu = [], [], 0.0
    for seed in range(1000, 1000 + seeds):
        y = np.random.default_rng(seed).standard_normal((n, 3)) * density * np.sqrt(rate)
        r = imukit.allan_deviation(y, rate_hz=rate, modified=False, hadamard=False)
        for axis in range(3):
            start = time.process_time()
            f = r.fit(axis)
            cpu += time.process_time() - start
            for k in detected:
                detected[k] += bool(f.active[k])
            chi2.append(f.chi2_per_dof)
            z.append((f.value["N"] - density) / f.sigma["N"])
    axes = 3 * seeds
    print(f"| {n} | {len(r.tau_s)} | {axes} | {np.mean(chi2):.2f} | "
          + " | ".join(str(detected[k]) for k in "QBKR")
          + f" | {np.sqrt(np.mean(np.square(z))):.2f} | {1e3 * cpu / axes:.0f} ms |", flush=True)
