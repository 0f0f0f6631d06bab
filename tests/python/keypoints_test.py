"""imukit.motion_from_keypoints and custom bodies from Python (docs/keypoints.md, docs/python.md):
a bundled BVH walk as exact Kinect and Human3.6M keypoints comes back with the truth's limb
rotations; Body.from_arrays; per-subject bodies; clear errors; a real UTD-MHAD trial.

run: pytest (tests/pytest.ini); $IMUKIT_CLI the command, PYTHONPATH <build>/python
"""
import os
import tempfile
import unittest

import numpy as np

import imukit
from support import data_file, python_steps_during

HERE = os.path.dirname(os.path.abspath(__file__))
WALK = os.path.join(HERE, "..", "..", "examples", "motion", "cmu_131_01_walk_2s.bvh")
# Kinect v1 keypoint -> the CMU (3dsMax release) joint standing for it.
KINECT_FROM_CMU = {
    "head": "Head", "shoulder_center": "lowerneck", "spine": "Chest", "hip_center": "Hips",
    "left_shoulder": "LeftShoulder", "left_elbow": "LeftElbow", "left_wrist": "LeftWrist",
    "left_hand": "LFingers", "right_shoulder": "RightShoulder", "right_elbow": "RightElbow",
    "right_wrist": "RightWrist", "right_hand": "RFingers", "left_hip": "LeftHip",
    "left_knee": "LeftKnee", "left_ankle": "LeftAnkle", "left_foot": "LeftToe",
    "right_hip": "RightHip", "right_knee": "RightKnee", "right_ankle": "RightAnkle",
    "right_foot": "RightToe"}
H36M_FROM_CMU = {"pelvis": "Hips", "spine": "Chest", "thorax": "lowerneck", "neck": "Neck", "head": "Head"}


def qmat(q):
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1)], -2)


def offset_spread_deg(G, A, E):
    """Largest angle (deg) of G(t)^T A^T E(t) from its chordal mean: 0 when the estimate is the
    truth up to a constant change of segment frame."""
    B = np.einsum("nji,jk,nkl->nil", G, A.T, E)
    U, _, Vt = np.linalg.svd(B.sum(0))
    M = U @ Vt
    D = np.einsum("ji,njk->nik", M, B)
    return np.degrees(np.arccos(np.clip((np.trace(D, axis1=1, axis2=2) - 1) / 2, -1, 1))).max()


class FromBvh(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.body, cls.motion, _ = imukit.read_bvh(WALK)
        cls.P, cls.Q = imukit.world_poses(cls.body, cls.motion)
        cls.t = np.arange(cls.P.shape[0]) / cls.motion.rate_hz

    def keypoints(self, topology, mapping):
        names = imukit.keypoint_topology(topology)["keypoints"]
        return self.P[:, [self.body.index_of(mapping.get(n, n)) for n in names], :]

    def check_limbs(self, eb, em, info, segments, limit_deg):
        _, Qe = imukit.world_poses(eb, em)
        self.assertEqual(em.rate_hz, 120.0)
        n = min(len(Qe), len(self.Q))
        for seg, joint in segments:
            G = qmat(self.Q[:n, self.body.index_of(joint)])
            E = qmat(Qe[:n, eb.index_of(seg)])
            self.assertLess(offset_spread_deg(G, info["R_world_input"], E), limit_deg, seg)

    def test_kinect_keypoints_give_back_the_arms_rotations(self):
        kp = self.keypoints("kinect_v1_20", KINECT_FROM_CMU)
        eb, em, info = imukit.motion_from_keypoints(kp, "kinect_v1_20", times=self.t, output_rate_hz=120.0,
                                                    cutoff_hz=6.0, up=[0, 0, 1.0])
        self.assertEqual(len(eb), 18)
        self.assertEqual(em.frame_count, len(self.t))
        np.testing.assert_allclose(info["up_input"], [0, 0, 1], atol=1e-12)
        # Upper arms and forearms: the CMU elbows are hinges, so the whole rotation comes back
        # (measured 0.4 deg on the full take at 6 Hz; 2 deg bound).
        self.check_limbs(eb, em, info, [("left_shoulder", "LeftShoulder"), ("right_elbow", "RightElbow"),
                                        ("left_elbow", "LeftElbow")], 2.0)
        lengths = {s["joint"]: s["length_m"] for s in info["segments"]}
        forearm = np.linalg.norm(self.P[0, self.body.index_of("RightWrist")] - self.P[0, self.body.index_of("RightElbow")])
        self.assertAlmostEqual(lengths["right_elbow"], forearm, places=6)

    def test_h36m_keypoints_as_a_dict_topology(self):
        topo = imukit.keypoint_topology("h36m_17")
        self.assertEqual(topo["schema"], "imukit.keypoint_topology/1")
        kp = self.keypoints("h36m_17", {**KINECT_FROM_CMU, **H36M_FROM_CMU})
        eb, em, info = imukit.motion_from_keypoints(kp, topo, rate_hz=120.0, output_rate_hz=120.0, cutoff_hz=6.0)
        self.assertEqual(len(eb), 18)  # 17 keypoints: 18 joints (both wrists and ankles are leaves)
        self.check_limbs(eb, em, info, [("right_shoulder", "RightShoulder"), ("right_elbow", "RightElbow")], 2.0)
        self.assertEqual(info["up_source"], "upright body")

    def test_bad_arguments_and_input_raise_imukit_errors(self):
        kp = self.keypoints("kinect_v1_20", KINECT_FROM_CMU)
        with self.assertRaisesRegex(ValueError, "exactly one of rate_hz= and times="):
            imukit.motion_from_keypoints(kp, "kinect_v1_20")
        # Found in review (2026-11-26): "Unable to cast Python instance of type <class 'str'> to
        # C++ type 'double'".
        with self.assertRaises(TypeError) as e:
            imukit.motion_from_keypoints(kp, "kinect_v1_20", rate_hz="50")
        self.assertEqual(str(e.exception), "motion_from_keypoints: rate_hz: expected a number, got str")
        with self.assertRaisesRegex(ValueError, r"expected shape \(frames, keypoints, 3\)"):
            imukit.motion_from_keypoints(kp[:, :, :2], "kinect_v1_20", rate_hz=120.0)
        with self.assertRaisesRegex(imukit.Error, "a motion needs at least 2 frames"):
            imukit.motion_from_keypoints(kp[:1], "kinect_v1_20", rate_hz=120.0)
        gone = kp.copy()
        gone[:, 7] = np.nan
        with self.assertRaisesRegex(imukit.Error, "keypoint 'left_hand' is missing in every frame"):
            imukit.motion_from_keypoints(gone, "kinect_v1_20", rate_hz=120.0)
        with self.assertRaisesRegex(imukit.Error, "20 keypoints per frame, topology h36m_17 has 17"):
            imukit.motion_from_keypoints(kp, "h36m_17", rate_hz=120.0)
        gap = kp.copy()
        gap[50:53, 10] = np.nan
        _, _, info = imukit.motion_from_keypoints(gap, "kinect_v1_20", rate_hz=120.0)
        self.assertEqual(info["missing_frames"], [50, 51, 52])
        self.assertIn("50-52", info["warnings"][0])
        # From the frame with data before the run to the one after (review, 2026-11-27).
        self.assertEqual(info["invalid_motion_ns"], [(round(49e9 / 120), round(53e9 / 120))])
        # Found in review, 2026-11-27: jump_speed_mps=nan turned jump flagging off without a word,
        # while every other threshold was checked.
        for v in (float("nan"), -1.0):
            with self.assertRaises(imukit.Error) as e:
                imukit.motion_from_keypoints(kp, "kinect_v1_20", rate_hz=120.0, jump_speed_mps=v)
            self.assertEqual(str(e.exception), "motion_from_keypoints: jump_speed_mps must be >= 0")

    def test_per_subject_offsets_are_used_as_given(self):
        kp = self.keypoints("kinect_v1_20", KINECT_FROM_CMU)
        b1, _, _ = imukit.motion_from_keypoints(kp[:120], "kinect_v1_20", rate_hz=120.0)
        b2, _, _ = imukit.motion_from_keypoints(kp[120:], "kinect_v1_20", rate_hz=120.0)
        avg = imukit.average_bodies([b1, b2])
        np.testing.assert_allclose(avg.offsets, np.median([b1.offsets, b2.offsets], axis=0), atol=1e-15)
        b3, m3, _ = imukit.motion_from_keypoints(kp, "kinect_v1_20", rate_hz=120.0, body=avg)
        np.testing.assert_array_equal(b3.offsets, avg.offsets)
        with self.assertRaisesRegex(imukit.Error, "the body given has 21 joints"):
            imukit.motion_from_keypoints(kp, "kinect_v1_20", rate_hz=120.0, body=imukit.Body.default_humanoid())


class HingeNearStraight(unittest.TestCase):
    def test_an_elbow_bending_through_straight_does_not_spin_the_upper_arm(self):
        """Found in review, 2026-11-27: the elbow plane's normal was taken with its sign, so an arm
        passing straight into an apparent hyperextension turned the upper arm by 180 degrees about
        itself (17 of 96 UTD-MHAD swing and throw trials, 195 degrees in 0.3 s in a12_s1_t1)."""
        names = imukit.keypoint_topology("kinect_v1_20")["keypoints"]
        pose = {  # a T-pose, z up, the arms along x
            "head": (0, 0, 1.65), "shoulder_center": (0, 0, 1.45), "spine": (0, 0, 1.1), "hip_center": (0, 0, 0.95),
            "left_shoulder": (-0.2, 0, 1.42), "left_elbow": (-0.47, 0, 1.42), "left_wrist": (-0.72, 0, 1.42),
            "left_hand": (-0.8, 0, 1.42), "right_shoulder": (0.2, 0, 1.42), "left_hip": (-0.1, 0, 0.9),
            "left_knee": (-0.1, 0.02, 0.5), "left_ankle": (-0.1, 0, 0.1), "left_foot": (-0.1, 0.12, 0.05),
            "right_hip": (0.1, 0, 0.9), "right_knee": (0.1, 0.02, 0.5), "right_ankle": (0.1, 0, 0.1),
            "right_foot": (0.1, 0.12, 0.05)}
        fps, frames = 30, 120
        kp = np.zeros((frames, len(names), 3))
        bends = 25 + 45 * np.cos(2 * np.pi * np.arange(frames) / frames)  # 70 degrees to -20 and back
        for i, bend in enumerate(np.radians(bends)):
            elbow = np.array([0.47, 0, 1.42])
            forearm = np.array([np.cos(bend), np.sin(bend), 0])
            pose.update(right_elbow=elbow, right_wrist=elbow + 0.25 * forearm, right_hand=elbow + 0.33 * forearm)
            kp[i] = [pose[n] for n in names]
            kp[i] += 1e-4 * np.sin(np.arange(kp[i].size).reshape(kp[i].shape) + i)  # a little jitter
        body, motion, _ = imukit.motion_from_keypoints(kp, "kinect_v1_20", rate_hz=fps, up=[0, 0, 1])
        q = np.asarray(motion.rotations_wxyz())[:, body.joint_names.index("right_shoulder")]
        twist = np.degrees(2 * np.arctan2(q[:, 1], q[:, 0]))  # about the upper arm (x)
        self.assertLess(np.max(np.abs(twist)), 5.0, f"upper-arm twist up to {np.max(np.abs(twist)):.1f} degrees")


class H36mThighTwist(unittest.TestCase):
    def test_a_bent_knee_gives_the_whole_thigh_rotation(self):
        """Found in review, 2026-11-27: Human3.6M's hip line, a fallback for a straight knee, was
        averaged with the knee plane as an equal partner, so a thigh turned by theta with the knee
        bent 90 degrees read theta / 2 and the knee took the rest as a sideways rotation."""
        names = imukit.keypoint_topology("h36m_17")["keypoints"]
        base = {"pelvis": (0, 0, 0.95), "right_hip": (0.1, 0, 0.92), "right_knee": (0.1, 0, 0.5),
                "right_ankle": (0.1, 0, 0.1), "left_hip": (-0.1, 0, 0.92), "left_knee": (-0.1, 0, 0.5),
                "spine": (0, 0, 1.15), "thorax": (0, 0, 1.4), "neck": (0, 0.02, 1.5), "head": (0, 0, 1.65),
                "left_shoulder": (-0.2, 0, 1.4), "left_elbow": (-0.45, 0, 1.4), "left_wrist": (-0.55, 0.25, 1.4),
                "right_shoulder": (0.2, 0, 1.4), "right_elbow": (0.45, 0, 1.4), "right_wrist": (0.55, 0.25, 1.4)}
        frames = 60
        for theta in (20.0, 60.0):
            pose = dict(base)
            th = np.radians(theta)  # the shank, bent 90 degrees, swung by theta about the vertical thigh
            pose["left_ankle"] = tuple(np.array(base["left_knee"]) + 0.4 * np.array([np.sin(th), -np.cos(th), 0]))
            one = np.array([pose[n] for n in names])
            kp = np.stack([one + 1e-4 * np.sin(i + np.arange(len(names)))[:, None] for i in range(frames)])
            body, motion, _ = imukit.motion_from_keypoints(kp, "h36m_17", times=np.arange(frames) / 30,
                                                           up=[0, 0, 1])
            q = np.asarray(motion.rotations_wxyz())[frames // 2]
            thigh, knee = q[body.joint_names.index("left_hip")], q[body.joint_names.index("left_knee")]
            self.assertAlmostEqual(np.degrees(2 * np.arctan2(thigh[3], thigh[0])), theta, delta=1.0)
            self.assertLess(np.max(np.abs(knee[2:])), 0.01, f"the knee bends about one axis: {knee}")


class CustomBody(unittest.TestCase):
    def test_from_arrays_round_trips_and_simulates_with_presets(self):
        names = ["Hips", "Spine1", "RightArm", "RightForeArm", "RightHand"]
        parents = [-1, 0, 1, 2, 3]
        offsets = np.array([[0, 0, 0], [0, 0, 0.3], [0.2, 0, 0.2], [0.3, 0, 0], [0.25, 0, 0]])
        b = imukit.Body.from_arrays(names, parents, offsets)
        self.assertEqual(b.joint_names, ["pelvis", "chest", "right_shoulder", "right_elbow", "right_wrist"])
        self.assertEqual(b.parents, parents)
        np.testing.assert_array_equal(b.offsets, offsets)
        self.assertEqual(b.index_of("RightForeArm"), 3)
        m = imukit.ProceduralMotion(len(b), rate_hz=100.0, frames=201)
        scene = imukit.Scene(b, m)
        scene.add_sensor(preset="right_wrist_watch")
        out = scene.simulate()["right_wrist_watch"]
        self.assertEqual(len(out.t), 201)
        with self.assertRaisesRegex(imukit.Error, r"joint 2 \('RightArm'\): parent 3 must be an earlier joint"):
            imukit.Body.from_arrays(names, [-1, 0, 3, 2, 3], offsets)
        with self.assertRaisesRegex(ValueError, r"offsets: expected shape \(5, 3\)"):
            imukit.Body.from_arrays(names, parents, offsets[:4])


class UtdMhadTrial(unittest.TestCase):
    def test_a_real_kinect_trial_becomes_a_simulatable_motion(self):
        from imukit.datasets import utd_mhad
        root = os.path.dirname(data_file("utd_mhad", "README.md"))
        trial = utd_mhad.load_trial(root, utd_mhad.TrialId(1, 1, 1))
        times = np.linspace(0, trial.duration_s, len(trial.keypoints))
        body, motion, info = imukit.motion_from_keypoints(trial.keypoints, "kinect_v1_20", times=times)
        self.assertEqual(motion.frame_count, 321)  # 3.2 s at 100 Hz
        lengths = {s["joint"]: s["length_m"] for s in info["segments"]}
        # Subject 1's forearms and shanks: 23-24 cm and 36-37 cm (docs/keypoints.md); symmetric.
        self.assertTrue(0.20 < lengths["right_elbow"] < 0.27, lengths)
        self.assertLess(abs(lengths["left_knee"] - lengths["right_knee"]), 0.02)
        # The camera stood nearly level: up within 8 degrees of its y axis.
        self.assertGreater(info["up_input"][1], np.cos(np.radians(8)))
        # Input frame 36: the right arm snaps back 45 cm after eight near-frozen frames (Kinect
        # lost it while it crossed the body): named, and its stretch left to identification.
        self.assertEqual(info["jump_frames"], [36])
        self.assertTrue(any("into input frames 36" in w for w in info["warnings"]), info["warnings"])
        self.assertEqual(len(info["invalid_motion_ns"]), 1)
        scene = imukit.Scene(body, motion, method="spline", rate_hz=50.0)
        scene.add_sensor(preset="right_wrist_watch")
        out = scene.simulate()["right_wrist_watch"]
        valid = np.ones(len(out.t), bool)
        for b, e in info["invalid_motion_ns"]:
            valid &= (out.t < b) | (out.t > e)
        # A standing subject swiping an arm: outside the jump the mean specific force is about g
        # (the real IMU's is 10.06 m/s^2) and the rate stays human (the real IMU peaks at 4.6 rad/s).
        self.assertAlmostEqual(np.linalg.norm(out.accel[valid], axis=1).mean(), 10.1, delta=1.0)
        self.assertLess(np.linalg.norm(out.gyro[valid], axis=1).max(), 8.0)


class Concurrency(unittest.TestCase):
    def test_world_poses_releases_the_gil(self):
        # Found in review (2026-11-26): 60,000 frames held the GIL for 134 ms.
        body, motion, _ = imukit.read_bvh(WALK)
        rot = np.tile(motion.rotations_wxyz(), (200, 1, 1))
        tr = np.tile(motion.root_translation(), (200, 1))
        long = imukit.Motion.from_arrays(rot, tr, rate_hz=motion.rate_hz, body=body)
        steps, seconds = python_steps_during(lambda: imukit.world_poses(body, long))
        self.assertGreater(seconds, 0.05)
        self.assertGreater(steps, 0, f"no Python step in the middle of a {seconds:.3f} s world_poses()")
        P, Q = imukit.world_poses(body, long)
        n = motion.frame_count
        P1, Q1 = imukit.world_poses(body, imukit.Motion.from_arrays(rot[:n], tr[:n], rate_hz=motion.rate_hz))
        self.assertEqual((P.shape, Q.shape), ((200 * n, len(body), 3), (200 * n, len(body), 4)))
        np.testing.assert_array_equal(P[-n:], P1)
        np.testing.assert_array_equal(Q[-n:], Q1)
        with self.assertRaisesRegex(imukit.Error, "world_poses: the motion has 31 joints, the body 3"):
            imukit.world_poses(imukit.Body.from_arrays(["a", "b", "c"], [-1, 0, 1], np.zeros((3, 3))), long)

    def test_reading_a_keypoint_file_releases_the_gil(self):
        # Found in review: a 98 MB CSV held the GIL for its whole 0.64 s read.
        topo = imukit.keypoint_topology("kinect_v1_20")
        names = ["t"] + [f"{k}_{c}" for k in topo["keypoints"] for c in "xyz"]
        frames = 40_000
        rows = np.random.default_rng(1).uniform(-1, 1, (frames, len(names)))
        rows[:, 0] = np.arange(frames) / 30.0
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "k.csv")
            np.savetxt(path, rows, fmt="%.6f", delimiter=",", header=",".join(names), comments="")
            steps, seconds = python_steps_during(lambda: imukit.read_keypoints(path, "kinect_v1_20"))
        self.assertGreater(seconds, 0.05)
        self.assertGreater(steps, 0, f"no Python step in the middle of a {seconds:.3f} s read")
