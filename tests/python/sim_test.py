"""imukit Python package: scenes built in Python or read from JSON simulate to the same arrays as
`imukit simulate` for the same seed (CSV and MCAP outputs), physics checks, the GIL released
while simulating, errors with the command's messages.

run: pytest (tests/pytest.ini); $IMUKIT_CLI the command, PYTHONPATH <build>/python
"""
import json
import math
import os
import tempfile
import threading
import unittest

import numpy as np

import imukit
from support import cli_error, data_file, euroc, python_steps_during, run_cli

DENSITY = 0.002
HARDWARE = {"schema": "imukit.profile/1",
            "accelerometer": {"noise": {"noise_density": [DENSITY] * 3}},
            "gyroscope": {"noise": {"noise_density": [3e-4] * 3}}}
SCENE = {
    "schema": "imukit.scene/1",
    "body": {"default_humanoid": {"height_m": 1.8}},
    "motion": {"procedural": {"rate_hz": 100, "duration_s": 8, "seed": 5}},
    "simulation": {"method": "spline", "rate_hz": 200, "seed": 11},
    "outputs": {"ground_truth": True},
    "sensors": [{"name": "watch", "preset": "left_wrist_watch", "hardware": HARDWARE,
                 "outputs": ["accelerometer", "gyroscope", "magnetometer"]},
                {"name": "belt", "preset": "waist_belt"}],
}


def python_scene(seed=11, frames=math.floor(8 * 100) + 1):
    """The scene above, built through the Python API instead of JSON."""
    body = imukit.Body.default_humanoid(1.8)
    motion = imukit.ProceduralMotion(len(body), rate_hz=100, frames=frames, seed=5)
    scene = imukit.Scene(body, motion, method="spline", rate_hz=200, seed=seed, ground_truth=True)
    scene.add_sensor("watch", preset="left_wrist_watch", hardware=HARDWARE, magnetometer=True)
    scene.add_sensor("belt", preset="waist_belt")
    return scene


class SimulateLikeTheCli(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.scene_path = os.path.join(cls.tmp.name, "scene.json")
        with open(cls.scene_path, "w") as f:
            json.dump(SCENE, f)
        cls.out = os.path.join(cls.tmp.name, "out")
        r = run_cli("simulate", cls.scene_path, "-o", cls.out, "--seed", 42)
        assert r.returncode == 0, r.stderr

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def check_equal_to_cli(self, result):
        self.assertEqual(sorted(result), ["belt", "belt.truth", "watch", "watch.truth"])
        for name, series in result.items():
            t, gyro, accel = euroc(os.path.join(self.out, name + ".csv"))
            self.assertEqual(len(series), 1601)
            np.testing.assert_array_equal(series.t, t, err_msg=name)
            np.testing.assert_array_equal(series.accel, accel, err_msg=name)
            np.testing.assert_array_equal(series.gyro, gyro, err_msg=name)
            if name.startswith("watch"):  # the magnetometer beside it: <name>.mag[.truth].csv
                mag_file = name.replace(".truth", "") + (".mag.truth.csv" if ".truth" in name else ".mag.csv")
                m = np.loadtxt(os.path.join(self.out, mag_file), delimiter=",", comments="#", ndmin=2)
                np.testing.assert_array_equal(series.mag, m[:, 1:4], err_msg=mag_file)
                # Earth's default field is 48.3 uT; the ideal magnetometer sees its norm.
                if ".truth" in name:
                    np.testing.assert_allclose(np.linalg.norm(series.mag, axis=1), np.hypot(20e-6, 44e-6), rtol=1e-12)
            else:
                self.assertIsNone(series.mag)

    def test_scene_file_with_seed_equals_cli_bit_for_bit(self):
        scene = imukit.read_scene(self.scene_path)
        self.assertEqual(scene.seed, 11)
        self.check_equal_to_cli(scene.simulate(seed=42))
        self.assertEqual(scene.seed, 11)  # seed= is for that run only

    def test_simulate_seed_is_for_that_run_only(self):
        """Found in review (2026-11-26): Scene.simulate(seed=1) replaced the scene's seed, so later
        simulate() calls, generate_dataset(scene) and scene.seed used 1."""
        scene = python_scene(seed=7)
        policy = imukit.read_policy("imukit")
        before = scene.simulate()["watch"].accel.copy()
        dataset = imukit.generate_dataset(scene, policy, window=50, stride=50, count=4, batch_size=2).X.copy()
        other = scene.simulate(seed=1)["watch"].accel.copy()
        self.assertEqual(scene.seed, 7)
        np.testing.assert_array_equal(scene.simulate()["watch"].accel, before)
        np.testing.assert_array_equal(python_scene(seed=1).simulate()["watch"].accel, other)
        self.assertFalse(np.array_equal(other, before))
        np.testing.assert_array_equal(
            imukit.generate_dataset(scene, policy, window=50, stride=50, count=4, batch_size=2).X, dataset)

    def test_scene_built_in_python_equals_cli(self):
        self.check_equal_to_cli(python_scene(seed=42).simulate())

    def test_other_seed_other_noise_same_truth(self):
        a = python_scene(seed=42).simulate()
        b = python_scene(seed=43).simulate()
        np.testing.assert_array_equal(a["watch.truth"].accel, b["watch.truth"].accel)
        diff = a["watch"].accel - b["watch"].accel
        # Two independent noise draws: the difference has sigma sqrt(2) * density * sqrt(rate).
        expected = math.sqrt(2) * DENSITY * math.sqrt(200)
        self.assertLess(abs(np.std(diff) / expected - 1), 0.05)
        np.testing.assert_array_equal(a["belt"].accel, b["belt"].accel)  # ideal sensor

    def test_seeds_are_the_commands_integers_0_to_2_pow_63_minus_1(self):
        # Found in review (2026-11-26): the Python Scene took seeds to 2^64 - 1 (a uint64), which
        # neither --seed nor a scene file takes, and -1 was "incompatible function arguments".
        top = 2**63 - 1
        out = os.path.join(self.tmp.name, "top_seed")
        r = run_cli("simulate", self.scene_path, "-o", out, "--seed", top)
        self.assertEqual(r.returncode, 0, r.stderr)
        sim = python_scene(seed=top).simulate()
        t, gyro, accel = euroc(os.path.join(out, "watch.csv"))
        np.testing.assert_array_equal(sim["watch"].accel, accel)
        self.assertEqual(imukit.read_scene(self.scene_path).simulate(seed=0)["watch"].t.size, 1601)
        expected = "expected an integer in [0, 9223372036854775807], got "
        scene = python_scene()
        for value in (2**63, 2**64, -1):
            with self.assertRaises(imukit.Error) as e:
                scene.simulate(seed=value)
            self.assertEqual(str(e.exception), f"Scene.simulate: seed: {expected}{value}")
            with self.assertRaises(imukit.Error) as e:
                scene.seed = value
            self.assertEqual(str(e.exception), f"Scene.seed: {expected}{value}")
        with self.assertRaises(imukit.Error) as e:
            python_scene(seed=2**63)
        self.assertEqual(str(e.exception), f"Scene: seed: {expected}{2**63}")
        with self.assertRaises(imukit.Error) as e:
            imukit.ProceduralMotion(3, frames=10, seed=-1)
        self.assertEqual(str(e.exception), f"ProceduralMotion: seed: {expected}-1")
        with self.assertRaises(TypeError) as e:
            scene.simulate(seed=7.0)
        self.assertEqual(str(e.exception), "Scene.simulate: seed: expected an int, got float")
        self.assertEqual(scene.seed, 11)

    def test_mcap_output_reads_back_to_the_same_arrays(self):
        path = os.path.join(self.tmp.name, "sim.mcap")
        r = run_cli("simulate", self.scene_path, "-o", path, "--seed", 42)
        self.assertEqual(r.returncode, 0, r.stderr)
        rec = imukit.read_mcap(path)
        self.assertTrue(rec.complete)
        sim = imukit.read_scene(self.scene_path).simulate(seed=42)
        for name in ("watch", "belt"):
            s = rec.streams[name]
            np.testing.assert_array_equal(s.t, sim[name].t)
            np.testing.assert_array_equal(s.accel, sim[name].accel)
            np.testing.assert_array_equal(s.gyro, sim[name].gyro)
        streams = rec.streams
        self.assertTrue(np.shares_memory(streams["watch"].accel, streams["watch"].accel))


class Physics(unittest.TestCase):
    def test_still_body_reads_gravity_in_any_orientation(self):
        body = imukit.Body.default_humanoid()
        q = np.array([0.8, 0.2, -0.4, 0.4]) / np.linalg.norm([0.8, 0.2, -0.4, 0.4])
        rot = np.zeros((40, len(body), 4))
        rot[..., 0] = 1.0
        rot[:, 0] = q
        motion = imukit.Motion.from_arrays(rot, np.tile([0.1, 0.2, 1.0], (40, 1)), rate_hz=50.0, body=body)
        np.testing.assert_allclose(motion.rotations_wxyz()[:, 0], np.tile(q, (40, 1)), rtol=0, atol=1e-15)
        for method in ("fd", "spline", "reference"):
            scene = imukit.Scene(body, motion, method=method, gravity=9.81)
            scene.add_sensor("custom", joint="pelvis", position_m=[0.1, 0.0, 0.05],
                             q_joint_sensor=[math.cos(0.3), 0, math.sin(0.3), 0])
            s = scene.simulate()["custom"]
            np.testing.assert_allclose(np.linalg.norm(s.accel, axis=1), 9.81, rtol=0, atol=1e-12)
            np.testing.assert_array_equal(s.gyro, 0.0)
            self.assertEqual(scene.gravity_world, (0.0, 0.0, -9.81))

    def test_walk_bvh_quick_form_equals_cli(self):
        walk = data_file("mocap", "scaled_131_01_walk.bvh")
        with tempfile.TemporaryDirectory() as tmp:
            prof = os.path.join(tmp, "hw.json")
            with open(prof, "w") as f:
                json.dump(HARDWARE, f)
            r = run_cli("simulate", "--bvh", walk, "--preset", "left_wrist_watch", "--hardware", prof,
                        "--seed", 7, "-o", tmp)
            self.assertEqual(r.returncode, 0, r.stderr)
            t, gyro, accel = euroc(os.path.join(tmp, "left_wrist_watch.csv"))
            profile = imukit.read_profile(prof)
        body, motion, warnings = imukit.read_bvh(walk)
        scene = imukit.Scene(body, motion, seed=7)
        scene.add_sensor(preset="left_wrist_watch", hardware=profile)
        s = scene.simulate()["left_wrist_watch"]
        self.assertEqual(len(s), 995)
        np.testing.assert_array_equal(s.t, t)
        np.testing.assert_array_equal(s.accel, accel)
        np.testing.assert_array_equal(s.gyro, gyro)


class Concurrency(unittest.TestCase):
    def test_gil_is_released_while_simulating(self):
        # One long call (20 min of motion): its middle half lasts far longer than a time slice.
        scene = python_scene(frames=20 * 60 * 100 + 1)
        steps, seconds = python_steps_during(scene.simulate)
        self.assertGreater(seconds, 0.05)
        self.assertGreater(steps, 0, f"no Python step in the middle of a {seconds:.3f} s simulate()")

    def test_gil_is_released_while_a_motion_is_copied_from_arrays(self):
        # Found in review (2026-11-26): 60,000 frames held the GIL for 83 ms.
        body = imukit.Body.default_humanoid()
        rot = np.zeros((150_000, len(body), 4))
        rot[..., 0] = 1.0
        tr = np.zeros((150_000, 3))
        steps, seconds = python_steps_during(lambda: imukit.Motion.from_arrays(rot, tr, rate_hz=100, body=body))
        self.assertGreater(seconds, 0.05)
        self.assertGreater(steps, 0, f"no Python step in the middle of a {seconds:.3f} s Motion.from_arrays()")
        m = imukit.Motion.from_arrays(rot[:3], tr[:3] + [1.0, 2.0, 3.0], rate_hz=100, body=body)
        np.testing.assert_array_equal(m.root_translation(), [[1.0, 2.0, 3.0]] * 3)
        np.testing.assert_array_equal(m.rotations_wxyz(), rot[:3])
        np.testing.assert_array_equal(imukit.Motion.from_arrays(rot[:3], None, rate_hz=100).root_translation(),
                                      np.zeros((3, 3)))

    def test_the_gil_check_sees_a_call_that_holds_it(self):
        # sum() over a range runs in C without ever letting the GIL go: the check must count 0.
        steps, seconds = python_steps_during(lambda: sum(range(20_000_000)))
        self.assertGreater(seconds, 0.05)
        self.assertEqual(steps, 0)

    def test_threads_give_the_same_arrays(self):
        results = [None] * 3

        def work(i):
            results[i] = python_scene(seed=42).simulate()["watch"].accel.copy()

        threads = [threading.Thread(target=work, args=(i,)) for i in range(3)]
        for th in threads:
            th.start()
        for th in threads:
            th.join()
        for r in results[1:]:
            np.testing.assert_array_equal(r, results[0])


class Errors(unittest.TestCase):
    def test_scene_errors_have_the_cli_message(self):
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "bad.json")
            with open(path, "w") as f:
                json.dump(dict(SCENE, sensors=[{"preset": "left_sock"}]), f)
            with self.assertRaises(imukit.Error) as e:
                imukit.read_scene(path)
            self.assertIn("sensors[0].preset", str(e.exception))
            self.assertEqual(str(e.exception), cli_error("simulate", path, "-o", os.path.join(tmp, "o")))
            with open(path, "w") as f:
                f.write('{"schema": "imukit.scene/1",\n "motion": }')
            with self.assertRaises(imukit.Error) as e:
                imukit.read_scene(path)
            self.assertEqual(e.exception.line, 2)
            self.assertEqual(str(e.exception), cli_error("simulate", path, "-o", os.path.join(tmp, "o")))

    def test_inline_hardware_errors_name_the_scene_line_column_and_whole_path(self):
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "inline_hw.json")
            hardware = dict(HARDWARE, clock={"error_ppm": 1e5})
            text = json.dumps(dict(SCENE, sensors=[dict(SCENE["sensors"][0], hardware=hardware)]),
                              indent=1)
            with open(path, "w") as f:
                f.write(text)
            at = text.index("100000.0")
            line = text.count("\n", 0, at) + 1
            column = at - text.rfind("\n", 0, at)
            with self.assertRaises(imukit.Error) as e:
                imukit.read_scene(path)
            self.assertEqual((e.exception.file, e.exception.line, e.exception.column),
                             (path, line, column))
            self.assertEqual(str(e.exception),
                             f"{path}:{line}:{column}: sensors[0].hardware.clock.error_ppm: "
                             "100000 ppm is not within +-10000 ppm")
            self.assertEqual(str(e.exception), cli_error("simulate", path, "-o", os.path.join(tmp, "o")))

    def test_hardware_dict_errors_name_the_json_path_not_a_column_of_a_copy(self):
        scene = python_scene()
        with self.assertRaises(imukit.Error) as e:
            scene.add_sensor("x", preset="chest_strap", hardware=dict(HARDWARE, clock={"error_ppm": 1e5}))
        self.assertEqual(str(e.exception), "<dict>: clock.error_ppm: 100000 ppm is not within +-10000 ppm")
        self.assertEqual((e.exception.file, e.exception.line, e.exception.column), ("<dict>", None, None))

    def test_hardware_is_checked_at_the_scene_rate_in_the_profile_terms(self):
        """Found in review (2026-11-26): a profile whose bandwidth is not below half the scene's rate
        was taken by add_sensor, and simulate() then named "accelerometer.bandwidth_hz", a key no
        profile has. add_sensor checks it at the scene's rate as read_scene does, naming the
        profile's key (docs/formats.md: limits.bandwidth) and, for a file, its line and column."""
        hardware = dict(HARDWARE, accelerometer=dict(HARDWARE["accelerometer"],
                                                     limits={"rate": 100.0, "bandwidth": 40.0}))
        body = imukit.Body.default_humanoid()
        scene = imukit.Scene(body, imukit.ProceduralMotion(len(body), frames=50), rate_hz=50)
        reason = "accelerometer.limits.bandwidth: 40 Hz is not below half the rate the model runs at (25 Hz)"
        with self.assertRaises(imukit.Error) as e:
            scene.add_sensor("w", preset="left_wrist_watch", hardware=hardware)
        self.assertEqual(str(e.exception), "<dict>: " + reason)
        with self.assertRaises(imukit.Error) as e:
            scene.add_sensor("w", preset="left_wrist_watch", hardware=imukit.profile(hardware))
        self.assertEqual(str(e.exception), "<Profile>: " + reason)
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "imu.json")
            text = json.dumps(hardware, indent=1)
            with open(path, "w") as f:
                f.write(text)
            at = text.index("40.0")
            line, column = text.count("\n", 0, at) + 1, at - text.rfind("\n", 0, at)
            with self.assertRaises(imukit.Error) as e:
                scene.add_sensor("w", preset="left_wrist_watch", hardware=path)
            self.assertEqual(str(e.exception), f"{path}:{line}:{column}: {reason}")
        self.assertEqual(scene.sensors, [])
        scene_100 = imukit.Scene(body, imukit.ProceduralMotion(len(body), frames=50), rate_hz=100)
        scene_100.add_sensor("w", preset="left_wrist_watch", hardware=hardware)
        self.assertEqual(len(scene_100.simulate()["w"]), 50)

    def test_gravity_that_is_not_finite_is_named(self):
        # Found in review (2026-11-26): gravity=nan said "|g| = 0 m/s^2".
        body = imukit.Body.default_humanoid()
        motion = imukit.ProceduralMotion(len(body), frames=50)
        for g, shown in ((float("nan"), "nan"), (float("inf"), "inf"), ([0.0, 0.0, float("nan")], "[0.0, 0.0, nan]"),
                         (np.float32("nan"), "nan")):
            with self.assertRaises(imukit.Error) as e:
                imukit.Scene(body, motion, gravity=g)
            self.assertEqual(str(e.exception), f"Scene: gravity: expected finite numbers, got {shown}")
        self.assertEqual(imukit.Scene(body, motion, gravity=np.float32(9.5)).gravity_world, (0.0, 0.0, -9.5))
        with self.assertRaises(TypeError) as e:
            imukit.Scene(body, motion, gravity=True)
        self.assertEqual(str(e.exception), "Scene: gravity: expected a number, got bool")

    def test_api_misuse(self):
        body = imukit.Body.default_humanoid()
        motion = imukit.ProceduralMotion(len(body), frames=50)
        scene = imukit.Scene(body, motion)
        with self.assertRaisesRegex(imukit.Error, "no sensors"):
            scene.simulate()
        # The simulator's limit, at construction (2..7 passed here and failed in simulate()).
        with self.assertRaisesRegex(imukit.Error, r"chunk_frames: must be a whole number in \[8, 1e7\], got 5"):
            imukit.Scene(body, motion, chunk_frames=5)
        with self.assertRaisesRegex(imukit.Error, "unknown placement preset 'left_sock'"):
            scene.add_sensor(preset="left_sock")
        with self.assertRaisesRegex(imukit.Error, "either preset= or joint="):
            scene.add_sensor("x")
        with self.assertRaisesRegex(imukit.Error, "not a unit quaternion"):
            scene.add_sensor("x", joint="pelvis", q_joint_sensor=[1, 1, 0, 0])
        scene.add_sensor(preset="chest_strap")
        with self.assertRaisesRegex(imukit.Error, "duplicate sensor name"):
            scene.add_sensor(preset="chest_strap")
        with self.assertRaisesRegex(imukit.Error, "joints"):
            imukit.Scene(body, imukit.ProceduralMotion(3, frames=50))
        with self.assertRaisesRegex(imukit.Error, "fd"):
            imukit.Scene(body, motion, method="euler")
        endless = imukit.Scene(body, imukit.ProceduralMotion(len(body)))
        endless.add_sensor(preset="chest_strap")
        with self.assertRaisesRegex(imukit.Error, "endless"):
            endless.simulate()
        with self.assertRaisesRegex(ValueError, r"\(frames, joints, 4\)"):
            imukit.Motion.from_arrays(np.zeros((10, 4)), None, rate_hz=100)
        rot = np.zeros((10, len(body), 4))
        rot[..., 0] = 1.0
        rot[3, 2] = np.nan
        with self.assertRaisesRegex(imukit.Error, "frame 3"):
            imukit.Motion.from_arrays(rot, None, rate_hz=100, body=body)
        names = [p["name"] for p in imukit.placement_presets()]
        self.assertEqual(len(names), 12)
        self.assertIn("left_wrist_watch", names)

    def test_rates_and_quaternions_at_the_limits(self):
        """Found in review (2026-11-26): Scene(rate_hz=1e-10) was accepted and simulate() then hung
        at 100 % CPU; a quaternion of 1e155 normalised to zero (and the simulator aborted), one of
        1e-300 was refused as zero norm. Rates are one an hour to 1 MHz; any finite quaternion but
        zero is a rotation (to 4e-16)."""
        body = imukit.Body.default_humanoid()
        motion = imukit.ProceduralMotion(len(body), frames=50)
        for rate in (1e-10, 1e-300, 2.7e-4, -1.0, 2e6):
            with self.assertRaisesRegex(
                    imukit.Error, r"^Scene: rate_hz .* Hz is outside \[1/3600 \(one an hour\), 1e6\] Hz$"):
                imukit.Scene(body, motion, rate_hz=rate)
        rot = np.zeros((40, len(body), 4))
        rot[..., 0] = 1.0
        # Gravity as a scene's simulation.gravity and simulate --gravity: 0.1 to 100 m/s^2.
        for g in (0.0, 0.05, [0, 0, 0], [0, 0, -100.5]):
            with self.assertRaisesRegex(imukit.Error, r"^Scene: gravity: \|g\| = .* m/s\^2 is outside \[0\.1, 100\]"):
                imukit.Scene(body, motion, gravity=g)
        self.assertEqual(imukit.Scene(body, motion, gravity=0.1).gravity_world[2], -0.1)
        with self.assertRaisesRegex(imukit.Error, "^Motion.from_arrays: rate_hz 1e-12 Hz is outside"):
            imukit.Motion.from_arrays(rot, None, rate_hz=1e-12, body=body)
        rot[5, 1] = [1e155, 0.0, 0.0, 1e155]
        rot[6, 1] = [1e-300, 0.0, 0.0, 0.0]
        with self.assertWarnsRegex(RuntimeWarning, "2 quaternions had norms further than 1e-06"):
            m = imukit.Motion.from_arrays(rot, None, rate_hz=100.0, body=body)
        scene = imukit.Scene(body, m, rate_hz=1.0 / 3600.0)
        scene.add_sensor(preset="chest_strap")
        self.assertEqual(len(scene.simulate()["chest_strap"].t), 1)  # 0.39 s: one sample an hour
        P, Q = imukit.world_poses(body, m)
        spine = np.asarray(Q)[:, 1]  # under the still pelvis: its own rotation
        np.testing.assert_allclose(spine[5], [math.sqrt(0.5), 0, 0, math.sqrt(0.5)], rtol=0, atol=4e-16)
        np.testing.assert_allclose(spine[6], [1, 0, 0, 0], rtol=0, atol=4e-16)
        rot[7, 1] = 0.0
        with self.assertRaisesRegex(imukit.Error, "frame 7, joint .*: quaternion is all zeros"):
            imukit.Motion.from_arrays(rot, None, rate_hz=100.0, body=body)

    def test_positions_beyond_their_limits_are_errors(self):
        """Found in review: a root translation of 1e17 m (double spacing 16 m) and a sensor 1e300 m
        from its joint were simulated without a word. Root translations are bounded at 3e7 m and
        other positions at 1e6 m (sim::PlausibilityLimits), from arrays as from files."""
        body = imukit.Body.default_humanoid()
        rot = np.zeros((10, len(body), 4))
        rot[..., 0] = 1.0
        tr = np.zeros((10, 3))
        tr[4, 0] = 1e17
        with self.assertRaisesRegex(
                imukit.Error, r"^motion: frame 4: root translation \(1e\+17 0 0\) m is beyond 3e\+07 m \(not metres\?\)$"):
            imukit.Motion.from_arrays(rot, tr, rate_hz=100.0, body=body)
        tr[4, 0] = -3.0000001e7
        with self.assertRaisesRegex(imukit.Error, r"^motion: frame 4: root translation \(-3e\+07 0 0\) m is beyond"):
            imukit.Motion.from_arrays(rot, tr, rate_hz=100.0, body=body)
        tr[4, 0] = -1e6
        m = imukit.Motion.from_arrays(rot, tr, rate_hz=100.0, body=body)
        scene = imukit.Scene(body, m)
        scene.add_sensor("far", joint="pelvis", position_m=[0.0, 1e300, 0.0])
        with self.assertRaisesRegex(imukit.Error, r"sensor far: position \(0 1e\+300 0\) m is beyond 1e\+06 m"):
            scene.simulate()

    def test_geodetic_root_translations_are_simulated(self):
        """Found in review: root translations above 1e6 m were refused as "not metres?", a UTM
        northing of 5.4e6 m and an ECEF origin among them. Up to 3e7 m they are simulated, and
        their rounding (a double's spacing, at most 3.7e-9 m there) moves the accelerations of a
        1 kHz motion by 0.71 spacings times the rate squared rms, 2 at most (6 at the first and
        last frames, where the stencil is one-sided): below a MEMS accelerometer's noise."""
        body = imukit.Body.default_humanoid()
        rate = 1000.0
        n = 2000
        t = np.arange(n) / rate
        rot = np.zeros((n, len(body), 4))
        rot[..., 0] = 1.0
        walk = np.stack([1.3 * t, 0.2 * np.sin(2 * np.pi * 0.9 * t), 0.05 * np.sin(2 * np.pi * 1.8 * t)], axis=1)

        def accel(origin):
            m = imukit.Motion.from_arrays(rot, walk + np.asarray(origin), rate_hz=rate, body=body)
            scene = imukit.Scene(body, m, rate_hz=rate)
            scene.add_sensor("s", joint="pelvis")
            return scene.simulate()["s"].accel

        at_origin = accel((0.0, 0.0, 0.0))
        for origin in ((5e5, 5.4e6, 300.0), (4.2e6, 1.7e5, 4.8e6), (0.0, 9.99e6, 0.0), (2.9e7, 0.0, -2.99e7)):
            spacing = np.spacing(np.abs(walk + np.asarray(origin)).max(axis=0))  # per axis
            off = np.abs(accel(origin) - at_origin) / (spacing * rate**2)
            self.assertLessEqual(off[1:-1].max(), 2.0 + 1e-6, origin)
            self.assertLessEqual(off.max(), 6.0 + 1e-6, origin)
            self.assertLess(np.abs(accel(origin) - at_origin).max(), 2.3e-2, origin)


class BindingsReview(unittest.TestCase):
    """Found in review, 2026-11-27 (the bindings review)."""

    def test_procedural_motion_options_are_checked_as_in_a_scene_file(self):
        # amplitude_rad=nan ended the interpreter at an assertion, translation_amplitude_m=nan or
        # inf gave Series of NaN, and a negative amplitude was taken; a scene file refused
        # amplitudes outside [0, 10] alone. One check in C++ now serves both.
        cases = [({"amplitude_rad": float("nan")}, "procedural motion: amplitude_rad must be in [0, 10] rad, got nan"),
                 ({"amplitude_rad": float("inf")}, "procedural motion: amplitude_rad must be in [0, 10] rad, got inf"),
                 ({"amplitude_rad": -1.0}, "procedural motion: amplitude_rad must be in [0, 10] rad, got -1"),
                 ({"translation_amplitude_m": float("nan")},
                  "procedural motion: translation_amplitude_m must be finite and >= 0 m, got nan"),
                 ({"translation_amplitude_m": float("inf")},
                  "procedural motion: translation_amplitude_m must be finite and >= 0 m, got inf")]
        for kw, message in cases:
            with self.assertRaises(imukit.Error) as e:
                imukit.ProceduralMotion(21, frames=100, **kw)
            self.assertEqual(str(e.exception), message)
        scene = dict(SCENE, motion={"procedural": {"rate_hz": 100, "duration_s": 8, "amplitude_rad": 11}})
        with self.assertRaises(imukit.Error) as e:
            imukit.parse_scene(json.dumps(scene), "s.json")
        self.assertEqual(str(e.exception),
                         "s.json: motion.procedural: procedural motion: amplitude_rad must be in [0, 10] rad, got 11")

    def test_simulate_sizes_its_buffers_from_the_frames_it_simulates(self):
        # frames= is a limit: simulate() allocated samples for the limit, not for the motion's
        # 200 frames (382 MiB for 5e7), and a limit of 1e12 could not be counted.
        body = imukit.Body.default_humanoid()
        motion = imukit.ProceduralMotion(len(body), frames=200)
        for frames in (200, 10**12, 2**63 - 1):
            scene = imukit.Scene(body, motion, frames=frames)
            scene.add_sensor(preset="chest_strap")
            self.assertEqual(len(scene.simulate()["chest_strap"]), 200)

    def test_frames_is_an_integer_not_a_bool(self):
        # Scene(frames=True) was 1 frame; ProceduralMotion(frames=True) one frame too.
        body = imukit.Body.default_humanoid()
        motion = imukit.ProceduralMotion(len(body), frames=200)
        for call, message in ((lambda: imukit.Scene(body, motion, frames=True), "Scene: frames: expected an int, got bool"),
                              (lambda: imukit.ProceduralMotion(21, frames=True),
                               "ProceduralMotion: frames: expected an int, got bool")):
            with self.assertRaises(TypeError) as e:
                call()
            self.assertEqual(str(e.exception), message)
        with self.assertRaises(imukit.Error) as e:
            imukit.Scene(body, motion, frames=-1)
        self.assertEqual(str(e.exception), "Scene: frames: expected an integer in [0, 9223372036854775807], got -1")
        self.assertEqual(imukit.ProceduralMotion(21, frames=np.int64(50)).frame_count, 50)

    def test_chunk_frames_is_documented(self):
        # Scene took chunk_frames, which neither its docstring nor docs/python.md named.
        self.assertIn("chunk_frames=4096", imukit.Scene.__doc__)
        self.assertIn("[8, 1e7]", imukit.Scene.__doc__)


class AntiAliasing(unittest.TestCase):
    """The bundled 2 s walk (CMU 131_01, 120 Hz frames) on a left wrist, sampled at 24 Hz. With
    the filter the samples are what an independent resampler makes of the 120 Hz simulation
    (SciPy's resample_poly, a Kaiser FIR of its own design): 0.028 m/s^2 and 0.0036 rad/s RMS
    apart, where the accelerometer signal is 9.2 m/s^2 RMS (measured 2026-11-27). Point samples
    are every fifth 120 Hz sample, 5.4 m/s^2 RMS from the band-limited signal: the walk above
    12 Hz folded into the band."""

    BVH = os.path.join(os.path.dirname(__file__), "..", "..", "examples", "motion", "cmu_131_01_walk_2s.bvh")

    def simulate(self, rate_hz, **kwargs):
        body, motion, _ = imukit.read_bvh(self.BVH)
        scene = imukit.Scene(body, motion, rate_hz=rate_hz, method="spline", **kwargs)
        scene.add_sensor(preset="left_wrist_watch")
        return scene, scene.simulate()["left_wrist_watch"]

    def test_samples_are_the_band_limited_simulation_and_point_samples_fold(self):
        from scipy.signal import resample_poly
        _, full = self.simulate(120.0)  # at the motion's rate: no filter
        scene, aa = self.simulate(24.0)
        self.assertTrue(scene.anti_alias)
        _, points = self.simulate(24.0, anti_alias=False)
        n = len(aa)
        inner = slice(12, n - 12)  # the filter's reach (12 samples) from the motion's ends
        rms = lambda d: float(np.sqrt((d[inner] ** 2).sum(axis=1).mean()))
        for kind, tol in (("accel", 0.05), ("gyro", 0.01)):
            ref = resample_poly(getattr(full, kind), 1, 5, axis=0)[:n]
            self.assertLess(rms(getattr(aa, kind) - ref), tol, kind)
            np.testing.assert_array_equal(getattr(points, kind), getattr(full, kind)[::5][:n])
        self.assertGreater(rms(points.accel - resample_poly(full.accel, 1, 5, axis=0)[:n]), 2.0)

    def test_the_scene_key_and_property(self):
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "scene.json")
            with open(path, "w") as f:
                json.dump({"schema": "imukit.scene/1", "motion": {"bvh": os.path.abspath(self.BVH)},
                           "simulation": {"rate_hz": 24, "anti_alias": False},
                           "sensors": [{"name": "w", "preset": "left_wrist_watch"}]}, f)
            scene = imukit.read_scene(path)
            self.assertFalse(scene.anti_alias)
            off = scene.simulate()["w"].accel
            scene.anti_alias = True
            self.assertGreater(np.abs(scene.simulate()["w"].accel - off).max(), 1.0)
            with open(path, "w") as f:
                json.dump({"schema": "imukit.scene/1", "motion": {"bvh": os.path.abspath(self.BVH)},
                           "simulation": {"anti_alias": "yes"}, "sensors": []}, f)
            with self.assertRaises(imukit.Error) as e:
                imukit.read_scene(path)
            self.assertIn("simulation.anti_alias", str(e.exception))
            self.assertIn("expected true or false", str(e.exception))
