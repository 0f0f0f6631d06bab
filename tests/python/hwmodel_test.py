"""imukit Python package: Allan deviation and noise fit on NumPy arrays, equal to what
`imukit characterize` writes for the same recording; closed forms; views; bad input.

run: pytest (tests/pytest.ini); $IMUKIT_CLI the command, PYTHONPATH <build>/python
"""
import json
import math
import os
import tempfile
import unittest

import numpy as np

import imukit
from support import run_cli

RATE = 100.0
GYRO_N = 3e-4   # rad/s/sqrt(Hz)
ACCEL_N = 2e-3  # m/s^2/sqrt(Hz)


def white_recording(n=60000, seed=3):
    r = np.random.default_rng(seed)
    t = np.arange(n, dtype=np.int64) * 10_000_000
    gyro = r.normal(0.0, GYRO_N * math.sqrt(RATE), (n, 3)) + [1e-3, -2e-3, 5e-4]
    accel = r.normal(0.0, ACCEL_N * math.sqrt(RATE), (n, 3)) + [0.0, 0.0, 9.80665]
    return t, accel, gyro


class AllanOnArrays(unittest.TestCase):
    def test_white_noise_matches_closed_form(self):
        t, _, gyro = white_recording(n=30000)
        res = imukit.allan_deviation(gyro, t)
        self.assertAlmostEqual(res.tau0_s, 0.01, places=12)
        self.assertTrue(res.uniform)
        self.assertEqual(res.n, len(t))
        tau = res.tau_s
        np.testing.assert_allclose(tau, res.factors * 0.01, rtol=1e-12)
        adev = res.allan.deviation
        self.assertEqual(adev.shape, (3, len(tau)))
        # White rate noise: ADEV(tau) = N / sqrt(tau); the estimate's relative spread is
        # ~1/sqrt(edf), where the edf assumed white FM (alpha 0; at the longest taus the noisy local
        # slope may suggest another type, whose edf does not apply).
        expected = GYRO_N / np.sqrt(tau)
        white = res.allan.alpha == 0
        self.assertGreater(np.count_nonzero(white[0]), 30)
        rel = np.abs(adev / expected - 1) * np.sqrt(res.allan.edf)
        self.assertLess(np.max(rel[white]), 4.0)
        self.assertTrue(np.all(res.allan.lower <= adev) and np.all(adev <= res.allan.upper))
        self.assertTrue(np.all(res.allan.alpha[:, :10] == 0))  # white FM read from the slope
        fit = res.fit(0)
        self.assertLess(abs(fit["N"] / GYRO_N - 1), 0.03)
        self.assertEqual(fit.value["B"], 0.0)
        self.assertFalse(fit.active["B"])
        # Same curve with uniform times from the rate; float32 input converted.
        same = imukit.allan_deviation(gyro, rate_hz=RATE)
        np.testing.assert_array_equal(same.allan.deviation, adev)
        f32 = imukit.allan_deviation(gyro.astype(np.float32), t)
        np.testing.assert_allclose(f32.allan.deviation, adev, rtol=1e-5)
        one = imukit.allan_deviation(np.ascontiguousarray(gyro[:, 1]), t, hadamard=False)
        # One axis alone: the same sums up to the order of floating-point operations.
        np.testing.assert_allclose(one.allan.deviation[0], adev[1], rtol=1e-14)
        self.assertIsNone(one.hadamard)

    def test_results_are_views_that_keep_the_result_alive(self):
        t, _, gyro = white_recording(n=5000)
        res = imukit.allan_deviation(gyro, t)
        a, b = res.allan.deviation, res.allan.deviation
        self.assertTrue(np.shares_memory(a, b))
        self.assertEqual(a.__array_interface__["data"][0], b.__array_interface__["data"][0])
        self.assertTrue(a.flags.f_contiguous)  # Eigen's column-major rows x taus, not copied
        self.assertTrue(np.shares_memory(res.tau_s, res.tau_s))
        dev = imukit.allan_deviation(gyro, t).modified.deviation
        np.testing.assert_array_equal(dev, res.modified.deviation)

    def test_noise_fit_recovers_model_coefficients(self):
        coeffs = [0.0, 0.01, 0.0, 1e-4, 0.0]  # N and K
        tau = np.logspace(-2, 3, 40)
        adev = [math.sqrt(imukit.model_allan_variance(coeffs, x)) for x in tau]
        self.assertAlmostEqual(adev[0], math.sqrt(0.01**2 / 0.01 + 1e-8 * 0.01 / 3), places=15)
        fit = imukit.fit_noise_model(list(tau), adev, [1000.0] * len(tau), terms=["N", "K"])
        self.assertLess(abs(fit["N"] / 0.01 - 1), 1e-6)
        self.assertLess(abs(fit["K"] / 1e-4 - 1), 1e-6)
        self.assertEqual(fit["Q"], 0.0)
        with self.assertRaisesRegex(imukit.Error, "unknown term 'X'"):
            imukit.fit_noise_model(list(tau), adev, [1000.0] * len(tau), terms=["X"])

    def test_goodness_of_fit_does_not_depend_on_the_grid_density(self):
        """Found in review, 2026-11-27: the whitener floored small eigenvalues but the degrees of
        freedom counted every point, so chi^2/dof of white noise fell from about 1 at 10 points
        per decade to 0.22 at 100, and a record with motion passed the goodness-of-fit gate
        with --points-per-decade 50."""
        rng = np.random.default_rng(7)
        rate, n, density = 100.0, 20000, 1e-3
        means = {}
        for ppd in (10, 100):
            chi = []
            for rep in range(2):
                x = np.ascontiguousarray(rng.standard_normal((n, 3)) * density * math.sqrt(rate))
                r = imukit.allan_deviation(x, rate_hz=rate, points_per_decade=ppd, modified=False, hadamard=False)
                for axis in range(3):
                    f = imukit.fit_noise_model_gls(list(r.tau_s), list(np.asarray(r.allan.deviation)[axis]),
                                                   list(r.factors), n)
                    chi.append(f.chi2_per_dof)
                    self.assertLess(abs(f.value["N"] / density - 1), 0.05)
            means[ppd] = float(np.mean(chi))
        # 6 fits each: the mean of chi^2/dof is 1 within its spread (about 0.1 here).
        for ppd, mean in means.items():
            self.assertTrue(0.7 < mean < 1.4, f"{ppd} points per decade: mean chi2/dof {mean:.2f}")
        self.assertTrue(0.75 < means[100] / means[10] < 1.35, means)
        # Factors that are not the taus' (twice too large: chi^2/dof 0.64 for 1.27, no error
        # until the same review), or more than n holds, are refused.
        tau, dev, factors = list(r.tau_s), list(np.asarray(r.allan.deviation)[0]), list(r.factors)
        with self.assertRaisesRegex(imukit.Error, "tau, factors and n must come from one Allan deviation"):
            imukit.fit_noise_model_gls(tau, dev, [2 * m for m in factors[:1]] + factors[1:], n)
        with self.assertRaisesRegex(imukit.Error, "cannot give an Allan deviation at factor"):
            imukit.fit_noise_model_gls(tau, dev, factors, 2 * max(factors))


def characterized_by_the_command(test, seed):
    """A white-noise recording written as EuRoC CSV, the profile `imukit characterize` writes for
    it (as a dict) and the recording read back as a Series."""
    t, accel, gyro = white_recording(n=20000, seed=seed)
    with tempfile.TemporaryDirectory() as tmp:
        src = os.path.join(tmp, "static.csv")
        imukit.write_euroc_csv(src, t, accel, gyro)
        profile = os.path.join(tmp, "profile.json")
        r = run_cli("characterize", src, "-o", profile)
        test.assertEqual(r.returncode, 0, r.stderr)
        return json.load(open(profile)), imukit.read_euroc_csv(src)


class EqualToCharacterize(unittest.TestCase):
    def test_profile_numbers_equal_python_fit(self):
        p, s = characterized_by_the_command(self, seed=9)
        for sensor, data in (("gyroscope", s.gyro), ("accelerometer", s.accel)):
            res = imukit.allan_deviation(data, s.t)
            noise = p[sensor]["noise"]
            np.testing.assert_allclose(noise["allan"]["tau"], res.tau_s, rtol=1e-15)
            for axis in range(3):
                np.testing.assert_allclose(noise["allan"]["adev"][axis], res.allan.deviation[axis], rtol=1e-15)
                fit = res.fit(axis)
                for key, term in (("noise_density", "N"), ("bias_instability", "B"), ("random_walk", "K")):
                    self.assertAlmostEqual(noise[key][axis], fit[term], delta=1e-12 * abs(fit[term]) + 1e-300,
                                           msg=f"{sensor} {key}[{axis}]")
                    self.assertAlmostEqual(noise[key + "_sigma"][axis], fit.sigma[term],
                                           delta=1e-12 * abs(fit.sigma[term]) + 1e-300)


class CharacterizeInPython(unittest.TestCase):
    def test_noise_sections_equal_the_command(self):
        # imukit.characterize runs what `imukit characterize` runs for one recording: the noise
        # sections come out identical, to the last digit of the JSON.
        cli, s = characterized_by_the_command(self, seed=5)
        py = imukit.characterize(s).to_dict()
        for sensor in ("accelerometer", "gyroscope"):
            self.assertEqual(py[sensor]["noise"], cli[sensor]["noise"], sensor)
        # White noise of known density: N within 3 % of it on every axis.
        np.testing.assert_allclose(py["gyroscope"]["noise"]["noise_density"], [GYRO_N] * 3, rtol=0.03)
        np.testing.assert_allclose(py["accelerometer"]["noise"]["noise_density"], [ACCEL_N] * 3, rtol=0.03)

    def test_a_series_without_inertial_samples_is_refused(self):
        with self.assertRaisesRegex(imukit.Error, "neither accelerometer nor gyroscope"):
            imukit.characterize(imukit.Series(np.arange(100, dtype=np.int64) * 10_000_000, mag=np.ones((100, 3))))


class ScaleInvariance(unittest.TestCase):
    def test_tiny_and_huge_noise_gives_the_same_relative_fit(self):
        """Found in review: white noise of amplitude 1e-170 came back with deviations of 0 (the
        squares underflowed) and no fit. Deviations and fits scale with the samples, to 1e-12;
        samples all equal still give deviations of exactly 0, at any magnitude."""
        x = np.random.default_rng(1).standard_normal(1000)
        one = imukit.allan_deviation(x, rate_hz=100.0)
        fit1 = one.fit(0)
        for s in (1e-170, 1e-300, 1e300):
            res = imukit.allan_deviation(x * s, rate_hz=100.0)
            np.testing.assert_allclose(res.allan.deviation / s, one.allan.deviation, rtol=1e-12, atol=0)
            fit = res.fit(0)
            for term in ("N", "B", "K"):
                self.assertLessEqual(abs(fit.value[term] / s - fit1.value[term]), 1e-12 * fit1.value[term])
                self.assertLessEqual(abs(fit.upper[term] / s - fit1.upper[term]), 1e-12 * fit1.upper[term])
            self.assertGreater(fit.value["N"], 0.0)
        for c in (0.1, 1e-170, -1e300):
            res = imukit.allan_deviation(np.full((500, 3), c), rate_hz=100.0)
            self.assertTrue(np.all(res.allan.deviation == 0.0))

    def test_deviations_beyond_the_largest_double_are_an_error(self):
        """Found in review: samples alternating +-1.5e308 gave allan.deviation[0][0] = inf with
        intervals of inf and no error, and fit(0) a Q of 1.2e306 from the other points. The
        error names the axis and its sample furthest from the mean; +-1e308 is still finite."""
        n = 2000
        w = np.where(np.arange(n) % 2 == 0, 1.5e308, -1.5e308)
        x = np.stack([np.random.default_rng(2).standard_normal(n), w, np.zeros(n)], axis=1)
        with self.assertRaisesRegex(
                imukit.Error, r"^Allan deviation: axis 1: the Allan deviation at tau 0\.01 s is beyond the "
                              r"largest double \(1\.79769e\+308\): sample 0 of axis 1 is 1\.5e\+308, too "
                              r"large for its differences$"):
            imukit.allan_deviation(x, rate_hz=100.0)
        res = imukit.allan_deviation(w / 1.5, rate_hz=100.0)
        for curve in (res.allan, res.modified, res.hadamard):
            for a in (curve.deviation, curve.lower, curve.upper):
                self.assertTrue(np.all(np.isfinite(a)))
        self.assertAlmostEqual(res.allan.deviation[0][0] / 1e308, math.sqrt(2.0), delta=1e-12)


class BadInput(unittest.TestCase):
    def test_errors(self):
        t, _, gyro = white_recording(n=100)
        with self.assertRaisesRegex(TypeError, "float32 or float64, got int64"):
            imukit.allan_deviation(gyro.astype(np.int64), t)
        with self.assertRaisesRegex(TypeError, "int64 nanoseconds"):
            imukit.allan_deviation(gyro, t * 1e-9)
        with self.assertRaisesRegex(ValueError, "99 times for 100 samples"):
            imukit.allan_deviation(gyro, t[1:])
        with self.assertRaisesRegex(ValueError, r"\(n,\) or \(n, axes\)"):
            imukit.allan_deviation(gyro.reshape(10, 10, 3), t)
        with self.assertRaisesRegex(ValueError, "rate_hz"):
            imukit.allan_deviation(gyro)
        # Rates are one an hour to 1 MHz as everywhere (found in review: 1e-10 Hz overflowed
        # building the times, "cannot create std::vector larger than max_size()").
        for rate in (1e-10, 2.7e-4, 1.000001e6, 1e300):
            with self.assertRaisesRegex(imukit.Error, r"^allan_deviation: rate_hz .* Hz is outside "
                                                      r"\[1/3600 \(one an hour\), 1e6\] Hz$"):
                imukit.allan_deviation(gyro, rate_hz=rate)
        self.assertEqual(imukit.allan_deviation(gyro, rate_hz=1.0 / 3600).tau0_s, 3600.0)
        self.assertAlmostEqual(imukit.allan_deviation(gyro, rate_hz=1e6).tau0_s, 1e-6, delta=1e-18)
        with self.assertRaises(imukit.Error) as e:
            imukit.allan_deviation(gyro[:5], t[:5])
        self.assertIn("8 samples", str(e.exception))
        bad = gyro.copy()
        bad[40, 1] = np.nan
        with self.assertRaisesRegex(imukit.Error, "NaN or infinity"):
            imukit.allan_deviation(bad, t)
        res = imukit.allan_deviation(gyro, t, allan=False)
        with self.assertRaisesRegex(imukit.Error, "allan=False"):
            res.fit(0)
        with self.assertRaises(IndexError):
            imukit.allan_deviation(gyro, t).fit(3)


class BindingsReview(unittest.TestCase):
    """Found in review, 2026-11-27 (the bindings review)."""

    def test_alpha_is_one_of_the_noise_types(self):
        # alpha=7 or 1 was clamped inside (the intervals of alpha 2) while curve.alpha said 7.
        t, _, gyro = white_recording(n=2000)
        for alpha in (7, 1, -3):
            with self.assertRaises(imukit.Error) as e:
                imukit.allan_deviation(gyro, t, alpha=alpha)
            self.assertEqual(str(e.exception),
                             f"allan_deviation: alpha must be 2, 0, -1 or -2 (or None: estimated), got {alpha}")
        for alpha in (2, 0, -1, -2):
            self.assertTrue(np.all(imukit.allan_deviation(gyro, t, alpha=alpha).allan.alpha == alpha))

    def test_result_arrays_are_read_only_views(self):
        # res.tau_s[:] = nan changed what res.fit() read ("fewer than 2 usable points").
        t, _, gyro = white_recording(n=5000)
        res = imukit.allan_deviation(gyro, t)
        before = res.fit(0)["N"]
        curve = res.allan
        for view in (res.tau_s, res.factors, curve.deviation, curve.lower, curve.upper, curve.edf, curve.alpha,
                     curve.terms):
            self.assertFalse(view.flags.writeable)
            with self.assertRaises(ValueError):
                view[0] = 0
        self.assertEqual(res.fit(0)["N"], before)

    def test_fit_axis_is_an_integer_not_a_bool(self):
        # fit(True) was axis 1.
        t, _, gyro = white_recording(n=2000)
        res = imukit.allan_deviation(gyro, t)
        with self.assertRaises(TypeError) as e:
            res.fit(True)
        self.assertEqual(str(e.exception), "AllanResult.fit: axis: expected an int, got bool")
        self.assertEqual(res.fit(np.int64(1))["N"], res.fit(1)["N"])
        with self.assertRaises(IndexError) as e:
            res.fit(2**70)
        self.assertEqual(str(e.exception), f"AllanResult.fit: axis {2**70} out of range")
