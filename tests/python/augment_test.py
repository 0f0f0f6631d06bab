"""imukit Python package: STDA on (N, T, C) arrays in place (float32 and float64), policies,
PPDA batches of a scene's windows (by index, description or dict; any thread count; into a
caller's buffer), datasets equal to `imukit augment` for the same seed; bad input.

run: pytest (tests/pytest.ini); $IMUKIT_CLI the command, PYTHONPATH <build>/python
"""
import json
import os
import pickle
import tempfile
import threading
import time
import unittest

import numpy as np

import imukit
from support import run_cli


def batch(n=8, t=60, c=12, dtype=np.float32, seed=0):
    r = np.random.default_rng(seed)
    x = r.normal(size=(n, t, c))
    x[:, :, 2::6] += 9.81  # accelerometer z of each sensor
    return x.astype(dtype)


def address(a):
    return a.__array_interface__["data"][0]


SCENE = {
    "schema": "imukit.scene/1",
    "body": {"default_humanoid": {"height_m": 1.75}},
    "motion": {"procedural": {"rate_hz": 100, "duration_s": 6, "seed": 2}},
    "simulation": {"rate_hz": 50, "seed": 1},
    "sensors": [{"name": "watch", "preset": "left_wrist_watch"}, {"name": "belt", "preset": "waist_belt"}],
}


class Stda(unittest.TestCase):
    def test_in_place_and_new_output(self):
        x = batch()
        before = x.copy()
        y = imukit.stda(x, "magnitude_scaling", 5, sigma=0.1)
        self.assertFalse(np.shares_memory(x, y))  # out=None: a new array ...
        np.testing.assert_array_equal(x, before)  # ... and x untouched
        self.assertEqual(y.dtype, np.float32)
        z = imukit.stda(x, "magnitude_scaling", 5, sigma=0.1, out=x)
        self.assertIs(z, x)  # out=x: augmented in place, no copy
        self.assertEqual(address(z), address(x))
        np.testing.assert_array_equal(x, y)  # same seed, same draws
        buf = np.empty_like(before)
        w = imukit.stda(before, "magnitude_scaling", 5, sigma=0.1, out=buf)
        self.assertTrue(np.shares_memory(w, buf))
        np.testing.assert_array_equal(buf, y)
        # Big-endian input (some .npy and MATLAB files) is read as its values, not refused (found
        # in review); the result is native.
        be = imukit.stda(before.astype(">f4"), "magnitude_scaling", 5, sigma=0.1)
        self.assertEqual(be.dtype, np.float32)
        np.testing.assert_array_equal(be, y)
        swapped = before.astype(">f4")
        with self.assertRaisesRegex(TypeError, "cannot be augmented in place"):
            imukit.stda(swapped, "magnitude_scaling", 5, sigma=0.1, out=swapped)
        with self.assertRaisesRegex(TypeError, "starts: expected int64 sample indices, got int32"):
            imukit.window_labels(np.zeros(100, np.int64), np.zeros(1, np.int32), 50)
        with self.assertRaisesRegex(imukit.Error, r"window 0 \(samples -10 to -10 \+ 50\) is outside the 100 labels"):
            imukit.window_labels(np.zeros(100, np.int64), np.array([-10]), 50)

    def test_magnitude_scaling_is_one_factor_per_window(self):
        x = batch(dtype=np.float64)
        y, draws = imukit.stda(x, "magnitude_scaling", 11, sigma=0.2, return_draws=True)
        self.assertEqual(draws.shape, (8, 1))
        np.testing.assert_allclose(y, x * draws[:, :, None], rtol=1e-15, atol=0)
        self.assertGreater(np.std(draws), 0.05)
        self.assertTrue(np.all(np.abs(draws.values - 1) < 1.0))

    def test_float32_and_float64_agree_and_replay_is_exact(self):
        x64 = batch(dtype=np.float64)
        x32 = x64.astype(np.float32)
        for spec in (imukit.StdaSpec("time_warping", knots=2, ratio=1.5),
                     imukit.StdaSpec("rotation"),
                     imukit.StdaSpec("magnitude_warping", sigma=0.2, knots=3),
                     imukit.StdaSpec("jittering", jitter_sigma=(0.05, 0.01, 0.0, 0.0))):
            a, draws = imukit.stda(x64, spec, 3, return_draws=True)
            b = imukit.stda(x32, spec, 3)
            np.testing.assert_allclose(b, a, rtol=0, atol=2e-5 * np.max(np.abs(a)), err_msg=spec.describe())
            np.testing.assert_array_equal(imukit.replay_stda(x64, spec, draws), a)
            self.assertFalse(np.array_equal(a, x64), spec.describe())

    def test_rotation_keeps_norms_per_sensor(self):
        x = batch(dtype=np.float64)
        y = imukit.stda(x, "rotation", 4, layout=["watch", "belt"])
        for first in (0, 3, 6, 9):
            np.testing.assert_allclose(np.linalg.norm(y[..., first:first + 3], axis=-1),
                                       np.linalg.norm(x[..., first:first + 3], axis=-1), rtol=1e-12)

    def test_rng_object_advances(self):
        x = batch()
        rng = imukit.Rng(5)
        a = imukit.stda(x, "magnitude_scaling", rng, sigma=0.1)
        b = imukit.stda(x, "magnitude_scaling", rng, sigma=0.1)
        self.assertFalse(np.array_equal(a, b))
        np.testing.assert_array_equal(a, imukit.stda(x, "magnitude_scaling", imukit.Rng(5), sigma=0.1))

    def test_bad_input(self):
        x = batch()
        with self.assertRaisesRegex(TypeError, "float32 or float64, got int64"):
            imukit.stda(x.astype(np.int64), "rotation", 1)
        with self.assertRaisesRegex(ValueError, r"\(windows, samples, channels\), got \(60, 12\)"):
            imukit.stda(x[0], "rotation", 1)
        with self.assertRaisesRegex(TypeError, "dtype float64 differs"):
            imukit.stda(x, "rotation", 1, out=np.zeros(x.shape))
        with self.assertRaisesRegex(ValueError, "C-contiguous"):
            imukit.stda(x, "rotation", 1, out=np.zeros((12, 60, 8), np.float32).transpose(2, 1, 0))
        with self.assertRaises(imukit.Error) as e:
            imukit.stda(x, "wobble", 1)
        self.assertIn("magnitude_scaling", str(e.exception))
        with self.assertRaisesRegex(TypeError, "unknown parameter 'sigmaa'"):
            imukit.stda(x, "magnitude_scaling", 1, sigmaa=0.1)
        with self.assertRaises(imukit.Error):
            imukit.StdaSpec("time_warping", ratio=0.5)
        with self.assertRaisesRegex(TypeError, "seed or an imukit.Rng"):
            imukit.stda(x, "rotation", "seed")

    def test_rotation_needs_three_axis_blocks(self):
        """Found in review (2026-11-26): rotation on a batch whose layout has no 3-axis blocks
        (3 channels: the default layout is 3 channels of kind other) returned x unchanged."""
        x = batch(n=2, t=20, c=3, dtype=np.float64)
        with self.assertRaises(imukit.Error) as e:
            imukit.stda(x, "rotation", 1)
        self.assertEqual(str(e.exception),
                         "stda: rotation turns sensors' 3-axis blocks, and the layout has none: the "
                         "default layout of 3 channels (not sensors of 6, ax ay az gx gy gz); name the "
                         "blocks with layout=imukit.ChannelLayout(kinds, sensors)")
        bare = imukit.ChannelLayout(["other"] * 3)
        with self.assertRaises(imukit.Error) as e:
            imukit.stda(x, "rotation", 1, layout=bare)
        self.assertEqual(str(e.exception),
                         "stda: rotation turns sensors' 3-axis blocks, and the layout given has none "
                         "(3 channels, no sensors)")
        # An accelerometer-only watch: its one block is turned, norms kept, the data changed.
        watch = imukit.ChannelLayout(["accelerometer"] * 3, {"watch": [0]})
        self.assertEqual((watch.channels, watch.kinds, watch.sensors), (3, ["accelerometer"] * 3, ["watch"]))
        y, draws = imukit.stda(x, "rotation", 1, layout=watch, return_draws=True)
        self.assertEqual(draws.shape, (2, 3))
        np.testing.assert_allclose(np.linalg.norm(y, axis=-1), np.linalg.norm(x, axis=-1), rtol=1e-12)
        self.assertGreater(np.abs(y - x).max(), 0.1)
        np.testing.assert_array_equal(imukit.replay_stda(x, imukit.StdaSpec("rotation"), draws, layout=watch), y)
        # Jittering needs no blocks: the kinds pick the sigmas (accelerometer: the first).
        j = imukit.stda(x, "jittering", 2, layout=watch, jitter_sigma=(0.5, 0, 0, 0))
        self.assertAlmostEqual(float(np.std(j - x)), 0.5, delta=0.1)
        for kinds, sensors, message in (
                (["accel"] * 3, None, "ChannelLayout: kinds[0] is 'accel', not one of accelerometer, "
                                      "gyroscope, magnetometer, other"),
                (["accelerometer"] * 3, {"w": [1]}, "ChannelLayout: sensors['w'][0]: a 3-axis block at "
                                                    "channel 1 is outside the 3 channels"),
                (["accelerometer"] * 2 + ["gyroscope"], {"w": [0]},
                 "ChannelLayout: sensors['w'][0]: channels 0 to 2 are not of one kind")):
            with self.assertRaises(imukit.Error) as e:
                imukit.ChannelLayout(kinds, sensors)
            self.assertEqual(str(e.exception), message)
        with self.assertRaises(TypeError) as e:
            imukit.ChannelLayout("accelerometer")
        self.assertEqual(str(e.exception), "ChannelLayout: kinds: expected a list of str, got str")

    def test_replay_checks_the_method_and_the_window_count(self):
        """Found in review (2026-11-26): the draws were a bare array and the binding gave them the
        spec's method, so draws of rotation were replayed as magnitude scaling; a size mismatch
        said "12 x 3", 12 being the total count."""
        x = batch(n=4, t=20, c=6, dtype=np.float64)
        y, draws = imukit.stda(x, "rotation", 1, return_draws=True)
        self.assertIsInstance(draws, imukit.StdaDraws)
        self.assertEqual((draws.method, draws.windows, draws.per_window, len(draws)), ("rotation", 4, 3, 4))
        self.assertEqual(repr(draws), "<imukit.StdaDraws rotation: 4 windows x 3>")
        self.assertIs(draws.values.base, draws)  # a view of the draws' memory
        np.testing.assert_array_equal(np.asarray(draws), draws.values)
        with self.assertRaises(imukit.Error) as e:
            imukit.replay_stda(x, imukit.StdaSpec("magnitude_scaling", sigma=0.1), draws)
        self.assertEqual(str(e.exception),
                         "replay_stda: the draws are of rotation, the spec is magnitude_scaling(sigma=0.1)")
        with self.assertRaises(imukit.Error) as e:
            imukit.replay_stda(x[:2], imukit.StdaSpec("rotation"), draws)
        self.assertEqual(str(e.exception), "replay_stda: the draws are for 4 windows x 3 draws, x has 2 windows")
        with self.assertRaises(imukit.Error) as e:
            imukit.replay_stda(x, imukit.StdaSpec("rotation"), imukit.StdaDraws("rotation", draws.values[:, :2]))
        self.assertEqual(str(e.exception),
                         "rotation: replayed draws (4 windows x 2 draws of rotation) do not fit 4 windows x 3 draws")
        with self.assertRaises(TypeError) as e:
            imukit.replay_stda(x, imukit.StdaSpec("rotation"), draws.values)
        self.assertEqual(str(e.exception),
                         "replay_stda: draws: expected the imukit.StdaDraws of stda(..., return_draws=True) "
                         "or imukit.StdaDraws(method, values), got ndarray")
        # Saved values come back with their method, and replay exactly.
        saved = imukit.StdaDraws("rotation", draws.values.copy())
        np.testing.assert_array_equal(imukit.replay_stda(x, imukit.StdaSpec("rotation"), saved), y)

    def test_arguments_are_converted_with_their_names(self):
        """Found in review (2026-11-26): wrong types gave pybind11's "Unable to cast ... to C++ type
        'std::vector<std::__cxx11::basic_string...'", a NumPy integer seed was refused although
        imukit.Rng takes it, and True was seed 1."""
        x = batch(n=2, t=20, c=6)
        cases = [
            (lambda: imukit.stda(x, "rotation", 1, layout="watch"),
             "layout: expected a list of sensor names or an imukit.ChannelLayout, got str"),
            (lambda: imukit.stda(x, "rotation", 1, layout=["watch", 3]), "layout[1]: expected a str, got int"),
            (lambda: imukit.stda(x, "magnitude_scaling", 1, sigma="0.1"), "stda: sigma: expected a number, got str"),
            (lambda: imukit.stda(x, "magnitude_scaling", 1, sigma=True), "stda: sigma: expected a number, got bool"),
            (lambda: imukit.stda(x, "time_warping", 1, knots=2.0), "stda: knots: expected an int, got float"),
            (lambda: imukit.stda(x, "magnitude_scaling", 1, per_channel=1),
             "stda: per_channel: expected a bool, got int"),
            (lambda: imukit.stda(x, 3, 1), "stda: spec: expected an imukit.StdaSpec or a method name, got int"),
            (lambda: imukit.stda(x, "rotation", True), "rng: expected an int seed or an imukit.Rng, got bool"),
            (lambda: imukit.stda(x, "rotation", 1.0), "rng: expected an int seed or an imukit.Rng, got float"),
            (lambda: imukit.Rng(True), "Rng: seed: expected an int, got bool"),
            (lambda: imukit.Rng(1, "2"), "Rng: stream: expected an int, got str"),
        ]
        for call, message in cases:
            with self.assertRaises(TypeError, msg=message) as e:
                call()
            self.assertEqual(str(e.exception), message)
        for value in (2**64, -1):
            with self.assertRaises(imukit.Error) as e:
                imukit.stda(x, "rotation", value)
            self.assertEqual(str(e.exception), f"rng: expected an integer in [0, 18446744073709551615], got {value}")
        with self.assertRaises(ValueError) as e:
            imukit.stda(x, "rotation", 1, max_angle_rad=(1, 2))
        self.assertEqual(str(e.exception), "stda: max_angle_rad: expected 3 numbers")
        # NumPy integers are seeds as ints are (operator.index), for stda as for imukit.Rng.
        top = 2**64 - 1
        for seed in (3, top):
            a = imukit.stda(x, "rotation", np.uint64(seed))
            np.testing.assert_array_equal(a, imukit.stda(x, "rotation", seed))
            np.testing.assert_array_equal(a, imukit.stda(x, "rotation", imukit.Rng(np.uint64(seed))))
        np.testing.assert_array_equal(imukit.stda(x, "rotation", np.int64(3)), imukit.stda(x, "rotation", 3))
        np.testing.assert_array_equal(imukit.stda(x, "magnitude_warping", 4, sigma=np.float32(0.25), knots=np.int32(3)),
                                      imukit.stda(x, "magnitude_warping", 4, sigma=0.25, knots=3))
        self.assertEqual(imukit.Rng(np.int64(3), stream=np.int8(2)).stream, 2)


    def test_a_parameter_the_method_does_not_use_is_refused(self):
        """Found in review (2026-11-27): stda(x, "jittering", seed, sigma=0.2) took sigma, which
        jittering does not read, and added no noise at all; so did ratio= on time scaling."""
        x = batch(dtype=np.float64)
        cases = (
            (lambda: imukit.stda(x, "jittering", 1, sigma=0.2),
             "stda: jittering does not use 'sigma' (it takes jitter_sigma); its noise is "
             "jitter_sigma=[accelerometer, gyroscope, magnetometer, other]"),
            (lambda: imukit.stda(x, "time_scaling", 1, ratio=2.0),
             "stda: time_scaling does not use 'ratio' (it takes lo, hi)"),
            (lambda: imukit.StdaSpec("magnitude_scaling", knots=3),
             "stda: magnitude_scaling does not use 'knots' (it takes sigma, per_channel)"),
            (lambda: imukit.stda(x, "identity", 1, sigma=0.1),
             "stda: identity does not use 'sigma' (it takes no parameters)"),
        )
        for call, message in cases:
            with self.assertRaises(TypeError) as e:
                call()
            self.assertEqual(str(e.exception), message)
        # The parameters a method does use still work, and jitter_sigma adds the noise asked for.
        y = imukit.stda(x, "jittering", 1, jitter_sigma=[0.2, 0.0, 0.0, 0.0], layout=["watch", "belt"])
        self.assertAlmostEqual(float(np.std(y[..., 0:3] - x[..., 0:3])), 0.2, delta=0.02)
        np.testing.assert_array_equal(y[..., 3:6], x[..., 3:6])

    def test_rotation_is_one_rotation_for_every_sensor(self):
        """Found in review (2026-11-27): each sensor drew its own rotation; the paper turns all
        the window's sensors by one R, which keeps their relative orientation."""
        x = batch(dtype=np.float64)
        x[..., 6:12] = x[..., 0:6]  # two sensors measuring the same
        y, draws = imukit.stda(x, "rotation", 9, layout=["watch", "belt"], return_draws=True)
        self.assertEqual(draws.per_window, 3)
        np.testing.assert_array_equal(y[..., 0:6], y[..., 6:12])
        self.assertFalse(np.allclose(y, x))


class Policies(unittest.TestCase):
    def test_builtin_grid(self):
        self.assertEqual(sorted(imukit.builtin_policy_names()), ["imukit", "paper"])
        p = imukit.read_policy("imukit")
        self.assertEqual(len(p), 810)
        d = p.describe()
        self.assertEqual(len(set(d)), 810)
        self.assertTrue(p[0].is_identity)
        self.assertEqual(p.index(d[417]), 417)
        np.testing.assert_allclose(p.probabilities, np.full(810, 1 / 810), rtol=1e-15)
        i = p.sample(3)
        self.assertEqual(i, p.sample(imukit.Rng(3)))
        self.assertTrue(0 <= i < 810)
        back = imukit.parse_policy(p.to_json())
        self.assertEqual(back.describe(), d)
        self.assertGreater(len(p.stda_counterparts(417)), 0)
        with self.assertRaises(imukit.Error):
            imukit.read_policy("nonexistent_policy")

    def test_a_description_two_sub_policies_share_is_refused(self):
        # describe() leaves amplitude joints out: the lookup took the first of the two (review,
        # 2026-11-27); it names both and asks for the index.
        p = imukit.parse_policy(json.dumps({"schema": "imukit.policy/1", "name": "twins", "sub_policies": [
            {"amplitude": {"method": "scaling", "sigma": 0.2, "joints": ["left_elbow"]}},
            {"amplitude": {"method": "scaling", "sigma": 0.2, "joints": ["right_elbow"]}},
            {"amplitude": {"method": "scaling", "sigma": 0.3}}]}))
        d = p.describe()
        self.assertEqual(d[0], d[1])
        with self.assertRaisesRegex(imukit.Error, "sub-policies 0, 1 of policy 'twins' are all described as"):
            p.index(d[0])
        self.assertEqual(p.index(d[2]), 2)


class Ppda(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.scene = imukit.parse_scene(json.dumps(SCENE))
        cls.aug = imukit.Augmenter(cls.scene, window=50)
        cls.policy = imukit.read_policy("imukit")

    def test_shape_layout_and_starts(self):
        a = self.aug
        self.assertEqual((a.window, a.channels, a.rate_hz), (50, 12, 50.0))
        self.assertEqual(a.sensor_names, ["watch", "belt"])
        self.assertEqual(a.sample_count, 301)
        np.testing.assert_array_equal(a.window_starts(25), np.arange(0, 251, 25))
        np.testing.assert_array_equal(imukit.window_starts(301, 50, 25), a.window_starts(25))

    def test_identity_equals_the_simulation(self):
        starts = self.aug.window_starts(25)
        x = self.aug.apply(0, starts, 1, policy=self.policy)
        # The spline re-simulation of the unchanged motion is the scene's spline simulation, to
        # float32 rounding. The first and last windows are left out: there the augmenter's windows
        # differ from the scene's (and from the same samples simulated inside a longer motion) by
        # up to ~1 m/s^2 (reported with issue 11).
        scene = imukit.parse_scene(json.dumps(dict(SCENE, simulation={"rate_hz": 50, "method": "spline"})))
        sim = scene.simulate()
        ref = np.concatenate([sim["watch"].channels(np.float64), sim["belt"].channels(np.float64)], axis=1)
        windows = np.stack([ref[s:s + 50] for s in starts])
        np.testing.assert_allclose(x[1:-1], windows[1:-1], rtol=0, atol=1e-6 * np.max(np.abs(windows)))

    def test_amplitude_knots_stay_three_samples_apart(self):
        """Found in review (2026-11-26): 98 amplitude knots on 100-sample windows read
        20,499 m/s^2. At most (T - 1) / 3 - 1 knots: 15 on these 50-sample windows."""
        starts = self.aug.window_starts(50)
        x = self.aug.apply({"amplitude": {"method": "warping", "sigma": 0.4, "knots": 15}}, starts, 3)
        self.assertTrue(np.all(np.isfinite(x)))
        with self.assertRaisesRegex(
                imukit.Error, r"amplitude warping with 16 knots on windows of 50 samples puts them 2\.88 "
                              r"samples apart; at most 15 knots \(3 samples apart or more\)"):
            self.aug.apply({"amplitude": {"method": "warping", "sigma": 0.4, "knots": 16}}, starts, 3)

    def test_by_index_description_dict_and_object_agree(self):
        starts = self.aug.window_starts(50)
        k = 417
        by_index = self.aug.apply(k, starts, 9, policy=self.policy)
        by_text = self.aug.apply(self.policy.describe()[k], starts, 9, policy=self.policy)
        by_object = self.aug.apply(self.policy[k], starts, 9)
        np.testing.assert_array_equal(by_index, by_text)
        np.testing.assert_array_equal(by_index, by_object)
        self.assertFalse(np.array_equal(by_index, self.aug.apply(0, starts, 9, policy=self.policy)))
        # "By description" as the policy file writes a sub-policy: the same sub-policy, the same batch.
        d = {"amplitude": {"method": "scaling", "sigma": 0.6},
             "speed": {"method": "warping", "knots": 2, "ratio": 1.5},
             "placement": {"rotation_deg": [25, 25, 25]},
             "hardware": {"accel_noise": 0.1, "accel_bias": 0.5, "gyro_noise": 0.01, "gyro_bias": 0.05}}
        self.assertEqual(imukit.SubPolicy.from_dict(d), self.policy[k])
        np.testing.assert_array_equal(self.aug.apply(d, starts, 9), by_index)
        with self.assertRaises(imukit.Error) as e:
            self.aug.apply({"speed": {"method": "scaling", "range": [1.1]}}, starts, 9)
        self.assertIn("sub_policies[0].speed", str(e.exception))

    def test_a_sub_policy_index_is_any_integer_but_a_bool(self):
        """Found in review (2026-11-26, fourth round): np.int64(417) was refused ("sub must be a
        SubPolicy, ...") while 417 was taken, and True ran sub-policy 1."""
        starts = self.aug.window_starts(50)
        by_int = self.aug.apply(417, starts, 9, policy=self.policy)
        for k in (np.int64(417), np.uint16(417), np.array([417])[0]):
            np.testing.assert_array_equal(self.aug.apply(k, starts, 9, policy=self.policy), by_int)

        def message(sub, error):
            with self.assertRaises(error) as e:
                self.aug.apply(sub, starts, 9, policy=self.policy)
            return str(e.exception)
        for sub, name in ((True, "bool"), (np.True_, "bool_"), (417.0, "float"), (np.float64(417), "float64")):
            self.assertEqual(message(sub, TypeError), "Augmenter.apply: sub must be a SubPolicy, a dict, "
                                                      f"an index or a description, got {name}")
        for sub in (810, -1, np.int64(810), 2**64):
            self.assertEqual(message(sub, IndexError), f"Augmenter.apply: sub: {int(sub)} is not a "
                                                       "sub-policy index of policy 'imukit' (0 to 809)")

    def test_too_short_windows_are_flagged_and_nan_in_a_new_array(self):
        """Windows sped up beyond the scene's motion: flagged, their rows left as they were in
        `out`, NaN in a new array (found in review, 2026-11-26: unset memory)."""
        sub = {"speed": {"method": "scaling", "range": [1.0, 8.0]}}
        starts = self.aug.window_starts(50)
        with self.assertRaisesRegex(imukit.Error, "at this speed needs"):
            self.aug.apply(sub, starts, 3)
        flags = np.zeros(len(starts), bool)
        x = self.aug.apply(sub, starts, 3, too_short=flags)
        self.assertTrue(0 < flags.sum() < len(starts))
        self.assertTrue(np.isnan(x[flags]).all())
        self.assertTrue(np.isfinite(x[~flags]).all())
        out = np.full_like(x, 5.0)
        self.aug.apply(sub, starts, 3, out=out, too_short=flags)
        self.assertTrue((out[flags] == 5.0).all())
        np.testing.assert_array_equal(out[~flags], x[~flags])
        with self.assertRaisesRegex(TypeError, "too_short: expected a bool array, got uint8"):
            self.aug.apply(sub, starts, 3, too_short=np.zeros(len(starts), np.uint8))
        with self.assertRaisesRegex(ValueError, r"too_short: expected shape \(%d,\)" % len(starts)):
            self.aug.apply(sub, starts, 3, too_short=np.zeros(len(starts) + 1, bool))
        with self.assertRaisesRegex(ValueError, "too_short: must be C-contiguous"):
            self.aug.apply(sub, starts, 3, too_short=np.zeros(2 * len(starts), bool)[::2])

    def test_threads_and_caller_buffer(self):
        starts = np.tile(self.aug.window_starts(25), 3)
        one = self.aug.apply(417, starts, 4, policy=self.policy, threads=1)
        out = np.empty((len(starts), 50, 12), np.float32)
        two = self.aug.apply(417, starts, 4, policy=self.policy, threads=2, out=out)
        self.assertIs(two, out)
        np.testing.assert_array_equal(one, out)
        with self.assertRaisesRegex(TypeError, "float32"):
            self.aug.apply(0, starts, 4, policy=self.policy, out=np.empty((len(starts), 50, 12)))
        with self.assertRaisesRegex(ValueError, "expected shape"):
            self.aug.apply(0, starts, 4, policy=self.policy, out=np.empty((2, 50, 12), np.float32))
        with self.assertRaises(IndexError):
            self.aug.apply(810, starts, 4, policy=self.policy)
        with self.assertRaisesRegex(ValueError, "policy="):
            self.aug.apply(3, starts, 4)


def run_together(*targets):
    """Runs each function in a thread of its own and waits for all of them."""
    threads = [threading.Thread(target=t) for t in targets]
    for th in threads:
        th.start()
    for th in threads:
        th.join()


class SceneLock(unittest.TestCase):
    def test_a_scene_changed_by_another_thread_is_read_under_its_lock(self):
        """Found in review (2026-11-26): Augmenter(scene) and generate_dataset(scene) read the scene
        with the GIL released and without its lock while Scene.add_sensor appended to its sensors:
        the interpreter crashed (SIGSEGV; this test did in most runs). Now every reader holds the
        scene's lock and every change takes it as well: each augmenter built while sensors are added
        holds a whole prefix of them, and its batches equal those of one built from a scene made
        with the same sensors in one thread; datasets made while the setters run equal one made
        alone."""
        body = imukit.Body.default_humanoid()
        motion = imukit.ProceduralMotion(len(body), rate_hz=100, frames=400, seed=2)

        def scene_with(n):
            scene = imukit.Scene(body, motion, seed=3)
            for i in range(n):
                scene.add_sensor(f"s{i}", joint="left_wrist", position_m=[0, 0, 0.001 * i])
            return scene

        def build_while_adding():
            scene = scene_with(1)
            built, done = [], threading.Event()

            def build():
                while not done.is_set():
                    aug = imukit.Augmenter(scene, window=50)
                    names = aug.sensor_names  # (s0 ... s{k-1}, each once: last == s{k-1} suffices)
                    built.append((len(names), names[-1], aug if len(built) < 3 else None))

            def add():
                # 4000 sensors: the vector moves 12 times, the last ones megabytes that are unmapped.
                for i in range(1, 4000):
                    scene.add_sensor(f"s{i}", joint="left_wrist", position_m=[0, 0, 0.001 * i])
                    time.sleep(0)
                done.set()

            run_together(build, add)
            self.assertEqual(len(scene.sensors), 4000)
            return built

        built = build_while_adding() + build_while_adding()  # two rounds: the race is a matter of luck
        self.assertGreater(len(built), 10)
        for k, last, _ in built:
            self.assertEqual(last, f"s{k - 1}")
        policy = imukit.read_policy("imukit")
        starts = np.array([0, 150, 350], np.int64)
        kept = [aug for _, _, aug in built if aug is not None]  # the first three of each round
        self.assertEqual(len(kept), 6)
        for aug in kept:
            k = len(aug.sensor_names)
            self.assertEqual(aug.sensor_names, [f"s{i}" for i in range(k)])
            alone = imukit.Augmenter(scene_with(k), window=50)
            np.testing.assert_array_equal(aug.apply(417, starts, 5, policy=policy),
                                          alone.apply(417, starts, 5, policy=policy))

        # The setters take the lock while datasets are made from the scene.
        small = scene_with(2)
        alone = imukit.generate_dataset(small, policy, window=50, stride=50, count=8, batch_size=4, seed=8)
        made, done = [], threading.Event()

        def generate():
            while not done.is_set() or not made:
                made.append(imukit.generate_dataset(small, policy, window=50, stride=50, count=8, batch_size=4,
                                                    seed=8, threads=1))

        def set_fields():
            for i in range(200):
                small.seed = 3
                small.ground_truth = bool(i % 2)
                small.method = "fd"
                time.sleep(0)
            done.set()

        run_together(generate, set_fields)
        for ds in made:
            np.testing.assert_array_equal(ds.X, alone.X)
        self.assertEqual((small.seed, small.method), (3, "fd"))


class Datasets(unittest.TestCase):
    def test_dataset_equals_the_command(self):
        # (A skip "while augment was not built" hid a broken command until review, 2026-11-27.)
        self.assertIn(" augment", run_cli("--help").stdout)
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "scene.json")
            with open(path, "w") as f:
                json.dump(SCENE, f)
            out = os.path.join(tmp, "ds")
            r = run_cli("augment", "--scene", path, "--policy", "imukit", "--window", 50, "--stride", 25, "--count", 40,
                        "--batch-size", 16, "--seed", 8, "-o", out)
            self.assertEqual(r.returncode, 0, r.stderr)
            X = np.load(os.path.join(out, "X.npy"))
            sub = np.load(os.path.join(out, "sub_policy.npy"))
            scene = imukit.read_scene(path)
        ds = imukit.generate_dataset(scene, imukit.read_policy("imukit"), window=50, stride=25,
                                     count=40, batch_size=16, seed=8, threads=2)
        self.assertEqual(ds.X.shape, (40, 50, 12))
        np.testing.assert_array_equal(ds.sub_policy, sub)
        np.testing.assert_array_equal(ds.X, X)
        self.assertTrue(np.shares_memory(ds.X, ds.X))
        # Without a seed both take the scene's own (found in review: Python took 0).
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "scene.json")
            with open(path, "w") as f:
                json.dump(SCENE, f)
            out = os.path.join(tmp, "ds")
            r = run_cli("augment", "--scene", path, "--policy", "imukit", "--window", 50, "--stride", 25,
                        "--count", 16, "--batch-size", 8, "-o", out)
            self.assertEqual(r.returncode, 0, r.stderr)
            X = np.load(os.path.join(out, "X.npy"))
        ds = imukit.generate_dataset(scene, imukit.read_policy("imukit"), window=50, stride=25, count=16,
                                     batch_size=8)
        np.testing.assert_array_equal(ds.X, X)

    def test_options_object(self):
        # imukit.DatasetOptions: the C++ fields and defaults, but threads 0 (all cores) in Python.
        o = imukit.DatasetOptions()
        self.assertEqual((o.window, o.stride, o.count, o.batch_size, o.seed, o.threads, o.normalize,
                          o.identity_fraction, o.method, o.max_bytes),
                         (100, 25, 0, 256, 0, 0, False, 0.0, "spline", 0))
        o = imukit.DatasetOptions(window=50, stride=25, count=40, batch_size=16, seed=8, method="fd")
        self.assertEqual((o.window, o.count, o.batch_size, o.seed, o.method), (50, 40, 16, 8, "fd"))
        o.method = "spline"
        self.assertEqual(o.method, "spline")
        # options= gives exactly what the same keywords give; keywords override its fields on a copy.
        scene, policy = imukit.parse_scene(json.dumps(SCENE)), imukit.read_policy("imukit")
        by_keywords = imukit.generate_dataset(scene, policy, window=50, stride=25, count=40, batch_size=16, seed=8)
        by_options = imukit.generate_dataset(scene, policy, options=o)
        np.testing.assert_array_equal(by_options.X, by_keywords.X)
        np.testing.assert_array_equal(by_options.sub_policy, by_keywords.sub_policy)
        seed9 = imukit.generate_dataset(scene, policy, options=o, seed=9, threads=1)
        np.testing.assert_array_equal(
            seed9.X, imukit.generate_dataset(scene, policy, window=50, stride=25, count=40, batch_size=16, seed=9).X)
        self.assertFalse(np.array_equal(seed9.X, by_options.X))
        self.assertEqual((o.seed, o.threads), (8, 0))
        # A name that is not a field, a value of the wrong type, an unknown method: clear errors.
        with self.assertRaisesRegex(TypeError, "generate_dataset: unexpected keyword argument 'windw'"):
            imukit.generate_dataset(scene, policy, windw=50)
        with self.assertRaisesRegex(TypeError, "DatasetOptions: unexpected keyword argument 'describe'"):
            imukit.DatasetOptions(describe=1)
        # A value out of range is an imukit.Error naming the field (before 2026-11-27 pybind11's
        # "incompatible function arguments", a TypeError).
        with self.assertRaises(imukit.Error) as e:
            imukit.DatasetOptions(window=-1)
        self.assertEqual(str(e.exception), "DatasetOptions: window: expected an integer in [2, 10000000], got -1")
        with self.assertRaises(imukit.Error):
            imukit.DatasetOptions(method="splines")

    def test_sub_policy_list_equals_the_command(self):
        r = run_cli("augment", "--policy", "paper", "--list-sub-policies")
        self.assertEqual(r.returncode, 0, r.stderr)
        described = imukit.read_policy("paper").describe()
        rows = [line.split(None, 2) for line in r.stdout.splitlines()[1:] if line.strip()]
        self.assertEqual(len(rows), 810)
        self.assertEqual([int(row[0]) for row in rows], list(range(810)))
        self.assertEqual([row[2] for row in rows], described)

    def test_recorded_streams_and_windows(self):
        sim = imukit.parse_scene(json.dumps(SCENE)).simulate()
        starts = imukit.window_starts(len(sim["watch"]), 50, 50)
        x = imukit.extract_windows([sim["watch"], sim["belt"]], starts, 50)
        self.assertEqual(x.shape, (len(starts), 50, 12))
        np.testing.assert_array_equal(x[2, :, :6], sim["watch"].channels()[100:150])
        ds = imukit.generate_dataset(sim, imukit.read_policy("imukit"), window=50, stride=50, seed=1)
        self.assertEqual(ds.X.shape, (len(starts), 50, 12))
        self.assertEqual(ds.info["mode"], "stda")
        labels = np.repeat(np.arange(7, dtype=np.int64), 43)[:301]
        np.testing.assert_array_equal(imukit.window_labels(labels, starts, 50),
                                      [np.bincount(labels[s:s + 50]).argmax() for s in starts])

    def test_labels_below_minus_one_are_refused(self):
        """Found in review (2026-11-26): window_labels and generate_dataset took labels below -1
        (-1 is "no label") and wrote them as classes."""
        scene = imukit.parse_scene(json.dumps(SCENE))
        labels = np.zeros(301, np.int64)
        labels[:10] = -1
        labels[120] = -2
        message = "labels[120] is -2; a label is a class index >= 0, or -1 for none"
        with self.assertRaises(imukit.Error) as e:
            imukit.window_labels(labels, np.array([100], np.int64), 50)
        self.assertEqual(str(e.exception), message)
        with self.assertRaises(imukit.Error) as e:
            imukit.generate_dataset(scene, imukit.read_policy("imukit"), labels=labels, window=50, stride=50, count=2)
        self.assertEqual(str(e.exception), message)
        labels[120] = 0
        ds = imukit.generate_dataset(scene, imukit.read_policy("imukit"), labels=labels, window=50, stride=50)
        np.testing.assert_array_equal(ds.y, np.zeros(6, np.int64))


class BindingsReview(unittest.TestCase):
    """Found in review, 2026-11-27 (the bindings review): dtypes compared by identity, windows
    without the command's bounds, writable draws, integers through pybind11's casters."""

    @classmethod
    def setUpClass(cls):
        cls.scene = imukit.parse_scene(json.dumps(SCENE))
        cls.aug = imukit.Augmenter(cls.scene, window=50)

    def test_unpickled_float32_arrays_are_float32(self):
        # A float32 dtype equal to NumPy's but another object (every array that went through
        # pickle) ran through the float64 code: wrong values, and heap corruption in bigger batches.
        x = batch(n=2, t=20, c=6)
        xp = pickle.loads(pickle.dumps(x))
        ref, draws = imukit.stda(x, "magnitude_scaling", 5, sigma=0.1, return_draws=True)
        got = imukit.stda(xp, "magnitude_scaling", 5, sigma=0.1)
        self.assertEqual(got.dtype, np.float32)
        np.testing.assert_array_equal(got, ref)
        out = pickle.loads(pickle.dumps(np.zeros_like(x)))  # was "out: dtype float32 differs from the input's float32"
        imukit.stda(x, "magnitude_scaling", 5, sigma=0.1, out=out)
        np.testing.assert_array_equal(out, ref)
        np.testing.assert_array_equal(imukit.replay_stda(xp, imukit.StdaSpec("magnitude_scaling", sigma=0.1), draws), ref)
        # PPDA: out= was "out: PPDA writes float32, got float32".
        starts = np.array([0, 25], np.int64)
        ref = self.aug.apply({"speed": {"method": "identity"}}, starts, 1)
        buf = pickle.loads(pickle.dumps(np.zeros((2, 50, 12), np.float32)))
        self.aug.apply({"speed": {"method": "identity"}}, starts, 1, out=buf)
        np.testing.assert_array_equal(buf, ref)
        flags = pickle.loads(pickle.dumps(np.zeros(2, bool)))
        self.aug.apply({"speed": {"method": "identity"}}, starts, 1, too_short=flags)

    def test_any_8_byte_signed_integer_array_is_int64(self):
        # np.longlong, unpickled int64 and big-endian int64 were "expected int64 ..., got int64".
        starts = np.array([0, 25], np.int64)
        ref = self.aug.apply({"speed": {"method": "identity"}}, starts, 1)
        for s in (starts.astype(np.longlong), pickle.loads(pickle.dumps(starts)), starts.astype(">i8")):
            np.testing.assert_array_equal(self.aug.apply({"speed": {"method": "identity"}}, s, 1), ref)
            np.testing.assert_array_equal(imukit.window_labels(np.arange(100, dtype=s.dtype), s, 50), [0, 25])
        series = imukit.Series(np.array([0, 10, 20], ">i8"), np.zeros((3, 3)))
        np.testing.assert_array_equal(series.t, [0, 10, 20])
        with self.assertRaises(TypeError) as e:
            imukit.window_labels(np.zeros(100, np.int32), starts, 50)
        self.assertEqual(str(e.exception), "labels: expected int64 class labels, got int32")

    def test_windows_take_the_commands_range(self):
        # extract_windows(window=0) gave (N, 0, 6) and 2^64 - 1 read out of range; Augmenter took
        # a window of 2^64 - 1. --window is a whole number in [2, 1e7], --stride in [1, 1e7].
        sim = self.scene.simulate()
        starts = np.array([0], np.int64)
        for window in (0, 1, 2**64 - 1, 10**7 + 1):
            with self.assertRaises(imukit.Error) as e:
                imukit.extract_windows([sim["watch"]], starts, window)
            self.assertEqual(str(e.exception),
                             f"extract_windows: window: expected an integer in [2, 10000000], got {window}")
        with self.assertRaises(imukit.Error) as e:
            imukit.extract_windows([sim["watch"]], starts, 10**7)
        self.assertEqual(str(e.exception), "windowing: a window lies outside the streams")
        with self.assertRaises(imukit.Error) as e:
            imukit.Augmenter(self.scene, window=2**64 - 1)
        self.assertEqual(str(e.exception),
                         "Augmenter: window: expected an integer in [2, 10000000], got 18446744073709551615")
        with self.assertRaises(imukit.Error) as e:
            imukit.Augmenter(self.scene, window=302)
        self.assertEqual(str(e.exception), "augment: the motion has 301 samples at 50 Hz, fewer than a window of 302")
        with self.assertRaises(imukit.Error) as e:
            self.aug.window_starts(0)
        self.assertEqual(str(e.exception), "Augmenter.window_starts: stride: expected an integer in [1, 10000000], got 0")
        with self.assertRaises(TypeError) as e:
            imukit.window_starts(301, True, 25)
        self.assertEqual(str(e.exception), "window_starts: window: expected an int, got bool")

    def test_draws_are_finite_and_read_only(self):
        # NaN or inf draws were replayed into NaN windows, and writing into draws.values changed
        # what replay_stda used.
        x = batch(n=4, t=20, c=6)
        spec = imukit.StdaSpec("rotation")
        values = np.zeros((4, 3))
        values[2, 1] = np.inf
        with self.assertRaises(imukit.Error) as e:
            imukit.StdaDraws("rotation", values)
        self.assertEqual(str(e.exception), "StdaDraws: values[2, 1] is inf; draws are finite numbers")
        _, draws = imukit.stda(x, spec, 3, return_draws=True)
        for view in (draws.values, np.asarray(draws), draws[0]):
            self.assertFalse(view.flags.writeable)
            with self.assertRaises(ValueError):
                view[0] = np.inf

    def test_integers_go_through_the_argument_helpers(self):
        # pybind11's casters took True as 1 and seeds from 2^63 (which Scene(seed=) and
        # `imukit augment --seed` refuse), and said "incompatible function arguments" for -1.
        cases = [
            (lambda: imukit.DatasetOptions(seed=True), TypeError, "DatasetOptions: seed: expected an int, got bool"),
            (lambda: imukit.DatasetOptions(seed=2**63), imukit.Error,
             "DatasetOptions: seed: expected an integer in [0, 9223372036854775807], got 9223372036854775808"),
            (lambda: imukit.DatasetOptions(seed=-1), imukit.Error,
             "DatasetOptions: seed: expected an integer in [0, 9223372036854775807], got -1"),
            (lambda: imukit.DatasetOptions(stride=0), imukit.Error,
             "DatasetOptions: stride: expected an integer in [1, 10000000], got 0"),
            (lambda: imukit.DatasetOptions(batch_size=0), imukit.Error,
             "DatasetOptions: batch_size: expected an integer in [1, 10000000], got 0"),
            (lambda: imukit.DatasetOptions(count=10**12 + 1), imukit.Error,
             "DatasetOptions: count: expected an integer in [0, 1000000000000], got 1000000000001"),
            (lambda: imukit.DatasetOptions(threads=1025), imukit.Error,
             "DatasetOptions: threads: expected an integer in [0, 1024], got 1025"),
            (lambda: imukit.Rng(1).child(True), TypeError, "Rng.child: index: expected an int, got bool"),
            (lambda: imukit.read_policy("imukit")[True], TypeError, "Policy: index: expected an int, got bool"),
        ]
        for call, error, message in cases:
            with self.assertRaises(error) as e:
                call()
            self.assertEqual(str(e.exception), message)
        o = imukit.DatasetOptions(seed=np.int64(2**63 - 1), window=np.int32(50))
        self.assertEqual((o.seed, o.window), (2**63 - 1, 50))
        self.assertEqual(imukit.Rng(1).child(np.uint64(3)).next_u64(), imukit.Rng(1).child(3).next_u64())
        policy = imukit.read_policy("imukit")
        self.assertEqual(policy[-1], policy[len(policy) - 1])
        with self.assertRaisesRegex(IndexError, "sub-policy index out of range"):
            policy[len(policy)]
