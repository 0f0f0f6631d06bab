"""How far PPDA's identity windows are from the plain simulation of the same scene, over fitted
scenes (docs/validation.md, "Fixed 2026-11-27 (fifth session)"): every window start of each
scene's first sensor, the scene's hardware taken out (PPDA draws its own), the largest difference
per scene (float32 output).

  PYTHONPATH=build/release/python /usr/bin/python3 python/bench/ppda_identity_windows.py \\
      FOLDER_OF_FITTED_SCENES [--pattern 'a*_s*_t1'] [--limit 40] [--window 50]

(the fitted UTD-MHAD scenes: python3 -m imukit.datasets.utd_mhad_scenes, docs/har.md).
"""
import argparse
import glob
import json
import os
import tempfile

import numpy as np

import imukit


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folder")
    ap.add_argument("--pattern", default="a*_s*_t1")
    ap.add_argument("--limit", type=int, default=40)
    ap.add_argument("--window", type=int, default=50)
    args = ap.parse_args()
    worst = []
    with tempfile.TemporaryDirectory() as tmp:
        for d in sorted(glob.glob(os.path.join(args.folder, args.pattern)))[:args.limit]:
            with open(os.path.join(d, "scene.json")) as f:
                doc = json.load(f)
            for s in doc["sensors"]:
                s.pop("hardware", None)
            motion = doc["motion"]
            for key in ("quaternion_csv", "bvh"):
                if key in motion:
                    motion[key] = os.path.join(d, motion[key])
            path = os.path.join(tmp, "scene.json")
            with open(path, "w") as f:
                json.dump(doc, f)
            scene = imukit.read_scene(path)
            s = scene.simulate()[scene.sensors[0]]
            x = np.concatenate([s.accel, s.gyro], axis=1)
            method = doc.get("simulation", {}).get("method", "spline")
            aug = imukit.Augmenter(imukit.read_scene(path), window=args.window, method=method)
            starts = np.arange(0, len(x) - args.window + 1)
            y = aug.apply({}, starts, 1, threads=1)
            e = max(float(np.abs(y[k] - x[t:t + args.window]).max()) for k, t in enumerate(starts))
            worst.append(e)
    w = np.array(worst)
    print(f"{len(w)} scenes: identity windows differ from the plain simulation by at most "
          f"{w.max():.3g} (median over scenes {np.median(w):.3g})")


if __name__ == "__main__":
    main()
