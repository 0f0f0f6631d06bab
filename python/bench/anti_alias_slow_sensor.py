"""Time and peak memory of simulating one left wrist watch on a procedural motion whose frames
come far faster than the sensor's samples, anti-aliased or point-sampled (docs/benchmarks.md,
"Anti-aliasing").

  PYTHONPATH=build/release/python /usr/bin/python3 python/bench/anti_alias_slow_sensor.py \\
      RATE_HZ {0|1} [MOTION_HZ=1000] [DURATION_S=1200]

Run each case in its own process: the peak memory is the process's (ru_maxrss).
"""
import os
import resource
import sys
import time

import imukit

BVH = os.path.join(os.path.dirname(__file__), "..", "..", "examples", "motion", "cmu_131_01_walk_2s.bvh")


def main():
    rate = float(sys.argv[1])
    anti_alias = sys.argv[2] == "1"
    motion_hz = int(sys.argv[3]) if len(sys.argv) > 3 else 1000
    duration_s = float(sys.argv[4]) if len(sys.argv) > 4 else 1200.0
    body, _, _ = imukit.read_bvh(BVH)
    motion = imukit.ProceduralMotion(len(body), rate_hz=motion_hz, seed=3)
    scene = imukit.Scene(body, motion, rate_hz=rate, anti_alias=anti_alias,
                         frames=int(duration_s * motion_hz) + 1)
    scene.add_sensor("w", preset="left_wrist_watch")
    t0 = time.perf_counter()
    samples = len(scene.simulate()["w"].t)
    seconds = time.perf_counter() - t0
    peak_mib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"{rate:g} Hz from {motion_hz} Hz frames, {duration_s:g} s, anti_alias={anti_alias}: "
          f"{samples} samples in {seconds:.1f} s, peak {peak_mib:.0f} MiB")


if __name__ == "__main__":
    main()
