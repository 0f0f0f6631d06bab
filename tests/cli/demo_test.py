"""`imukit demo` end to end: runs it into a temporary folder, checks every output exists and
parses (profile and report JSON, MCAP recordings through `imukit info`, the simulated EuRoC CSVs
and the PPDA / STDA datasets with numpy, the SVG plots), and that what characterize and calibrate
estimated matches the mock's truth (truth_profile.json, written before the mock is made):

  white-noise densities       within 5 %
  turn-on bias means          within 3 standard errors (spread / sqrt(power cycles))
  calibrated scale factors    within 0.2 %
  misalignment angles         within 0.05 degrees

In quick mode (the sanitizer pass, $IMUKIT_TEST_QUICK) the demo runs with --quick and shortens
every step (10 min still recording, 5 power cycles, poses held 3 s instead of 5); the same
tolerances hold there, just with less margin (see the printed errors).

run: pytest (tests/pytest.ini), $IMUKIT_CLI the command under test
"""
import json
import math
import os
import shutil
import subprocess
from types import SimpleNamespace

import numpy as np
import pytest
from conftest import running_in_ci

SENSORS = ["accelerometer", "gyroscope"]


@pytest.fixture(scope="module")
def demo(imukit, workdir, quick):
    """One `imukit demo` (with --quick in quick mode) and the profiles it wrote."""
    out = os.path.join(workdir, "demo")
    args = [imukit, "demo", "-o", out] + (["--quick"] if quick else [])
    r = subprocess.run(args, capture_output=True, text=True)
    print(r.stdout)
    assert r.returncode == 0, f"imukit demo exits 0 ({r.stderr.strip()[-400:]})"
    return SimpleNamespace(out=out, stdout=r.stdout, quick=quick,
                           report=json.load(open(os.path.join(out, "report.json"))),
                           truth=json.load(open(os.path.join(out, "truth_profile.json"))),
                           est=json.load(open(os.path.join(out, "profile.json"))))


def test_report_lists_the_steps_and_their_outputs(demo):
    report, out = demo.report, demo.out
    assert report["schema"] == "imukit.demo/1" and report["quick"] == demo.quick, \
        "report.json parses, schema imukit.demo/1"
    names = [s["name"] for s in report["steps"]]
    assert names == ["static capture", "multi-position capture", "calibrate + characterize", "simulate", "augment"], \
        f"five steps reported in order ({names})"
    assert all(s["seconds"] >= 0 for s in report["steps"]) and report["total_seconds"] > 0, "with their times"
    for s in report["steps"]:
        for o in s["outputs"]:
            if "*" in o:
                continue
            assert os.path.isfile(os.path.join(out, o)) and os.path.getsize(os.path.join(out, o)) > 0, \
                f"{s['name']}: {o} written"
    assert demo.truth["schema"] == demo.est["schema"] == "imukit.profile/1", "truth and estimated profiles parse"


def test_recordings_read_back(imukit, demo):
    """Recordings read back through imukit info."""
    report = demo.report
    runs = report["static_runs"]
    for rec in [runs[0]["file"], runs[-1]["file"], report["poses_run"]["file"]]:
        i = subprocess.run([imukit, "info", os.path.join(demo.out, rec)], capture_output=True, text=True)
        assert i.returncode == 0 and "samples" in i.stdout, f"imukit info reads {rec}"
    rate = report["simulation"]["rate_hz"]
    long_s = runs[0]["samples"] / rate
    assert abs(long_s - (600 if demo.quick else 7200)) < 1, f"the long still recording holds {long_s:.1f} s"
    assert report["poses_run"]["distinct_poses"] == 26, \
        f"the guided capture held {report['poses_run']['distinct_poses']} distinct poses"


@pytest.mark.parametrize("sensor", SENSORS)
def test_estimates_match_the_truth(demo, sensor):
    t, e = demo.truth[sensor], demo.est[sensor]
    runs = demo.report["static_runs"]
    # White noise densities.
    for ax in range(3):
        n_t, n_e = t["noise"]["noise_density"][ax], e["noise"]["noise_density"][ax]
        assert abs(n_e / n_t - 1) < 0.05, \
            f"{sensor} N[{ax}] {n_e:.5g} vs {n_t:.5g} ({100 * (n_e / n_t - 1):+.2f} %, < 5 %)"
    # Turn-on bias mean over the power cycles, against the mean the mock draws from.
    tob = e["turn_on_bias"]
    n = tob["runs"]
    assert n == len(runs), f"{sensor} turn-on bias from {n} power cycles"
    for ax in range(3):
        se = tob["spread"][ax] / math.sqrt(n)
        d = tob["mean"][ax] - t["turn_on_bias"]["mean"][ax]
        assert se > 0 and abs(d) < 3 * se, \
            f"{sensor} turn-on bias[{ax}] off by {d:+.3g} = {d / se:+.2f} standard errors (< 3)"
    # Each power cycle's mean against the bias that cycle's mock drew: a far tighter check than
    # the above (a still gyroscope's mean is its bias plus about 1e-4 rad/s of bias instability
    # and random walk), so a turn-on bias estimate that ignored the data would fail here.
    # The accelerometer's is its mean minus the reading the calibration predicts for a level
    # sensor (diag(scale) misalignment g): without that correction the z axis would be off by
    # (scale_z - 1) g = 0.02 m/s^2, twice the bound.
    key, bound, unit = ("gyroscope", 5e-4, "rad/s") if sensor == "gyroscope" else ("accelerometer", 0.01, "m/s^2")
    worst = max(abs(a - b) for rr in runs for a, b in zip(rr[f"measured_{key}_bias"], rr[f"true_{key}_bias"]))
    assert worst < bound, f"every power cycle's {sensor} bias within {worst:.2g} {unit} of its draw (< {bound:g})"
    # Calibration: forward scale and misalignment.
    for ax in range(3):
        s_t, s_e = t["calibration"]["scale"][ax], e["calibration"]["scale"][ax]
        assert abs(s_e / s_t - 1) < 0.002, \
            f"{sensor} scale[{ax}] {s_e:.6f} vs {s_t:.6f} ({100 * (s_e / s_t - 1):+.4f} %, < 0.2 %)"
    worst = 0.0
    for i in range(3):
        for j in range(3):
            if i != j:
                d = math.degrees(abs(e["calibration"]["misalignment"][i][j] - t["calibration"]["misalignment"][i][j]))
                worst = max(worst, d)
    assert worst < 0.05, f"{sensor} misalignment angles within {worst:.4f} deg (< 0.05)"


@pytest.fixture(scope="module")
def simulated_watch(demo):
    """The simulated watch: EuRoC CSV, measured and noiseless."""
    sim = os.path.join(demo.out, "simulate")
    m = np.loadtxt(os.path.join(sim, "left_wrist_watch.csv"), delimiter=",", comments="#")
    tr = np.loadtxt(os.path.join(sim, "left_wrist_watch.truth.csv"), delimiter=",", comments="#")
    return m, tr


def test_simulated_watch_parses_at_the_device_rate(demo, simulated_watch):
    m, tr = simulated_watch
    rate = demo.report["simulation"]["rate_hz"]
    assert m.shape == tr.shape and m.shape[1] == 7 and m.shape[0] == demo.report["simulation"]["samples"], \
        f"simulated CSVs parse with numpy ({m.shape})"
    assert np.all(np.diff(m[:, 0]) > 0) and abs(np.median(np.diff(m[:, 0])) - 1e9 / rate) < 1, "at the device rate"


def test_noiseless_watch_equals_simulate(imukit, workdir, demo, simulated_watch):
    """The noiseless watch is what `imukit simulate` makes of the same motion, preset, rate and
    method (the demo calls the same sim::run_scene)."""
    tr = simulated_watch[1]
    rate = demo.report["simulation"]["rate_hz"]
    simdir = os.path.join(workdir, "simulate_cli")
    r = subprocess.run([imukit, "simulate", "--bvh", demo.report["simulation"]["motion"], "--preset",
                        "left_wrist_watch", "--method", "spline", "--rate", str(rate), "--ground-truth", "-o", simdir],
                       capture_output=True, text=True)
    cli = np.loadtxt(os.path.join(simdir, "left_wrist_watch.truth.csv"), delimiter=",", comments="#") \
        if r.returncode == 0 else np.zeros((0, 7))
    assert cli.shape == tr.shape and np.array_equal(cli[:, 0], tr[:, 0]) \
        and np.allclose(cli[:, 1:], tr[:, 1:], rtol=1e-12, atol=1e-12), \
        f"the noiseless signal equals `imukit simulate --ground-truth` on the same walk ({r.stderr.strip()})"


@pytest.mark.parametrize("sensor, cols", [("gyroscope", slice(1, 4)), ("accelerometer", slice(4, 7))])
def test_measured_watch_is_the_model_of_the_truth(demo, simulated_watch, sensor, cols):
    """The measured signal is the truth through the measured hardware model: y = M x + b + n with
    M = diag(scale) misalignment (profile.json's calibration), b the run's turn-on bias, n white
    noise of the estimated density (399 samples: the sample sd within 15 %)."""
    m, tr = simulated_watch
    rate = demo.report["simulation"]["rate_hz"]
    c = demo.est[sensor]["calibration"]
    M = np.diag(c["scale"]) @ np.array(c["misalignment"])
    resid = m[:, cols] - tr[:, cols] @ M.T
    sd = (resid - resid.mean(axis=0)).std(axis=0)
    expected = np.array(demo.est[sensor]["noise"]["noise_density"]) * math.sqrt(rate)
    assert np.all(np.abs(sd / expected - 1) < 0.15), \
        f"simulated {sensor} noise {np.round(sd, 5)} matches the measured density's {np.round(expected, 5)} (15 %)"


@pytest.mark.parametrize("mode", ["ppda", "stda"])
def test_dataset(demo, mode):
    d = os.path.join(demo.out, mode)
    X, y = np.load(os.path.join(d, "X.npy")), np.load(os.path.join(d, "y.npy"))
    info = json.load(open(os.path.join(d, "dataset.json")))
    assert X.dtype == np.float32 and y.dtype == np.int64 and X.ndim == 3 and X.shape[0] == y.shape[0] > 0, \
        f"{mode}: X.npy {X.shape} float32, y.npy {y.shape} int64"
    assert info["schema"] == "imukit.dataset/1" and X.shape[1] == info["window"] and X.shape[2] == 6, \
        f"{mode}: dataset.json describes it (window {info.get('window')}, 6 channels ax..gz)"
    assert np.all(np.isfinite(X)) and np.all(y == 0), f"{mode}: finite windows, every label 0 (walking)"
    acc = np.linalg.norm(X[:, :, 0:3], axis=2).mean()
    # Walking gives 0.5 to 2 g at the wrist; PPDA's faster variants (speed x2: accelerations
    # x4) and added biases widen that, hence the loose bound: a sanity check, not a test of
    # the augmentations (tests/augment does that).
    assert 4.9 < acc < 49, f"{mode}: accelerometer magnitude averages {acc:.2f} m/s^2 (0.5 to 5 g)"


def test_ppda_and_stda_differ(demo):
    Xp, Xs = np.load(os.path.join(demo.out, "ppda", "X.npy")), np.load(os.path.join(demo.out, "stda", "X.npy"))
    assert Xp.shape == Xs.shape and not np.array_equal(Xp, Xs), "PPDA and STDA are different data of the same shape"


@pytest.mark.parametrize("sensor", SENSORS)
def test_report_holds_the_printed_comparison(demo, sensor):
    """report.json holds the printed comparison: every row's truth, estimate and standard error, and
    they are the profiles' numbers (issue 16: it held only the poses run's bias)."""
    truth, est = demo.truth, demo.est
    rows = {row["quantity"]: row for row in demo.report["comparison"][sensor]["rows"]}
    unit = "m/s^2" if sensor == "accelerometer" else "rad/s"
    for ax, a in enumerate("xyz"):
        row = rows.get(f"white noise N {a} [{unit}/sqrt(Hz)]")
        ok = row is not None and row["true"] == truth[sensor]["noise"]["noise_density"][ax] \
            and row["estimated"] == est[sensor]["noise"]["noise_density"][ax] \
            and row["standard_error"] == est[sensor]["noise"]["noise_density_sigma"][ax] \
            and abs(row["error"] - (row["estimated"] - row["true"])) <= 1e-15 * abs(row["true"]) \
            and row["summary"] in demo.stdout
        assert ok, f"report.json: {sensor} white noise {a}: true, estimated, standard error as printed"
        row = rows.get(f"scale {a} (forward model)")
        assert row is not None and row["estimated"] == est[sensor]["calibration"]["scale"][ax] \
            and row["standard_error"] is None, f"report.json: {sensor} scale {a} as in profile.json"
    assert len(rows) == 21, f"report.json: {sensor}: all 21 printed rows ({len(rows)})"


def test_plots(demo):
    """Plots (SVG from gnuplot, when installed)."""
    if shutil.which("gnuplot") is None:
        if running_in_ci():  # setup.sh installs it: a skip there would hide the plots' checks
            pytest.fail("gnuplot not installed under CI (scripts/setup.sh installs gnuplot-nox)")
        pytest.skip("gnuplot not installed, plots not drawn")
    out, est = demo.out, demo.est
    for p in ["plots/accelerometer_allan.svg", "plots/gyroscope_allan.svg", "plots/calibration_residuals.svg",
              "simulate/left_wrist_watch.svg"]:
        path = os.path.join(out, p)
        ok = os.path.isfile(path) and "<svg" in open(path).read(4096)
        assert ok, f"{p} is an SVG"
    # The scripts run from anywhere (they move to their own folder) and redraw the same plot.
    svg = os.path.join(out, "plots", "gyroscope_allan.svg")
    os.remove(svg)
    g = subprocess.run(["gnuplot", os.path.join(out, "plots", "gyroscope_allan.gp")], cwd="/",
                       capture_output=True, text=True)
    assert g.returncode == 0 and os.path.isfile(svg), f"plots/gyroscope_allan.gp runs from / ({g.stderr.strip()})"
    # Allan plots: reference lines for every axis with a fitted term, none for a term not fitted,
    # powers of ten on the axes.
    gp = open(os.path.join(out, "plots", "gyroscope_allan.gp")).read()
    fitted_k = [est["gyroscope"]["noise"]["random_walk"][ax] > 0 for ax in range(3)]
    assert all(f"{a}: N/sqrt(tau)" in gp for a in "xyz") and "10^{%L}" in gp \
        and all((f"{a}: K sqrt(tau/3)" in gp) == fitted_k[ax] for ax, a in enumerate("xyz")), \
        "the gyroscope Allan plot draws N for x, y and z, K only where fitted, powers of ten"
