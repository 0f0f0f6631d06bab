"""Sliding windows over labelled recordings, as the paper: a window of T samples every `stride`
samples while a whole window fits, labelled with the majority of its samples' labels (unlabelled
samples vote and lose ties; ties between classes go to the smaller label; windows whose majority
is unlabelled are dropped), and per-channel standardisation with statistics of the training
windows only.

Window starts and majority labels come from imukit (`window_starts`, `window_labels`), the
functions `imukit augment` uses.
"""
import dataclasses

import numpy as np

import imukit

from .recordings import check_sensor_orders


@dataclasses.dataclass
class Windows:
    X: np.ndarray          # (N, T, C) float32, SI units (not standardised)
    y: np.ndarray          # (N,) int64 majority label
    recording: np.ndarray  # (N,) int64 index into the Recordings the windows came from
    start: np.ndarray      # (N,) int64 first sample in that recording

    def __len__(self):
        return len(self.y)

    def subset(self, mask_or_index):
        return Windows(self.X[mask_or_index], self.y[mask_or_index], self.recording[mask_or_index],
                       self.start[mask_or_index])


def make_windows(recordings, window, stride, indices=None):
    """Windows of the recordings `indices` (default all). A recording shorter than a window gives
    none."""
    if window < 2 or stride < 1:
        raise ValueError(f"window must be >= 2 and stride >= 1, got {window}, {stride}")
    idx = range(len(recordings)) if indices is None else indices
    C = recordings.channels
    recordings.rate_hz  # raises FormatError for recordings at different rates (windows of one length)
    check_sensor_orders(recordings)  # channels are stacked by position: one order of sensors
    xs, ys, rs, ss = [], [], [], []
    for i in idx:
        r = recordings[i]
        starts = imukit.window_starts(len(r), window, stride)
        if len(starts) == 0:
            continue
        labels = imukit.window_labels(r.labels, starts, window)
        keep = labels >= 0
        starts, labels = starts[keep], labels[keep]
        # (n, T, C) views of the recording, copied once into float32
        view = np.lib.stride_tricks.sliding_window_view(r.samples, window, axis=0)[starts]
        xs.append(np.transpose(view, (0, 2, 1)).astype(np.float32))
        ys.append(labels)
        rs.append(np.full(len(starts), i, np.int64))
        ss.append(starts.astype(np.int64))
    if not xs:
        return Windows(np.empty((0, window, C), np.float32), np.empty(0, np.int64),
                       np.empty(0, np.int64), np.empty(0, np.int64))
    return Windows(np.ascontiguousarray(np.concatenate(xs)), np.concatenate(ys), np.concatenate(rs),
                   np.concatenate(ss))


class Standardizer:
    """Per-channel (x - mean) / std with the statistics of the windows it was fitted on."""

    def __init__(self, mean, std):
        self.mean = np.asarray(mean, np.float32)
        self.std = np.asarray(std, np.float32)

    @classmethod
    def fit(cls, X):
        flat = X.reshape(-1, X.shape[-1]).astype(np.float64)
        std = flat.std(axis=0)
        # A constant channel is left unscaled rather than divided by zero.
        return cls(flat.mean(axis=0), np.where(std > 0, std, 1.0))

    def __call__(self, X, out=None):
        """Standardised float32 copy of X (or into `out`, which may be X itself)."""
        if out is None:
            out = np.empty(X.shape, np.float32)
        np.subtract(X, self.mean, out=out, casting="same_kind")
        np.divide(out, self.std, out=out)
        return out

    def to_dict(self):
        return {"mean": self.mean.tolist(), "std": self.std.tolist()}
