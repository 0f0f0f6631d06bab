"""PPDA amplitude outputs on every fitted UTD-MHAD window, to compare two versions of imukit
(docs/har.md: the amplitude arms trained before the fix of joints crossing pi).

  PYTHONPATH=<package A> python3 python/bench/utd_mhad_amplitude_outputs.py dump A.npz --scenes S
  PYTHONPATH=<package B> python3 python/bench/utd_mhad_amplitude_outputs.py dump B.npz --scenes S
  PYTHONPATH=<package B> python3 python/bench/utd_mhad_amplitude_outputs.py compare A.npz B.npz --scenes S

`dump` re-simulates every fitted window (window 50, stride 25) under the paper grid's amplitude
sub-policies with Rng(7); `compare` counts the windows whose outputs differ, among them those
PPDA may use (`PpdaSource.usable`), their peaks against the real windows', and the windows
peaking above 4x the real peak + 10 in each version.
"""
import argparse
import os

import numpy as np

import imukit
from imukit.har import augmentation, experiments, utd_mhad, windows

DATA = os.environ.get("IMUKIT_DATA_DIR", os.path.join(os.path.dirname(__file__), "../../../shared/data"))
SUBS = [("amplitude_scaling", k) for k in (1, 2, 3, 4)] + [("amplitude_warping", 5)]


def fitted_windows(scenes):
    R = utd_mhad.load(os.path.join(DATA, "utd_mhad"), scenes=scenes)
    W = windows.make_windows(R, 50, 25)
    return R, W.subset(np.array([R[i].scene is not None for i in W.recording]))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("mode", choices=("dump", "compare"))
    ap.add_argument("files", nargs="+")
    ap.add_argument("--scenes", required=True)
    a = ap.parse_args()
    R, Wf = fitted_windows(a.scenes)
    src = augmentation.PpdaSource(R, 50)
    if a.mode == "dump":
        policy = imukit.read_policy("paper")
        out = {}
        for name, opt in SUBS:
            X = np.empty_like(Wf.X)
            src.apply(experiments.grid_index(name, opt), Wf.recording, Wf.start, imukit.Rng(7), policy, X)
            out[f"{name}:{opt}"] = X
        np.savez(a.files[0], **out)
        return
    old, new = np.load(a.files[0]), np.load(a.files[1])
    usable = src.usable(Wf.recording, Wf.start)
    real_peak = np.abs(Wf.X).max(axis=(1, 2))

    def implausible(X):
        bad = np.zeros(len(X), bool)
        for lo in (0, 3):
            bad |= np.abs(X[..., lo:lo + 3]).max(axis=(1, 2)) > 4 * np.abs(Wf.X[..., lo:lo + 3]).max(axis=(1, 2)) + 10
        return bad

    for k in old.files:
        diff = np.abs(old[k] - new[k]).max(axis=(1, 2)) > 1e-4
        m = diff & usable
        po, pn = np.abs(old[k]).max(axis=(1, 2)), np.abs(new[k]).max(axis=(1, 2))
        print(f"{k}: {diff.sum()} of {len(diff)} windows differ, {m.sum()} of them usable "
              f"(in {len(set(Wf.recording[m].tolist()))} trials); peak there median {np.median(po[m]):.0f} "
              f"(max {po[m].max():.0f}) before, {np.median(pn[m]):.0f} (max {pn[m].max():.0f}) after, "
              f"real {np.median(real_peak[m]):.0f}; usable windows above 4x real + 10: "
              f"{(implausible(old[k]) & usable).sum()} before, {(implausible(new[k]) & usable).sum()} after")


if __name__ == "__main__":
    main()
