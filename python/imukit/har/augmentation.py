"""Online augmentation of training mini-batches, as in the paper: per mini-batch ONE sub-policy
of a policy (imukit's `paper` grid by default) is drawn with its probability, and the whole
batch is augmented under it.

- STDA: the sub-policy's signal-transform counterparts (`Policy.stda_counterparts`:
  amplitude -> magnitude scaling/warping, speed -> time scaling/warping, placement -> rotation
  U[-180, 180] deg, hardware -> jittering) through `imukit.stda` on the real windows. Magnitude,
  time and rotation act on the windows in SI units (a rotation turns the accelerometer and
  gyroscope vectors together, which it cannot do to z-scored channels); jittering is added after
  standardisation, its sigma in standard deviations, as in the paper.
- PPDA: each window's recording is re-simulated from its fitted scene (`imukit.Augmenter`,
  one per recording, built once) under the sub-policy: the window of the scene that corresponds
  to the real window (start + time offset), with the motion's amplitude or speed, the sensor's
  placement or its hardware changed. The batch's windows are grouped by recording, one
  `Augmenter.apply` call per recording, written straight into the batch buffer. A window whose
  re-simulation with nothing changed is implausible next to the real one (`PpdaSource.usable`:
  where Kinect tracking failed, the converted motion can spin a segment) stays real, as do the
  windows of recordings without a fitted scene and those whose scene window would fall outside
  the scene (`PpdaSource.inside_scene`).

Both kinds share the draws that decide which batches are augmented (`SubPolicySampler`), so two
arms with the same seed augment the same batches. Not quite the same number of windows: a PPDA
window the screens keep real is not augmented (8-12 % of them with the screens on UTD-MHAD).
"""
import time

import numpy as np
import torch

import imukit


class SubPolicySampler:
    """Draws one sub-policy index per mini-batch from fixed probabilities. The draw is an inverse
    CDF of one uniform number from the run's own stream, so arms whose probability vectors put
    the same mass on the identity (index `identity`) augment exactly the same batches."""

    def __init__(self, probabilities, seed):
        p = np.asarray(probabilities, np.float64)
        if p.ndim != 1 or np.any(p < 0) or not p.sum() > 0:
            raise ValueError("probabilities must be a non-negative vector with a positive sum")
        self.p = p / p.sum()
        self._cdf = np.cumsum(self.p)
        self._rng = np.random.default_rng([seed, 0x5B9])

    def draw(self):
        u = self._rng.random()
        return int(min(np.searchsorted(self._cdf, u, side="right"), len(self.p) - 1)), None


class GumbelPolicy:
    """Learned sub-policy probabilities (AutoAugHAR-style differentiable search): the loop holds
    logits over the sub-policies; each batch draws k with the Gumbel-max trick (an exact sample of
    softmax(logits)) and carries the relaxed one-hot's k-th entry as a multiplicative gate of
    value 1 on the batch (straight-through), so the loss reaches the logits. Every `every`
    batches the logits take one step on the gradient of the validation loss after a virtual SGD
    step of the model (DARTS' second-order term, by the finite difference of two gradients;
    see Trainer._policy_step)."""

    def __init__(self, count, seed, lr=0.01, temperature=1.0, every=4):
        self.logits = torch.zeros(count, requires_grad=True)
        self.optimizer = torch.optim.Adam([self.logits], lr=lr)
        self.temperature = temperature
        self.every = every
        self._gen = torch.Generator().manual_seed(int(seed) * 7919 + 17)

    @property
    def probabilities(self):
        return torch.softmax(self.logits.detach(), 0).numpy()

    def draw(self):
        """(k, gumbel noise): k = argmax(logits + noise), an exact sample of softmax(logits)."""
        u = torch.rand(self.logits.shape, generator=self._gen).clamp_(1e-12, 1.0 - 1e-12)
        noise = -torch.log(-torch.log(u))
        return int(torch.argmax(self.logits.detach() + noise)), noise

    def gate(self, k, noise):
        """The straight-through gate of draw k: value 1, gradient that of the relaxed one-hot's
        k-th entry softmax((logits + noise) / temperature)[k] (a fresh graph per call)."""
        soft = torch.softmax((self.logits + noise) / self.temperature, 0)
        return soft[k] - soft[k].detach() + 1.0


class PpdaSource:
    """The fitted scenes of the recordings, one imukit.Augmenter each (built on first use)."""

    # A window is usable when its identity re-simulation peaks below PEAK_FACTOR times the real
    # window's peak plus a margin, accelerometer and gyroscope each (see usable()).
    PEAK_FACTOR = 2.0
    PEAK_MARGIN = (10.0, 10.0)  # m/s^2, rad/s

    def __init__(self, recordings, window, method="spline", policy="paper"):
        self.recordings = recordings
        self.window = window
        self.method = method
        self._augmenters = {}
        self._usable = {}  # (recording, start) -> bool
        self._identity = {}  # (recording, start) -> its identity re-simulation, for usable windows
        # The sub-policy that re-simulates with nothing changed (usable(), window_fidelity).
        self.identity_policy = imukit.read_policy(policy) if isinstance(policy, str) else policy
        self.identity = next(k for k in range(len(self.identity_policy))
                             if self.identity_policy[k].is_identity)

    def augmenter(self, i):
        a = self._augmenters.get(i)
        if a is None:
            r = self.recordings[i]
            if r.scene is None:
                raise ValueError(f"recording {r.id}: no fitted scene for PPDA")
            scene = imukit.read_scene(r.scene.path)
            a = imukit.Augmenter(scene, window=self.window, method=self.method)
            if abs(a.rate_hz - r.rate_hz) > 1e-9 * r.rate_hz:
                raise ValueError(f"{r.scene.path}: the scene samples at {a.rate_hz:g} Hz, recording "
                                 f"{r.id} at {r.rate_hz:g} Hz")
            names = a.sensor_names
            missing = [s for s in r.scene.sensors if s not in names]
            if missing:
                raise ValueError(f"{r.scene.path}: no sensor {missing} (the scene has {names})")
            cols = np.concatenate([np.arange(6) + 6 * names.index(s) for s in r.scene.sensors])
            offset = int(round(r.scene.time_offset_s * r.rate_hz))
            bias = None if r.scene.bias is None else np.asarray(r.scene.bias, np.float32).reshape(-1)
            a = (a, None if np.array_equal(cols, np.arange(a.channels)) else cols, offset, bias)
            self._augmenters[i] = a
        return a

    def has_scene(self, i):
        return self.recordings[i].scene is not None

    def usable(self, recording, start):
        """Per window (recording[k], start[k]): whether PPDA may re-simulate it. False without a
        fitted scene, where the scene has no window for it (inside_scene), and where the window
        re-simulated with nothing changed (fitted biases added) peaks above PEAK_FACTOR times
        the real window's peak plus PEAK_MARGIN on the accelerometer or the gyroscope: on
        UTD-MHAD, where Kinect tracking failed (a wrist jumping 0.4 m between frames) the
        converted forearm spins at 140 rad/s and the re-simulation reads up to 1,287 m/s^2
        beside a real peak of 48 (a sensor that saturates at 78); 165 of 4,867 fitted windows,
        found in review. Every sub-policy re-simulates that
        same motion, so such a window stays real under all of them. Cached per window."""
        recording = np.asarray(recording)
        start = np.asarray(start)
        inside = self.inside_scene(recording, start).tolist()
        todo = {}
        for i, s0, ok in zip(recording.tolist(), start.tolist(), inside):
            if ok and (i, s0) not in self._usable:
                todo.setdefault(i, []).append(s0)
        for i, starts in todo.items():
            starts = np.unique(np.asarray(starts, np.int64))
            sim = np.empty((len(starts), self.window, self.recordings[i].samples.shape[1]), np.float32)
            self.resimulate(np.full(len(starts), i), starts, sim)
            for s0, x in zip(starts.tolist(), sim):
                ok = self.plausible(self.recordings[i].samples[s0:s0 + self.window], x)
                self._usable[(i, s0)] = ok
                if ok:
                    self._identity[(i, s0)] = x
        return np.array([ok and self._usable[(i, s0)]
                         for i, s0, ok in zip(recording.tolist(), start.tolist(), inside)], bool)

    def identity_windows(self, recording, start):
        """The identity re-simulations (N, T, C) of windows usable() has found usable (it made
        them; looked up, not checked again)."""
        try:
            return np.stack([self._identity[(i, s0)] for i, s0 in zip(np.asarray(recording).tolist(),
                                                                       np.asarray(start).tolist())])
        except KeyError as e:
            raise ValueError(f"identity_windows: window {e.args[0]} was not found usable (PpdaSource.usable)") from None

    def inside_scene(self, recording, start):
        """Per window: whether its scene window (start + the time offset) lies inside its
        recording's scene; False without a scene. Found in review: the scene window used to be
        clipped into the scene, so near the scene's ends several real windows became one scene
        window (a recording of 400 samples with an offset of 2 s in a scene of 401: starts 275 to
        350 all re-simulated the scene's last window, at 351). Such windows stay real."""
        recording = np.asarray(recording)
        start = np.asarray(start)
        out = np.zeros(len(recording), bool)
        for i in np.unique(recording).tolist():
            if self.has_scene(i):
                m = recording == i
                out[m] = self.scene_starts(i, start[m])[1]
        return out

    def resimulate(self, recording, start, out):
        """The windows re-simulated with nothing changed (fitted biases added) into out."""
        return self.apply(self.identity, recording, start, imukit.Rng(0), self.identity_policy, out)

    def plausible(self, real, sim, factor=None):
        """Whether the re-simulation sim (T, C) of the real window (T, C) peaks at most `factor`
        (default PEAK_FACTOR) times the real peak plus PEAK_MARGIN, accelerometer and gyroscope
        each."""
        factor = self.PEAK_FACTOR if factor is None else factor
        for lo, margin in zip((0, 3), self.PEAK_MARGIN):
            cols = np.concatenate([np.arange(lo, lo + 3) + c for c in range(0, real.shape[1], 6)])
            if np.abs(sim[:, cols]).max() > factor * np.abs(real[:, cols]).max() + margin:
                return False
        return True

    def scene_starts(self, i, starts):
        """The scene's sample index of each real window start of recording i, and whether the
        scene window there lies inside the scene."""
        a, _, offset, _ = self.augmenter(i)
        s = np.asarray(starts, np.int64) + offset
        return s, (s >= 0) & (s <= a.sample_count - self.window)

    def apply(self, sub, recording, start, rng, policy, out, too_short=None):
        """Simulates windows (recording[k], start[k]) under `sub` into out (N, T, C) float32,
        C-contiguous; the windows of one recording must be consecutive, and inside its scene
        (inside_scene). With `too_short` (a bool array of N) a window whose re-timed span the
        drawn speed makes longer than its scene is flagged there and its row of out left as it
        was (imukit.Augmenter.apply), instead of failing the batch: found on 2026-11-26, speed
        scaling up to 2x of a 1 s window of a 2.1 s trial (UTD-MHAD a16_s2_t1) ended a 64-run
        experiment."""
        n = len(recording)
        cut = np.flatnonzero(np.diff(recording)) + 1
        for a0, a1 in zip(np.r_[0, cut], np.r_[cut, n]):
            flags = None if too_short is None else too_short[a0:a1]
            self._apply_one_scene(sub, int(recording[a0]), start[a0:a1], rng, policy, out[a0:a1], flags)
        return out

    def _apply_one_scene(self, sub, i, start, rng, policy, out, too_short):
        aug, cols, _, bias = self.augmenter(i)
        starts, inside = self.scene_starts(i, start)
        if not inside.all():
            raise ValueError(f"recording {self.recordings[i].id}: the window at sample "
                             f"{int(start[~inside][0])} has no scene window inside its scene")
        if cols is None:
            aug.apply(sub, starts, rng, policy=policy, out=out, threads=1, too_short=too_short)
        else:
            x = aug.apply(sub, starts, rng, policy=policy, threads=1, too_short=too_short)
        # The windows made, known once apply has set the flags (found in review: taken before,
        # the flagged rows were overwritten with the scene's unset rows).
        made = slice(None) if too_short is None else ~too_short
        if cols is not None:
            out[made] = x[made][:, :, cols]
        if bias is not None:
            out[made] += bias


class BatchAugmenter:
    """Makes the standardised training batch for one sub-policy of `policy`: kind "none" (real
    windows), "stda" or "ppda". Times the imukit calls (`imukit_seconds`).

    `residual` PPDA adds what the sub-policy changes to the real window instead of replacing it:
    real + (re-simulated under the sub-policy - re-simulated with nothing changed). What the
    fitted scene does not reproduce (on UTD-MHAD the forearm twist the skeleton cannot see,
    tracking errors, the sensor's own noise) stays in the window; the identity sub-policy gives
    the real window exactly. Every sub-policy acts on the simulated part only: the remainder is
    not rotated, scaled or re-timed."""

    def __init__(self, kind, policy, windows, standardize, ppda=None, resimulate_identity=False,
                 output_screen=0.0, residual=False):
        if kind not in ("none", "stda", "ppda"):
            raise ValueError(f"unknown augmentation kind '{kind}'")
        if kind == "ppda" and ppda is None:
            raise ValueError("PPDA needs the recordings' fitted scenes (a PpdaSource)")
        self.kind = kind
        self.policy = policy
        self.windows = windows
        self.standardize = standardize
        self.ppda = ppda
        # sim-only training: even the identity sub-policy's windows are re-simulated
        self.resimulate_identity = resimulate_identity
        if residual and (kind != "ppda" or resimulate_identity):
            raise ValueError("residual augmentation is a kind of PPDA, not sim-only")
        self.residual = residual
        self.imukit_seconds = 0.0
        # PPDA windows left real: no fitted scene, no scene window (inside_scene), an
        # implausible re-simulation (usable()), or an output of the drawn sub-policy above
        # `output_screen` (Settings.output_screen)
        self.output_screen = output_screen
        self.unfitted_windows = 0
        self.outside_scene_windows = 0
        self.implausible_windows = 0
        self.implausible_outputs = 0
        self.too_short_windows = 0  # scene too short for the drawn speed (PpdaSource.apply)
        self.augmented_windows = 0
        self._specs = {}

    def _stda_specs(self, k):
        s = self._specs.get(k)
        if s is None:
            specs = self.policy.stda_counterparts(k, normalized=True)
            s = ([x for x in specs if x.method != "jittering"], [x for x in specs if x.method == "jittering"])
            self._specs[k] = s
        return s

    def batch(self, k, index, seed):
        """(X standardised float32 (B, T, C), y int64) for the windows `index` under sub-policy k.
        The PPDA path reorders the windows by recording; y follows."""
        w = self.windows
        if self.kind == "none" or (self.policy[k].is_identity and not self.resimulate_identity):
            return self.standardize(w.X[index]), w.y[index]
        if self.kind == "stda":
            raw, jitter = self._stda_specs(k)
            X = w.X[index]
            rng = imukit.Rng(seed)
            t0 = time.perf_counter()
            for spec in raw:
                imukit.stda(X, spec, rng, out=X)
            self.imukit_seconds += time.perf_counter() - t0
            X = self.standardize(X, out=X)
            t0 = time.perf_counter()
            for spec in jitter:
                imukit.stda(X, spec, rng, out=X)
            self.imukit_seconds += time.perf_counter() - t0
            self.augmented_windows += len(index)
            return X, w.y[index]
        # Windows without a fitted scene (a failed fit), without a scene window or whose
        # re-simulation is implausible (PpdaSource.usable) stay real, at the end.
        rec = w.recording[index]
        t0 = time.perf_counter()
        fitted = self.ppda.usable(rec, w.start[index])
        self.imukit_seconds += time.perf_counter() - t0
        scene = np.array([self.ppda.has_scene(i) for i in rec.tolist()], bool)
        inside = self.ppda.inside_scene(rec, w.start[index])
        self.unfitted_windows += int((~scene).sum())
        self.outside_scene_windows += int((scene & ~inside).sum())
        self.implausible_windows += int((inside & ~fitted).sum())
        index = np.concatenate([index[fitted][np.argsort(rec[fitted], kind="stable")], index[~fitted]])
        n = int(fitted.sum())
        X = np.empty((len(index),) + w.X.shape[1:], np.float32)
        too_short = np.zeros(n, bool)
        t0 = time.perf_counter()
        self.ppda.apply(k, w.recording[index[:n]], w.start[index[:n]], imukit.Rng(seed), self.policy, X[:n],
                        too_short=too_short)
        self.imukit_seconds += time.perf_counter() - t0
        X[n:] = w.X[index[n:]]
        # A window whose scene is too short for the drawn speed is trained on as the real one.
        X[:n][too_short] = w.X[index[:n][too_short]]
        self.too_short_windows += int(too_short.sum())
        if self.residual:
            made = np.flatnonzero(~too_short)
            X[made] += w.X[index[made]] - self.ppda.identity_windows(w.recording[index[made]], w.start[index[made]])
        n -= int(too_short.sum())
        if self.output_screen > 0:
            # The identity screen cannot see motion a sub-policy reads beyond the window (sped
            # up) or an angle its scaling makes jump: such an output is trained on as the real one.
            bad = [j for j in np.flatnonzero(~too_short).tolist()
                   if not self.ppda.plausible(w.X[index[j]], X[j], self.output_screen)]
            X[bad] = w.X[index[bad]]
            self.implausible_outputs += len(bad)
            n -= len(bad)
        self.augmented_windows += n
        return self.standardize(X, out=X), w.y[index]
