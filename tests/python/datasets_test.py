"""imukit.datasets.utd_mhad: the UTD-MHAD reader against the files of the shared data folder.

run: pytest (tests/pytest.ini); $IMUKIT_CLI the command, PYTHONPATH <build>/python
"""
import contextlib
import io
import os
import tempfile
import unittest

import numpy as np

from imukit.datasets import utd_mhad
from support import data_file


class UtdMhad(unittest.TestCase):
    def setUp(self):
        self.root = os.path.dirname(data_file("utd_mhad", "README.md"))

    def test_lists_the_861_paired_trials_of_8_subjects_and_27_actions(self):
        trials, unpaired = utd_mhad.list_trials(self.root)
        self.assertEqual(len(trials), 861)
        self.assertEqual(sorted({t.subject for t in trials}), list(range(1, 9)))
        self.assertEqual(sorted({t.action for t in trials}), list(range(1, 28)))
        # Every file of the release has its partner (the 3 trials missing lack both files).
        self.assertEqual(unpaired, [])
        self.assertEqual(trials[0], utd_mhad.TrialId(action=1, subject=1, trial=1))

    def test_subjects_are_named_as_the_dataset_names_them_or_bare(self):
        self.assertEqual(utd_mhad.parse_subjects("s1,4, s8"), [1, 4, 8])
        for bad in ("x9", "s", "s0", "1.5", ""):
            with self.assertRaisesRegex(ValueError, f"subject {bad!r}: expected a subject as s1 or 1"):
                utd_mhad.parse_subjects(bad)
        # The fitting batch took "s4" to a traceback (int("s4")); now the list and a clear error.
        from imukit.datasets import utd_mhad_scenes
        with tempfile.TemporaryDirectory() as d:
            err = io.StringIO()
            with contextlib.redirect_stderr(err), self.assertRaises(SystemExit) as exit:
                utd_mhad_scenes.main([self.root, d, "--subjects", "s4,s9"])
            self.assertEqual(exit.exception.code, 2)
            self.assertIn("--subjects: no trials of subject(s) s9 in", err.getvalue())

    def test_the_fitting_batch_checks_its_numbers_where_parsed(self):
        # Found in review: --threads 0 was a traceback, --limit -1 fitted 860 of 861 trials.
        from imukit.datasets import utd_mhad_scenes
        for flag, value in (("--threads", "0"), ("--threads", "-2"), ("--limit", "0"), ("--limit", "-1")):
            err = io.StringIO()
            with contextlib.redirect_stderr(err), self.assertRaises(SystemExit) as exit:
                utd_mhad_scenes.main([self.root, "/nonexistent", flag, value])
            self.assertEqual(exit.exception.code, 2)
            self.assertEqual(err.getvalue().splitlines()[-1],
                             "python3 -m imukit.datasets.utd_mhad_scenes: error: "
                             f"argument {flag}: expected an integer >= 1, got '{value}'")

    def test_converts_g_and_deg_per_s_to_si_and_keeps_the_skeleton_in_frame_order(self):
        trial = utd_mhad.load_trial(self.root, utd_mhad.TrialId(1, 1, 1))
        # First row of a1_s1_t1_inertial.mat: -0.959473 g and 5.221374 deg/s.
        self.assertAlmostEqual(trial.accel[0, 0], -0.959473 * 9.80665, places=12)
        self.assertAlmostEqual(trial.gyro[0, 0], np.deg2rad(5.221374), places=15)
        self.assertEqual(trial.accel.shape, (160, 3))
        self.assertEqual(trial.keypoints.shape, (48, 20, 3))
        # Frame 0, joint 1 (head) of d_skel is (-0.04576265, 0.48398542, 2.83018947) m.
        np.testing.assert_allclose(trial.keypoints[0, 0], [-0.04576265, 0.48398542, 2.83018947],
                                   atol=1e-8)
        self.assertEqual(trial.site, "right_wrist")
        self.assertAlmostEqual(trial.duration_s, 3.2)
        # A still-ish wrist at the start reads about one g in magnitude.
        self.assertAlmostEqual(np.linalg.norm(trial.accel[0]), 9.6, delta=0.5)

    def test_sensor_site_by_action_and_bad_action(self):
        self.assertEqual(utd_mhad.sensor_site(21), "right_wrist")
        self.assertEqual(utd_mhad.sensor_site(22), "right_thigh")
        with self.assertRaisesRegex(ValueError, "action 28 is not in 1..27"):
            utd_mhad.sensor_site(28)

    def test_a_damaged_or_wrong_file_is_named_in_the_error(self):
        with tempfile.TemporaryDirectory() as d:
            os.makedirs(os.path.join(d, "Inertial"))
            os.makedirs(os.path.join(d, "Skeleton"))
            bad = os.path.join(d, "Inertial", "a1_s1_t1_inertial.mat")
            with open(bad, "wb") as f:
                f.write(b"MATLAB 5.0 MAT-file, truncated")
            with open(os.path.join(d, "Skeleton", "a1_s1_t1_skeleton.mat"), "wb") as f:
                f.write(b"")
            trials, _ = utd_mhad.list_trials(d)
            self.assertEqual(len(trials), 1)
            with self.assertRaisesRegex(ValueError, "a1_s1_t1_inertial.mat: not a readable"):
                utd_mhad.load_trial(d, trials[0])
        with self.assertRaisesRegex(FileNotFoundError, "no such folder"):
            utd_mhad.list_trials("/nonexistent")
