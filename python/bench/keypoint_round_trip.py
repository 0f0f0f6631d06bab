"""Round trip of imukit.motion_from_keypoints on synthetic Kinect-like keypoints (docs/keypoints.md).

A known BVH motion (truth) -> joint positions by forward kinematics -> Kinect v1 keypoints seen by
a tilted camera, resampled to a Kinect-like frame rate, with Gaussian jitter and occasional
left/right arm swaps -> motion_from_keypoints -> compared with the truth:
  - segment rotations (deg, RMS over time, split into swing of the bone and twist about it), after
    removing the constant offset between the BVH's segment frames and the keypoint segment frames
    (the chordal mean of G(t)^T A^T E(t));
  - a wrist IMU (on the left forearm, 90 % to the wrist) simulated on both at 120 Hz with the
    spline method, against the truth as is and low-passed at 5 Hz (what a camera at 19-30 fps can
    show): RMSE and Pearson correlation per axis (mean over axes) of accelerometer and
    gyroscope. The sensor sits at the same physical pose on both (the truth placement carried over
    by the same constant offset: what identification would fit).

  PYTHONPATH=build/release/python /usr/bin/python3 python/bench/keypoint_round_trip.py [--table]
"""
import argparse
import os
import sys

import numpy as np

import imukit

# The IMUs are compared at the mocap's rate: sampled at 50 Hz, the truth's mocap noise above
# 25 Hz would alias into the band and no filter could take it out again.
IMU_RATE = 120.0
DATA = os.environ.get("IMUKIT_DATA_DIR", os.path.join(os.path.dirname(__file__), "../../../shared/data"))

# Kinect v1 keypoint -> the BVH joint whose position stands for it (CMU 3dsMax release names).
KINECT_FROM_CMU = {
    "head": "Head", "shoulder_center": "lowerneck", "spine": "Chest", "hip_center": "Hips",
    "left_shoulder": "LeftShoulder", "left_elbow": "LeftElbow", "left_wrist": "LeftWrist",
    "left_hand": "LFingers", "right_shoulder": "RightShoulder", "right_elbow": "RightElbow",
    "right_wrist": "RightWrist", "right_hand": "RFingers", "left_hip": "LeftHip",
    "left_knee": "LeftKnee", "left_ankle": "LeftAnkle", "left_foot": "LeftToe",
    "right_hip": "RightHip", "right_knee": "RightKnee", "right_ankle": "RightAnkle",
    "right_foot": "RightToe"}
# Keypoint segment -> the BVH joint carrying the same body part.
SEGMENT_TRUTH = {"pelvis": "Hips", "left_shoulder": "LeftShoulder", "left_elbow": "LeftElbow",
                 "right_shoulder": "RightShoulder", "right_elbow": "RightElbow",
                 "left_hip": "LeftHip", "left_knee": "LeftKnee", "left_ankle": "LeftAnkle",
                 "right_hip": "RightHip", "right_knee": "RightKnee", "right_ankle": "RightAnkle"}


def qmat(q):
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1)], -2)


def mat_quat(R):
    # Shepperd's method, one matrix at a time (few thousand: fine).
    out = []
    for M in R.reshape(-1, 3, 3):
        t = np.trace(M)
        if t > 0:
            s = np.sqrt(t + 1) * 2
            q = [0.25 * s, (M[2, 1] - M[1, 2]) / s, (M[0, 2] - M[2, 0]) / s, (M[1, 0] - M[0, 1]) / s]
        else:
            i = int(np.argmax(np.diag(M)))
            j, k = (i + 1) % 3, (i + 2) % 3
            s = np.sqrt(1 + M[i, i] - M[j, j] - M[k, k]) * 2
            q = [0.0] * 4
            q[0] = (M[k, j] - M[j, k]) / s
            q[1 + i] = 0.25 * s
            q[1 + j] = (M[j, i] + M[i, j]) / s
            q[1 + k] = (M[k, i] + M[i, k]) / s
        out.append(q)
    return np.array(out).reshape(R.shape[:-2] + (4,))


def chordal_mean(R):
    U, _, Vt = np.linalg.svd(R.sum(0))
    M = U @ Vt
    if np.linalg.det(M) < 0:
        U[:, -1] *= -1
        M = U @ Vt
    return M


def swing_twist_deg(D, axis):
    """RMS swing and twist angles (deg) of rotations D (n, 3, 3) about a unit axis."""
    q = mat_quat(D)
    q *= np.sign(q[:, :1] + 1e-300)
    proj = q[:, 1:] @ axis
    twist = 2 * np.arctan2(np.abs(proj), q[:, 0])
    total = 2 * np.arctan2(np.linalg.norm(q[:, 1:], axis=1), q[:, 0])
    # swing = D twist^-1; its angle from the swung axis.
    swing = np.arccos(np.clip(np.einsum("nij,j,i->n", D, axis, axis), -1, 1))
    del total
    return np.degrees(np.sqrt(np.mean(swing ** 2))), np.degrees(np.sqrt(np.mean(twist ** 2)))


def camera(tilt_deg):
    """Camera rotation R_cam_world: Kinect axes (x to the camera's left, y up, z from the camera
    towards the subject), the subject facing the camera, the camera pitched down by tilt_deg."""
    # World: x right, y forward (towards the camera), z up. Camera facing -y (the subject).
    base = np.array([[1.0, 0, 0], [0, 0, 1], [0, -1, 0]])  # x_c = x_w, y_c = z_w, z_c = -y_w
    a = np.radians(tilt_deg)
    tilt = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    return tilt @ base


def run(bvh, fps=19.0, jitter_m=0.01, swap_rate=0.01, tilt_deg=10.0, cutoff_hz=3.0, seed=1,
        give_up=False, band_hz=5.0):
    rng = np.random.default_rng(seed)
    body, motion, _ = imukit.read_bvh(bvh)
    P, Q = imukit.world_poses(body, motion)
    F = P.shape[0]
    rate = motion.rate_hz
    topo = imukit.keypoint_topology("kinect_v1_20")
    names = topo["keypoints"]
    neutral = {s["joint"]: s["neutral"] for s in topo["segments"]}
    idx = [body.index_of(KINECT_FROM_CMU[n]) for n in names]
    Rc = camera(tilt_deg)
    cam = (P[:, idx, :] - np.array([0, 3.0, 0])) @ Rc.T + np.array([0, 0.8, 0])
    # Kinect-like sampling: linear interpolation of the 120 Hz positions at fps.
    duration = (F - 1) / rate
    t = np.arange(0, duration, 1 / fps)
    tf = t * rate
    i0 = np.minimum(np.floor(tf).astype(int), F - 2)
    a = (tf - i0)[:, None, None]
    kp = (1 - a) * cam[i0] + a * cam[i0 + 1]
    kp = kp + rng.normal(0, jitter_m, kp.shape)
    swaps = []
    if swap_rate > 0:
        L = [names.index(n) for n in ("left_elbow", "left_wrist", "left_hand")]
        R = [names.index(n) for n in ("right_elbow", "right_wrist", "right_hand")]
        for f in np.nonzero(rng.random(len(t)) < swap_rate)[0]:
            kp[f, L + R] = kp[f, R + L]
            swaps.append(int(f))
    up = Rc @ np.array([0, 0, 1.0]) if give_up else None
    eb, em, info = imukit.motion_from_keypoints(kp, "kinect_v1_20", times=t, cutoff_hz=cutoff_hz,
                                                output_rate_hz=100.0, up=up)
    Pe, Qe = imukit.world_poses(eb, em)
    A = info["R_world_input"] @ Rc  # estimate world <- truth world
    # Common instants: multiples of 1/20 s lie on both grids (120 Hz and 100 Hz).
    n = int(min((F - 1) / rate, (em.frame_count - 1) / 100.0) * 20) + 1
    ti = np.arange(n) * 6
    ei = np.arange(n) * 5
    res = {"swaps_injected": len(swaps), "swaps_found": len(info["swapped_frames"]),
           "up_error_deg": float(np.degrees(np.arccos(np.clip(info["up_input"] @ (Rc @ [0, 0, 1.0]), -1, 1)))),
           "segments": {}}
    offsets = {}
    for seg, joint in SEGMENT_TRUTH.items():
        G = qmat(Q[ti, body.index_of(joint)])
        E = qmat(Qe[ei, eb.index_of(seg)])
        Bt = np.einsum("nji,jk,nkl->nil", G, A.T, E)  # G^T A^T E
        B = chordal_mean(Bt)
        offsets[seg] = B
        D = np.einsum("ji,njk->nik", B, Bt)  # B^T B(t)
        axis = np.array(neutral[seg]) / np.linalg.norm(neutral[seg])
        res["segments"][seg] = swing_twist_deg(D, axis)
    # Wrist IMU on the left forearm, 90 % to the wrist, axes of the BVH forearm frame (the left:
    # the right arm of 131_01 has a mocap glitch, docs/validation.md "Real motion").
    jt = body.index_of("LeftElbow")
    child = [i for i, p in enumerate(body.parents) if p == jt][0]
    p_true = 0.9 * body.offsets[child]
    B = offsets["left_elbow"]
    p_est = B.T @ p_true
    q_est = mat_quat(B.T[None])[0]
    truth = imukit.Scene(body, motion, method="spline", rate_hz=IMU_RATE)
    truth.add_sensor("w", joint="LeftElbow", position_m=p_true, q_joint_sensor=[1.0, 0, 0, 0])
    est = imukit.Scene(eb, em, method="spline", rate_hz=IMU_RATE)
    est.add_sensor("w", joint="left_elbow", position_m=p_est, q_joint_sensor=q_est)
    st, se = truth.simulate()["w"], est.simulate()["w"]
    m = min(len(st.t), len(se.t))
    assert np.array_equal(st.t[:m], se.t[:m])
    from scipy.signal import butter, filtfilt  # Debian python3-scipy
    b, a = butter(2, band_hz / (IMU_RATE / 2))
    for key in ("accel", "gyro"):
        x, y = getattr(st, key)[:m], getattr(se, key)[:m]
        xb = filtfilt(b, a, x, axis=0)  # the truth in the band a camera at fps can show
        for name, ref in ((key, x), (key + "_band", xb)):
            rmse = np.sqrt(np.mean((ref - y) ** 2, axis=0))
            corr = [np.corrcoef(ref[:, k], y[:, k])[0, 1] for k in range(3)]
            res[name] = {"rmse": float(rmse.mean()), "corr": float(np.mean(corr)),
                         "signal_rms": float(np.sqrt(np.mean((ref - ref.mean(0)) ** 2, axis=0)).mean())}
    res["warnings"] = info["warnings"]
    return res


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bvh", default=os.path.join(DATA, "mocap", "scaled_131_01_walk.bvh"))
    ap.add_argument("--table", action="store_true", help="the tables of docs/keypoints.md")
    args = ap.parse_args()
    if not os.path.exists(args.bvh):
        sys.exit(f"{args.bvh}: missing (set IMUKIT_DATA_DIR)")

    def line(label, r):
        segs = r["segments"]
        sw = lambda names: np.mean([segs[n][0] for n in names])
        tw = lambda names: np.mean([segs[n][1] for n in names])
        arms, fore = ["left_shoulder", "right_shoulder"], ["left_elbow", "right_elbow"]
        legs = ["left_hip", "right_hip", "left_knee", "right_knee"]
        print(f"| {label} | {segs['pelvis'][0]:.1f} / {segs['pelvis'][1]:.1f} | "
              f"{sw(arms):.1f} / {tw(arms):.1f} | {sw(fore):.1f} / {tw(fore):.1f} | "
              f"{sw(legs):.1f} / {tw(legs):.1f} | {r['accel']['rmse']:.2f} ({r['accel']['corr']:.2f}) | "
              f"{r['accel_band']['rmse']:.2f} ({r['accel_band']['corr']:.2f}) | "
              f"{r['gyro']['rmse']:.2f} ({r['gyro']['corr']:.2f}) | "
              f"{r['gyro_band']['rmse']:.2f} ({r['gyro_band']['corr']:.2f}) | {r['swaps_found']}/{r['swaps_injected']} | "
              f"{r['up_error_deg']:.1f} |")

    body, motion, _ = imukit.read_bvh(args.bvh)
    print(f"{os.path.basename(args.bvh)}: {motion.frame_count} frames at {motion.rate_hz} Hz")
    print("| case | pelvis swing/twist (deg) | upper arms | forearms | thighs+shanks | wrist acc RMSE m/s^2 (corr) | "
          "same, truth below 5 Hz | wrist gyro RMSE rad/s (corr) | same, truth below 5 Hz | swaps found/injected | "
          "up error (deg) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    cases = [("exact keypoints, 120 fps", dict(fps=120.0, jitter_m=0.0, swap_rate=0.0)),
             ("exact, 19 fps", dict(fps=19.0, jitter_m=0.0, swap_rate=0.0)),
             ("19 fps, 1 cm jitter", dict(fps=19.0, jitter_m=0.01, swap_rate=0.0)),
             ("19 fps, 1 cm, 2 % swaps", dict(fps=19.0, jitter_m=0.01, swap_rate=0.02)),
             ("19 fps, 2 cm jitter", dict(fps=19.0, jitter_m=0.02, swap_rate=0.0)),
             ("19 fps, 1 cm, up given", dict(fps=19.0, jitter_m=0.01, swap_rate=0.0, give_up=True)),
             ("30 fps, 1 cm jitter", dict(fps=30.0, jitter_m=0.01, swap_rate=0.0))]
    if not args.table:
        cases = cases[2:4]
    for label, kw in cases:
        line(label, run(args.bvh, **kw))
    if args.table:
        print()
        print("| cut-off (Hz), 19 fps, 1 cm | forearm swing/twist (deg) | wrist acc RMSE (corr), truth below 5 Hz | "
              "wrist gyro RMSE (corr), truth below 5 Hz |")
        print("|---|---|---|---|")
        for fc in (1.5, 2.0, 3.0, 4.0, 6.0):
            r = run(args.bvh, fps=19.0, jitter_m=0.01, swap_rate=0.0, cutoff_hz=fc)
            f = r["segments"]["left_elbow"]
            print(f"| {fc} | {f[0]:.1f} / {f[1]:.1f} | {r['accel_band']['rmse']:.2f} ({r['accel_band']['corr']:.2f}) | "
                  f"{r['gyro_band']['rmse']:.2f} ({r['gyro_band']['corr']:.2f}) |")
        print()
        print(f"truth signal RMS (std over time, mean of axes): acc {r['accel']['signal_rms']:.2f} m/s^2 "
              f"({r['accel_band']['signal_rms']:.2f} below 5 Hz), gyro {r['gyro']['signal_rms']:.2f} rad/s "
              f"({r['gyro_band']['signal_rms']:.2f} below 5 Hz)")


if __name__ == "__main__":
    main()
