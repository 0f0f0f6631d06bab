"""CPU time of imukit.identify per UTD-MHAD trial, one thread, with the batch's settings
(imukit.datasets.utd_mhad_scenes.FIT), without and with the twist correction, and the keypoint
conversion for comparison (docs/identification.md, "UTD-MHAD"). Process CPU time, so the load of
a shared machine does not count; run it alone (under the CPU lock) all the same.

  PYTHONPATH=build/release/python IMUKIT_DATA_DIR=/work/shared/data \\
      /usr/bin/python3 python/bench/utd_mhad_identify_time.py [--every 4]
"""
import argparse
import os
import sys
import time

import numpy as np

import imukit
from imukit.datasets import utd_mhad
from imukit.datasets.utd_mhad_scenes import _identify, _keypoint_motion, _series

DATA = os.environ.get("IMUKIT_DATA_DIR", os.path.join(os.path.dirname(__file__), "../../../shared/data"))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--every", type=int, default=4, help="every N-th trial (default 4)")
    args = ap.parse_args()
    root = os.path.join(DATA, "utd_mhad")
    trials, _ = utd_mhad.list_trials(root)
    times = {"keypoints": [], "none": [], "twist": [], "rotation": []}
    iterations = {"none": [], "twist": [], "rotation": []}
    samples = []
    for tid in trials[::args.every]:
        tr = utd_mhad.load_trial(root, tid)
        c0 = time.process_time()
        body, motion, info = _keypoint_motion(tr)
        times["keypoints"].append(time.process_time() - c0)
        imu = _series(tr)
        for corr in ("none", "twist", "rotation"):
            c0 = time.process_time()
            try:
                r, _ = _identify(body, motion, imu, info, tr.site, corr)  # as the batch fits
            except imukit.Error:
                continue
            times[corr].append(time.process_time() - c0)
            iterations[corr].append(r.iterations)
            if corr == "twist":
                samples.append(r.samples_used)
    print(f"{len(times['keypoints'])} trials (every {args.every}-th), median {np.median(samples):.0f} "
          f"samples used; CPU ms per trial, median [IQR] (max):")
    for key, v in times.items():
        q1, med, q3 = np.percentile(1e3 * np.array(v), [25, 50, 75])
        it = f", iterations {np.median(iterations[key]):.0f}" if key in iterations else ""
        print(f"  {key}: {med:.0f} [{q1:.0f}, {q3:.0f}] ({1e3 * max(v):.0f}){it}")


if __name__ == "__main__":
    sys.exit(main())
