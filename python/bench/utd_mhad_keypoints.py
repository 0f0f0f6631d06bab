"""imukit.motion_from_keypoints over every UTD-MHAD trial (docs/keypoints.md, "UTD-MHAD"):
segment lengths per subject (median over trials of each trial's median, and the median
within-trial interquartile range), the input frames each repair touched, where up came from and
its angle from the camera's y axis, the fraction of output frames whose twist was observed, the
run time per trial, and the trials that fail with why.

  PYTHONPATH=build/release/python IMUKIT_DATA_DIR=/work/shared/data \
      /usr/bin/python3 python/bench/utd_mhad_keypoints.py [--limit N]
"""
import argparse
import collections
import os
import sys
import time

import numpy as np

import imukit
from imukit.datasets import utd_mhad

DATA = os.environ.get("IMUKIT_DATA_DIR", os.path.join(os.path.dirname(__file__), "../../../shared/data"))
SEGMENTS = ("spine", "left_clavicle", "left_shoulder", "left_elbow", "right_shoulder", "right_elbow",
            "right_wrist", "left_hip", "left_knee", "right_hip", "right_knee")



def cpu_model():
    """The CPU's model name from /proc/cpuinfo (benchmarks name their CPU), else the machine type."""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return os.uname().machine

def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--limit", type=int, default=0, help="only the first N trials")
    args = ap.parse_args()
    root = os.path.join(DATA, "utd_mhad")
    trials, _ = utd_mhad.list_trials(root)
    if args.limit:
        trials = trials[:args.limit]
    lengths = collections.defaultdict(lambda: collections.defaultdict(list))
    iqr = collections.defaultdict(list)
    flagged = collections.Counter()
    frames_in = 0
    twist = collections.defaultdict(list)
    up_angle, up_source = [], collections.Counter()
    seconds, failures = [], []
    warnings = 0
    trials_with_jumps, invalid_s, total_s = 0, 0.0, 0.0
    for tid in trials:
        tr = utd_mhad.load_trial(root, tid)
        times = np.linspace(0.0, tr.duration_s, len(tr.keypoints))  # README: same span as the IMU
        t0 = time.perf_counter()
        try:
            body, motion, info = imukit.motion_from_keypoints(tr.keypoints, "kinect_v1_20", times=times)
        except imukit.Error as e:
            failures.append((tid.stem, str(e)))
            continue
        seconds.append(time.perf_counter() - t0)
        frames_in += len(tr.keypoints)
        for key in ("missing_frames", "frozen_frames", "swapped_frames", "outlier_frames", "jump_frames"):
            flagged[key] += len(info[key])
        flagged["any"] += info["flagged_frames"]
        warnings += len(info["warnings"])
        trials_with_jumps += bool(info["jump_frames"])
        invalid_s += sum(e - b for b, e in info["invalid_motion_ns"]) * 1e-9
        total_s += (motion.frame_count - 1) / motion.rate_hz
        up_source[info["up_source"]] += 1
        up_angle.append(np.degrees(np.arccos(abs(info["up_input"][1]))))
        for s in info["segments"]:
            lengths[s["joint"]][tid.subject].append(s["length_m"])
            iqr[s["joint"]].append(s["length_iqr_m"])
            twist[s["joint"]].append(s["twist_observed"])
    n = len(seconds)
    print(f"{n} trials converted, {len(failures)} failed; {frames_in} input frames")
    for stem, why in failures:
        print(f"  failed: {stem}: {why}")
    print(f"time per trial, wall clock, one trial at a time: median {1e3 * np.median(seconds):.1f} ms, "
          f"max {1e3 * np.max(seconds):.1f} ms, sum {np.sum(seconds):.2f} s (CPU {cpu_model()})")
    print("input frames touched by each repair (fraction of all input frames):")
    for key in ("missing_frames", "frozen_frames", "swapped_frames", "outlier_frames", "jump_frames", "any"):
        print(f"  {key}: {flagged[key]} ({100.0 * flagged[key] / frames_in:.2f} %)")
    print(f"{warnings} warnings in all; {trials_with_jumps} trials with jumps; invalid_motion covers "
          f"{100 * invalid_s / total_s:.1f} % of the motion time")
    print(f"up from: {dict(up_source)}; angle from the camera's y axis: median {np.median(up_angle):.1f} deg, "
          f"5-95 % {np.percentile(up_angle, 5):.1f}-{np.percentile(up_angle, 95):.1f} deg")
    print()
    print("| segment | " + " | ".join(f"s{s}" for s in range(1, 9)) + " | within-trial IQR (median) | "
          "twist observed (median) |")
    print("|---|" + "---|" * 10)
    for seg in SEGMENTS:
        cells = []
        for s in range(1, 9):
            v = lengths[seg].get(s, [])
            cells.append(f"{100 * np.median(v):.1f} ({100 * (np.percentile(v, 75) - np.percentile(v, 25)):.1f})"
                         if v else "-")
        print(f"| {seg} | " + " | ".join(cells) + f" | {100 * np.median(iqr[seg]):.1f} | "
              f"{np.median(twist[seg]):.2f} |")
    print("(cm: median over the subject's trials of each trial's median length, and in brackets the IQR "
          "over the trials)")


if __name__ == "__main__":
    sys.exit(main())
