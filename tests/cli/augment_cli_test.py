"""End-to-end tests of `imukit augment` through the real binary, read back with NumPy: a PPDA
dataset from a scene (shapes, dtypes, labels from segments, sub-policy indices, dataset.json), the
same bytes for 1 and 2 threads, identity batches equal to `imukit simulate`, an STDA dataset from
a recording, a JSON policy, the built-in grid listing (810 sub-policies), and one-line errors.

run: pytest (tests/pytest.ini), $IMUKIT_CLI the command under test
"""
import json
import os

import numpy as np
import pytest


@pytest.fixture(scope="module")
def scene_file(workdir):
    scene = {
        "schema": "imukit.scene/1",
        "motion": {"procedural": {"rate_hz": 50, "duration_s": 20, "seed": 3}},
        "simulation": {"seed": 7},
        "sensors": [{"name": "watch", "preset": "left_wrist_watch"},
                    {"name": "belt", "preset": "waist_belt"}],
    }
    spath = os.path.join(workdir, "scene.json")
    json.dump(scene, open(spath, "w"))
    return spath


def test_paper_grid_lists_810_sub_policies(run):
    r = run("augment", "--policy", "paper", "--list-sub-policies")
    lines = [l for l in r.stdout.splitlines() if l.strip()]
    assert r.returncode == 0 and lines[0].startswith("policy paper: 810 sub-policies") and len(lines) == 811, \
        "the paper's grid lists 810 sub-policies"


@pytest.fixture(scope="module")
def ppda_dataset(run, workdir, scene_file):
    """The PPDA dataset of the scene with segment labels, made with 1 and with 2 threads."""
    labels = os.path.join(workdir, "labels.csv")
    with open(labels, "w") as f:
        f.write("start_s,end_s,label\n0,10,3\n10,20,5\n")
    outs = {}
    for threads in ("1", "2"):
        out = os.path.join(workdir, "ppda" + threads)
        r = run("augment", "--scene", scene_file, "--policy", "paper", "--window", "50", "--stride", "25",
                "--count", "40", "--batch-size", "16", "--labels", labels, "--seed", "11",
                "--threads", threads, "-o", out)
        outs[threads] = out
        assert r.returncode == 0, f"PPDA dataset with {threads} thread(s)"
    return outs


def test_ppda_shapes_labels_and_description(ppda_dataset):
    outs = ppda_dataset
    X = np.load(os.path.join(outs["1"], "X.npy"))
    y = np.load(os.path.join(outs["1"], "y.npy"))
    sp = np.load(os.path.join(outs["1"], "sub_policy.npy"))
    meta = json.load(open(os.path.join(outs["1"], "dataset.json")))
    assert X.dtype == np.float32 and X.shape == (40, 50, 12), f"X is float32 (N, T, C) = {X.shape}"
    assert y.dtype == np.int64 and y.shape == (40,), "y is int64 (N)"
    assert np.all(np.isfinite(X)), "X is finite"
    # 20 s at 50 Hz = 1000 samples: windows start every 25 samples; 0..9 s are label 3, then 5.
    starts = np.arange(0, 1000 - 50 + 1, 25)
    base = np.where(starts + 25 <= 500, 3, 5)  # majority: the window's first half decides ties to 3
    expect = np.array([base[i % len(starts)] for i in range(40)])
    assert np.array_equal(y, expect), "labels are the majority of the segments in each window"
    # One sub-policy per batch of 16 (16, 16 and 8 windows), the batches dealt in a shuffled order
    # (until review, 2026-11-27, each batch was 16 consecutive windows).
    counts = sorted(np.unique(sp, return_counts=True)[1].tolist())
    assert np.all((sp >= 0) & (sp < 810)) and counts == [8, 16, 16], \
        f"one sub-policy index per batch of 16: {counts}"
    assert len(set(sp[:16])) > 1, "the first 16 windows are not one batch"
    assert meta["schema"] == "imukit.dataset/1" and meta["mode"] == "ppda" and meta["rate_hz"] == 50 \
        and meta["window"] == 50 and meta["stride"] == 25 and meta["sensors"] == ["watch", "belt"] \
        and meta["channels"][:6] == ["watch.ax", "watch.ay", "watch.az", "watch.gx", "watch.gy", "watch.gz"] \
        and meta["policy"]["builtin"] == "paper" and meta["seeds"]["seed"] == 11, \
        "dataset.json: schema, mode, rate, window, stride, sensors, channels, policy, seed"


def test_ppda_same_bytes_for_1_and_2_threads(ppda_dataset):
    outs = ppda_dataset
    same = all(open(os.path.join(outs["1"], f), "rb").read() == open(os.path.join(outs["2"], f), "rb").read()
               for f in ("X.npy", "y.npy", "sub_policy.npy"))
    assert same, "the same seed gives the same bytes with 1 and 2 threads"


@pytest.fixture(scope="module")
def simulated(run, workdir, scene_file):
    """`imukit simulate` of the scene (ideal sensors): the plain simulation, and a recording."""
    sim_out = os.path.join(workdir, "sim")
    r = run("simulate", scene_file, "-o", sim_out, "--method", "spline")
    return sim_out, r


def test_identity_batches_equal_simulate(run, workdir, scene_file, simulated):
    """Identity batches are the plain simulation: compare with `imukit simulate` (ideal sensors)."""
    ident = os.path.join(workdir, "ident")
    r = run("augment", "--scene", scene_file, "--identity-fraction", "1", "--window", "50", "--stride", "50",
            "-o", ident)
    sim_out, r2 = simulated
    assert r.returncode == 0 and r2.returncode == 0, "identity dataset and simulate ran"
    Xi = np.load(os.path.join(ident, "X.npy"))
    d = np.loadtxt(os.path.join(sim_out, "watch.csv"), delimiter=",", comments="#")
    w = 5  # window 5 starts at sample 250: away from the ends (windows there slide by 3 frames)
    acc, gyr = d[250:300, 4:7], d[250:300, 1:4]
    err = max(np.max(np.abs(Xi[w, :, 0:3] - acc)), np.max(np.abs(Xi[w, :, 3:6] - gyr)))
    assert np.all(np.load(os.path.join(ident, "sub_policy.npy")) == -1) and err < 1e-4, \
        f"identity batches equal `imukit simulate` (max diff {err:.2e}, float32)"


def test_stda_from_a_recording(run, workdir, simulated):
    """STDA from a recording: the simulated CSV as input, a JSON policy with one sub-policy."""
    sim_out, r_sim = simulated
    assert r_sim.returncode == 0, "simulate ran"
    pol = {"schema": "imukit.policy/1", "name": "jitter_only",
           "sub_policies": [{"hardware": {"accel_noise": 0.5, "gyro_noise": 0.05}}]}
    ppath = os.path.join(workdir, "policy.json")
    json.dump(pol, open(ppath, "w"))
    stda = os.path.join(workdir, "stda")
    r = run("augment", "--input", os.path.join(sim_out, "watch.csv"), "--policy", ppath, "--window", "50",
            "--stride", "50", "-o", stda)
    assert r.returncode == 0, "STDA dataset from a recording"
    d = np.loadtxt(os.path.join(sim_out, "watch.csv"), delimiter=",", comments="#")
    Xs = np.load(os.path.join(stda, "X.npy"))
    meta = json.load(open(os.path.join(stda, "dataset.json")))
    resid = Xs[5] - np.hstack([d[250:300, 4:7], d[250:300, 1:4]])
    assert Xs.shape == (20, 50, 6) and meta["mode"] == "stda" and abs(meta["rate_hz"] - 50) < 1e-9, \
        f"STDA dataset from a recording {Xs.shape}"
    assert 0.4 < resid[:, :3].std() < 0.6 and 0.04 < resid[:, 3:].std() < 0.06, \
        f"jitter sigma per sensor type ({resid[:, :3].std():.3f} m/s^2, {resid[:, 3:].std():.4f} rad/s)"


def test_errors_are_one_line(run, workdir, scene_file, simulated):
    """Errors: one line, non-zero exit."""
    tmp, spath = workdir, scene_file
    bad = os.path.join(tmp, "bad.json")
    with open(bad, "w") as f:
        f.write('{"schema": "imukit.policy/1",\n "sub_policies": [{"speed": {"method": "warping", "knots": 2, "ratio": 0.5}}]}')
    r = run("augment", "--scene", spath, "--policy", bad, "-o", os.path.join(tmp, "x"))
    assert r.returncode != 0 and "sub_policies[0].speed.ratio" in r.stderr \
        and len(r.stderr.strip().splitlines()) == 1, "a bad policy names the JSON path in one line"
    with open(bad, "w") as f:
        f.write('{"schema": "imukit.policy/1",\n  "builtin": paper}')
    r = run("augment", "--scene", spath, "--policy", bad, "-o", os.path.join(tmp, "x"))
    assert r.returncode != 0 and "bad.json:2:" in r.stderr, "a JSON syntax error names file:line"
    r = run("augment", "--scene", spath, "--window", "5000", "-o", os.path.join(tmp, "x"))
    assert r.returncode != 0 and "window" in r.stderr, "a window longer than the scene is refused"
    r = run("augment", "--policy", "paper", "-o", os.path.join(tmp, "x"))
    assert r.returncode != 0 and "--scene" in r.stderr, "no input is refused"
    # A recording whose times do not advance has no measured rate: the label file is not mapped
    # at a made-up rate, the same error as the dataset's (core/sampling.hpp measured_rate_hz).
    still = os.path.join(tmp, "still.csv")
    with open(os.path.join(simulated[0], "watch.csv")) as f:
        head = [f.readline(), f.readline()]
    with open(still, "w") as f:
        f.writelines([head[0], head[1], head[1]])
    seg = os.path.join(tmp, "segments.csv")
    with open(seg, "w") as f:
        f.write("start_s,end_s,label\n0,1,3\n")
    r = run("augment", "--input", still, "--labels", seg, "-o", os.path.join(tmp, "x"))
    assert r.returncode == 1 and "still.csv: the time stamps do not advance" in r.stderr, \
        "a recording whose times do not advance is refused before its labels are mapped"


def test_options_that_do_not_apply_and_windows_left_unaugmented_are_said(run, workdir, scene_file, simulated):
    """Found in review (2026-11-27): --method was ignored with --input, and windows whose drawn
    speed needed more motion than the scene has were written unaugmented with only a count in
    dataset.json to say so."""
    out = os.path.join(workdir, "m")
    r = run("augment", "--input", os.path.join(simulated[0], "watch.csv"), "--method", "fd", "-o", out)
    assert r.returncode == 2 and "--method chooses how a --scene is simulated again" in r.stderr, \
        f"--method with --input is refused: {r.stderr}"
    # 20 s of motion, windows of 10 s at 1.6-2.4x the speed: a window drawn faster than about 2x
    # needs more than the 20 s (windows slide inwards, so only the whole scene's length counts).
    pol = {"schema": "imukit.policy/1", "name": "fast",
           "sub_policies": [{"speed": {"method": "scaling", "range": [1.6, 2.4]}}]}
    ppath = os.path.join(workdir, "fast.json")
    json.dump(pol, open(ppath, "w"))
    fast = os.path.join(workdir, "fast")
    r = run("augment", "--scene", scene_file, "--policy", ppath, "--window", "500", "--stride", "50", "-o", fast)
    sp = np.load(os.path.join(fast, "sub_policy.npy"))
    meta = json.load(open(os.path.join(fast, "dataset.json")))
    short = int((sp == -1).sum())
    assert r.returncode == 0 and 0 < short < len(sp) and meta["too_short_windows"] == short, \
        f"some windows re-timed, some not ({short} of {len(sp)}): {r.stderr}"
    assert f"warning: augment: {short} of the {len(sp)} windows to augment" in r.stderr, \
        f"the windows written unaugmented are counted on stderr: {r.stderr}"
