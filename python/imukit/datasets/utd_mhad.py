"""UTD-MHAD (Chen, Jafari, Kehtarnavaz, ICIP 2015): a wrist or thigh IMU and a Kinect v1 skeleton
per trial, 8 subjects x 27 actions x about 4 trials.

The files are MATLAB v5 (`d_iner`: N x 6, accelerometer in g, gyroscope in deg/s, 50 Hz;
`d_skel`: 20 x 3 x F joint positions in metres, Kinect camera frame: right-handed, x to the
camera's left (the subject's right when facing it), y up, z away from the camera, as
docs/formats.md says; "x right" here read as a left-handed frame until review, 2026-11-27). SciPy's loadmat reads them (Debian python3-scipy); the C++ side has no need for
MATLAB files, so no libmatio dependency is added for one dataset.

The reader converts to SI (m/s^2 with standard gravity, rad/s) and changes nothing else: the
sensor axes and the camera frame stay as recorded.
"""
import dataclasses
import os
import re

import numpy as np

from .._imukit import STANDARD_GRAVITY  # m/s^2 per g (the dataset's accelerometer unit)

IMU_RATE_HZ = 50.0

# Kinect v1 joint order of Skeleton_joint_order.txt (the `kinect_v1_20` topology).
JOINTS = ("head", "shoulder_center", "spine", "hip_center",
          "left_shoulder", "left_elbow", "left_wrist", "left_hand",
          "right_shoulder", "right_elbow", "right_wrist", "right_hand",
          "left_hip", "left_knee", "left_ankle", "left_foot",
          "right_hip", "right_knee", "right_ankle", "right_foot")

ACTIONS = ("right arm swipe to the left", "right arm swipe to the right", "right hand wave",
           "two hand front clap", "right arm throw", "cross arms in the chest", "basketball shoot",
           "right hand draw x", "right hand draw circle (clockwise)",
           "right hand draw circle (counter clockwise)", "draw triangle", "bowling (right hand)",
           "front boxing", "baseball swing from right", "tennis right hand forehand swing",
           "arm curl (two arms)", "tennis serve", "two hand push", "right hand knock on door",
           "right hand catch an object", "right hand pick up and throw", "jogging in place",
           "walking in place", "sit to stand", "stand to sit", "forward lunge (left foot forward)",
           "squat (two arms stretch out)")

# No leading zeros: the stem a{action}_s{subject}_t{trial} is then the name found (found in
# review, 2026-11-27: a01_s01_t01 was listed as a1_s1_t1 and opened under that other name).
_NAME = re.compile(r"^a([1-9]\d*)_s([1-9]\d*)_t([1-9]\d*)_(inertial|skeleton)\.mat$")
_SUBJECT = re.compile(r"^s?([1-9]\d*)$")


def parse_subjects(text):
    """Subject numbers from a comma list as the dataset names them (`s1,s4`) or bare (`1,4`)."""
    out = []
    for item in text.split(","):
        m = _SUBJECT.match(item.strip())
        if not m:
            raise ValueError(f"subject {item.strip()!r}: expected a subject as s1 or 1 (comma separated)")
        out.append(int(m.group(1)))
    return out


def sensor_site(action):
    """Where the IMU was worn: the right wrist for actions 1-21, the right thigh for 22-27."""
    if not 1 <= action <= len(ACTIONS):
        raise ValueError(f"UTD-MHAD action {action} is not in 1..{len(ACTIONS)}")
    return "right_wrist" if action <= 21 else "right_thigh"


@dataclasses.dataclass(frozen=True)
class TrialId:
    action: int
    subject: int
    trial: int

    @property
    def stem(self):
        return f"a{self.action}_s{self.subject}_t{self.trial}"


@dataclasses.dataclass
class Trial:
    id: TrialId
    accel: np.ndarray       # (N, 3) m/s^2, sensor frame
    gyro: np.ndarray        # (N, 3) rad/s, sensor frame
    keypoints: np.ndarray   # (F, 20, 3) m, Kinect camera frame, joints in JOINTS order
    imu_rate_hz: float = IMU_RATE_HZ

    @property
    def duration_s(self):
        """The trial's length by its IMU; the skeleton spans the same interval (README)."""
        return len(self.accel) / self.imu_rate_hz

    @property
    def site(self):
        return sensor_site(self.id.action)


def list_trials(root):
    """Every trial with both an inertial and a skeleton file, sorted by (subject, action, trial),
    and the files that have no partner (the published release lacks a few). A file of an action
    outside 1..27 is a ValueError naming it (found in review, 2026-11-27: it failed later, in
    sensor_site, naming neither file nor trial)."""
    found = {"inertial": set(), "skeleton": set()}
    for kind, folder in (("inertial", "Inertial"), ("skeleton", "Skeleton")):
        path = os.path.join(root, folder)
        if not os.path.isdir(path):
            raise FileNotFoundError(f"{path}: no such folder (expected UTD-MHAD's {folder}/)")
        for name in os.listdir(path):
            m = _NAME.match(name)
            if m and m.group(4) == kind:
                action, subject, trial = map(int, m.groups()[:3])
                if action > len(ACTIONS):
                    raise ValueError(f"{os.path.join(path, name)}: UTD-MHAD action {action} is not in "
                                     f"1..{len(ACTIONS)}")
                found[kind].add(TrialId(action, subject, trial))
    both = sorted(found["inertial"] & found["skeleton"],
                  key=lambda t: (t.subject, t.action, t.trial))
    unpaired = sorted(found["inertial"] ^ found["skeleton"],
                      key=lambda t: (t.subject, t.action, t.trial))
    return both, unpaired


def _read_matrix(path, variable):
    from scipy.io import loadmat  # imported here: only this reader needs SciPy
    try:
        content = loadmat(path)
    except Exception as e:  # scipy raises several types for a damaged file
        raise ValueError(f"{path}: not a readable MATLAB file ({e})") from None
    if variable not in content:
        raise ValueError(f"{path}: variable '{variable}' missing")
    m = np.asarray(content[variable], dtype=np.float64)
    if not np.all(np.isfinite(m)):
        bad = np.argwhere(~np.isfinite(m))[0]
        raise ValueError(f"{path}: '{variable}' has a non-finite value at index {tuple(bad)}")
    return m


def load_trial(root, trial_id):
    """One trial in SI units; raises ValueError naming the file for anything malformed."""
    stem = trial_id.stem
    ipath = os.path.join(root, "Inertial", f"{stem}_inertial.mat")
    spath = os.path.join(root, "Skeleton", f"{stem}_skeleton.mat")
    iner = _read_matrix(ipath, "d_iner")
    if iner.ndim != 2 or iner.shape[1] != 6 or iner.shape[0] < 2:
        raise ValueError(f"{ipath}: d_iner has shape {iner.shape}, expected (N >= 2, 6)")
    skel = _read_matrix(spath, "d_skel")
    if skel.ndim != 3 or skel.shape[:2] != (len(JOINTS), 3) or skel.shape[2] < 2:
        raise ValueError(f"{spath}: d_skel has shape {skel.shape}, expected (20, 3, F >= 2)")
    return Trial(id=trial_id,
                 accel=iner[:, 0:3] * STANDARD_GRAVITY,
                 gyro=np.deg2rad(iner[:, 3:6]),
                 keypoints=np.ascontiguousarray(np.transpose(skel, (2, 0, 1))))
