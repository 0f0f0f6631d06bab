"""End-to-end tests of `imukit characterize` and `imukit calibrate` through the real binary:
a synthetic static recording of known noise density written by NumPy, and the imu_tk Xsens
multi-position recording (raw counts) from the shared data folder.

run: pytest (tests/pytest.ini), $IMUKIT_CLI the command under test
"""
import json
import os

import numpy as np
import pytest


@pytest.fixture(scope="module")
def characterized(run, workdir, quick):
    """2 h of white noise at 100 Hz (30 min in quick mode, where the same bounds hold; time stamps
    from NumPy): gyro density 3e-4 rad/s/sqrt(Hz), accel 2e-3 m/s^2/sqrt(Hz) on top of gravity on
    z; characterized into a profile and a Kalibr YAML file."""
    rate, n = 100.0, (180000 if quick else 720000)
    rng = np.random.default_rng(7)
    t = 1000.0 + np.arange(n) / rate
    gyr = rng.normal(0.0, 3e-4 * np.sqrt(rate), (n, 3)) + [1e-3, -2e-3, 5e-4]
    acc = rng.normal(0.0, 2e-3 * np.sqrt(rate), (n, 3)) + [0.0, 0.0, 9.80665]
    src = os.path.join(workdir, "static.txt")
    np.savetxt(src, np.column_stack([t, gyr, acc]), fmt="%.9f")
    profile = os.path.join(workdir, "profile.json")
    yaml = os.path.join(workdir, "imu.yaml")
    r = run("characterize", src, "--columns", "t,gx,gy,gz,ax,ay,az", "-o", profile, "--kalibr", yaml)
    assert r.returncode == 0, "characterize exits 0"
    return profile, yaml, rng


def test_noise_densities_and_turn_on_bias(characterized):
    p = json.load(open(characterized[0]))
    assert p["schema"] == "imukit.profile/1", "profile schema"
    nd = np.array(p["gyroscope"]["noise"]["noise_density"])
    assert np.all(np.abs(nd / 3e-4 - 1) < 0.02), f"gyro noise density {nd} within 2 % of 3e-4"
    na = np.array(p["accelerometer"]["noise"]["noise_density"])
    assert np.all(np.abs(na / 2e-3 - 1) < 0.02), f"accel noise density {na} within 2 % of 2e-3"
    bi = np.array(p["gyroscope"]["noise"]["bias_instability"])
    assert np.all(bi == 0.0), f"no bias instability detected in white noise ({bi})"
    tob = np.array(p["gyroscope"]["turn_on_bias"]["mean"])
    assert np.allclose(tob, [1e-3, -2e-3, 5e-4], atol=3e-5), f"gyro turn-on bias {tob}"


def test_kalibr_yaml(characterized):
    yaml = characterized[1]
    ky = dict(line.split("#")[0].split(":", 1) for line in open(yaml) if ":" in line and not line.startswith("#"))
    assert abs(float(ky["gyroscope_noise_density"]) / 3e-4 - 1) < 0.02, "Kalibr gyroscope_noise_density"
    assert abs(float(ky["update_rate"]) - 100.0) < 1e-6, "Kalibr update_rate from the time stamps"


def test_calibrate_xsens_raw_counts(run, workdir, characterized, data_file):
    xs = data_file("imu_tk_xsens")
    profile = characterized[0]
    r = run("calibrate", os.path.join(xs, "xsens_acc.txt"), "--columns", "t,ax,ay,az",
            os.path.join(xs, "xsens_gyro.txt"), "--columns", "t,gx,gy,gz", "--raw",
            "--gravity", "9.81744", "-o", profile)
    assert r.returncode == 0, "calibrate exits 0"
    p = json.load(open(profile))
    c = p["accelerometer"]["calibration"]
    assert c["raw_counts"] is True, "raw_counts recorded"
    assert all(400 < s < 430 for s in c["scale"]), f"accelerometer counts per m/s^2 {c['scale']}"
    assert c["residual"]["rms"] < 0.005, f"norm residual rms {c['residual']['rms']} m/s^2"
    assert "noise" in p["gyroscope"], "calibrate kept characterize's noise section"
    assert p["gravity"] == 9.81744, "gravity recorded"
    # characterize without --level uses no gravity, and leaves the calibration's (it wrote its
    # default over it until review, 2026-11-27).
    src = os.path.join(workdir, "static.txt")
    r = run("characterize", src, "--columns", "t,gx,gy,gz,ax,ay,az", "-o", profile)
    p = json.load(open(profile))
    assert r.returncode == 0 and p["gravity"] == 9.81744 and "calibration" in p["accelerometer"], r.stderr


def test_calibrate_refuses_data_in_another_unit_than_it_is_told(run, workdir, data_file):
    """Found in review, 2026-11-27: counts or g read as m/s^2, or SI data with --gravity 1, gave a
    calibration scaled by 10 or 400, exit 0. The scale of SI data must come out near 1."""
    xs = os.path.dirname(data_file("imu_tk_xsens", "xsens_acc.txt"))
    out = os.path.join(workdir, "unit.json")
    r = run("calibrate", os.path.join(xs, "xsens_acc.txt"), "--columns", "t,ax,ay,az", "--no-gyro", "-o", out)
    assert r.returncode == 1 and "the data are not in m/s^2 (counts need --raw" in r.stderr, r.stderr
    assert not os.path.exists(out), "nothing written"


def test_calibrate_refuses_poses_about_one_axis(run, workdir, characterized):
    """Poses about one axis only cannot calibrate: a clear one-line error, exit code != 0."""
    rng = characterized[2]
    bad = os.path.join(workdir, "flat.txt")
    tt = np.arange(9000) / 100.0
    np.savetxt(bad, np.column_stack([tt, np.zeros(9000), np.zeros(9000), 9.8 + rng.normal(0, 0.01, 9000)]), fmt="%.6f")
    r = run("calibrate", bad, "--columns", "t,ax,ay,az", "-o", os.path.join(workdir, "x.json"))
    assert r.returncode != 0 and "error" in r.stderr, f"flat recording rejected: {r.stderr.strip()}"


def test_output_problems_are_io_errors_and_found_before_the_work(run, workdir):
    # Found in review: an unwritable --kalibr path was an "internal error" (exit 4); an invalid
    # profile to update, or a folder that does not exist, was found after the whole fit; an
    # accelerometer-only input wrote a Kalibr file with a perfect (0) gyroscope.
    rng = np.random.default_rng(3)
    n = 20000
    src = os.path.join(workdir, "acc_only.txt")
    np.savetxt(src, np.column_stack([np.arange(n) / 100.0, rng.normal(0, 0.02, (n, 3)) + [0, 0, 9.8]]),
               fmt="%.6f")
    r = run("characterize", src, "--columns", "t,ax,ay,az", "-o", os.path.join(workdir, "no", "p.json"))
    assert r.returncode == 3 and "the folder of the profile to create or update does not exist" in r.stderr, \
        r.stderr
    bad = os.path.join(workdir, "bad_profile.json")
    with open(bad, "w") as f:
        f.write('{"schema": "imukit.profile/1", "accelerometer": 3}')
    r = run("characterize", src, "--columns", "t,ax,ay,az", "-o", bad)
    assert r.returncode == 1 and "bad_profile.json" in r.stderr and "wrote" not in r.stdout, r.stderr
    r = run("characterize", src, "--columns", "t,ax,ay,az", "-o", os.path.join(workdir, "acc.json"),
            "--kalibr", os.path.join(workdir, "acc.yaml"))
    assert r.returncode == 1 and "Kalibr's imu.yaml needs accelerometer and gyroscope noise" in r.stderr, \
        r.stderr
    assert not os.path.exists(os.path.join(workdir, "acc.yaml"))
    assert not os.path.exists(os.path.join(workdir, "acc.json")), "refused before the profile is written"
    six = os.path.join(workdir, "six.txt")
    np.savetxt(six, np.column_stack([np.arange(n) / 100.0, rng.normal(0, 0.01, (n, 3)),
                                     rng.normal(0, 0.02, (n, 3)) + [0, 0, 9.8]]), fmt="%.6f")
    r = run("characterize", six, "--columns", "t,gx,gy,gz,ax,ay,az", "-o", os.path.join(workdir, "six.json"),
            "--kalibr", os.path.join(workdir, "no", "k.yaml"))
    assert r.returncode == 3 and "no/k.yaml" in r.stderr and "internal" not in r.stderr, r.stderr
    assert not os.path.exists(os.path.join(workdir, "six.json")), "refused before the profile is written"


def test_characterize_says_what_its_records_cannot_give(run, workdir):
    # Found in review (2026-11-26): a gap was called jitter and biased N; a short record "detected"
    # B with N = 0; a record with motion gave a profile without a word; the noise came from the
    # record with the most samples, not the longest.
    rng = np.random.default_rng(3)

    def write(name, t, gyr, acc):
        path = os.path.join(workdir, name)
        np.savetxt(path, np.column_stack([t, gyr, acc]), fmt="%.9f")
        return path

    def white(n, rate, density):
        return rng.normal(0.0, density * np.sqrt(rate), (n, 3))

    # 40 min at 100 Hz of white noise with 10 min missing in the middle.
    t = np.arange(240000) / 100.0
    t[120000:] += 600.0
    gap = write("gap.txt", t, white(240000, 100.0, 1e-3), white(240000, 100.0, 1e-2) + [0, 0, 9.8])
    r = run("characterize", gap, "--columns", "t,gx,gy,gz,ax,ay,az", "-o", os.path.join(workdir, "g.json"))
    p = json.load(open(os.path.join(workdir, "g.json"))) if r.returncode == 0 else {}
    nd = np.array(p.get("gyroscope", {}).get("noise", {}).get("noise_density", [0, 0, 0]))
    assert r.returncode == 0 and "tau0 0.01 s" in r.stdout and "1 gap(s) in the time stamps" in r.stdout \
        and "jitter" not in r.stdout and np.all(np.abs(nd / 1e-3 - 1) < 0.02), \
        f"a gap: tau0 10 ms, a warning naming it, N within 2 % ({nd}; {r.stdout[:400]})"
    # 60 s at 1 Hz: too short for anything but N.
    short = write("short.txt", np.arange(60.0), white(60, 1.0, 1e-3), white(60, 1.0, 1e-2) + [0, 0, 9.8])
    r = run("characterize", short, "--columns", "t,gx,gy,gz,ax,ay,az", "-o", os.path.join(workdir, "s.json"))
    p = json.load(open(os.path.join(workdir, "s.json"))) if r.returncode == 0 else {}
    noise = p.get("gyroscope", {}).get("noise", {})
    assert r.returncode == 0 and r.stdout.count("only N fitted") == 6 \
        and np.all(np.array(noise.get("noise_density", [0, 0, 0])) > 0) \
        and np.all(np.array(noise.get("bias_instability", [1, 1, 1])) == 0), \
        f"60 s at 1 Hz: N alone on every axis, with the note ({r.stdout[:600]})"
    # A record with motion: a sinusoidal turn on every axis.
    tm = np.arange(60000) / 100.0
    moving = white(60000, 100.0, 1e-3) + np.sin(2 * np.pi * 0.05 * tm)[:, None]
    motion = write("motion.txt", tm, moving, white(60000, 100.0, 1e-2) + [0, 0, 9.8])
    m_json = os.path.join(workdir, "m.json")
    m_plots = os.path.join(workdir, "m_plots")
    r = run("characterize", motion, "--columns", "t,gx,gy,gz,ax,ay,az", "-o", m_json, "--plot", m_plots)
    assert os.path.exists(os.path.join(m_plots, "gyroscope_allan.dat")), \
        "the plots are written, the profile refused: they show why"
    assert r.returncode == 1 and r.stdout.count("the noise model does not describe this curve") >= 3 \
        and not os.path.exists(m_json) and "No profile written" in r.stderr \
        and all(f"gyroscope {a} (chi2/dof" in r.stderr for a in "xyz"), \
        f"motion: a warning per gyroscope axis, exit 1 and no profile (review, 2026-11-27: it " \
        f"was written) ({r.returncode}, {r.stdout[:600]}, {r.stderr})"
    r = run("characterize", motion, "--columns", "t,gx,gy,gz,ax,ay,az", "-o", m_json, "--keep-bad-fit")
    assert r.returncode == 0 and os.path.exists(m_json) and "no noise model (gyroscope x" in r.stderr, \
        f"motion, --keep-bad-fit: written, with a warning ({r.returncode}, {r.stderr})"
    # Two records: 2 h at 1 Hz (7200 samples) and 80 s at 100 Hz (8000): the noise from the 2 h.
    long = write("long.txt", np.arange(7200.0), white(7200, 1.0, 1e-3), white(7200, 1.0, 1e-2) + [0, 0, 9.8])
    brief = write("brief.txt", 5000 + np.arange(8000) / 100.0, white(8000, 100.0, 1e-3),
                  white(8000, 100.0, 1e-2) + [0, 0, 9.8])
    r = run("characterize", brief, "--columns", "t,gx,gy,gz,ax,ay,az", long, "--columns", "t,gx,gy,gz,ax,ay,az",
            "-o", os.path.join(workdir, "two.json"))
    assert r.returncode == 0 and r.stdout.startswith(f"noise from {long} "), \
        f"the noise from the longest record in time ({r.stdout.splitlines()[:1]})"


def test_characterize_takes_each_sensor_from_its_longest_record(run, workdir):
    # Review, 2026-11-27: an accelerometer and a gyroscope in separate files on different time
    # stamps are two records; the longest gave the noise of both, and the other sensor was
    # dropped without a word (no section, and 0 for it in Kalibr's imu.yaml).
    rng = np.random.default_rng(5)
    ta = np.arange(20000) / 100.0            # 200 s of accelerometer
    tg = 0.005 + np.arange(19000) / 100.0    # 190 s of gyroscope, 5 ms later
    acc = os.path.join(workdir, "acc_only.txt")
    gyr = os.path.join(workdir, "gyr_only.txt")
    np.savetxt(acc, np.column_stack([ta, rng.normal(0, 2e-3 * 10, (20000, 3)) + [0, 0, 9.80665]]), fmt="%.9f")
    np.savetxt(gyr, np.column_stack([tg, rng.normal(0, 3e-4 * 10, (19000, 3))]), fmt="%.9f")
    out = os.path.join(workdir, "split.json")
    yaml = os.path.join(workdir, "split.yaml")
    r = run("characterize", acc, "--columns", "t,ax,ay,az", gyr, "--columns", "t,gx,gy,gz", "-o", out,
            "--kalibr", yaml)
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith(f"noise from {acc} (accelerometer) and {gyr} (gyroscope)"), r.stdout[:200]
    p = json.load(open(out))
    nd = np.array(p["gyroscope"]["noise"]["noise_density"])
    na = np.array(p["accelerometer"]["noise"]["noise_density"])
    assert np.all(np.abs(nd / 3e-4 - 1) < 0.05) and np.all(np.abs(na / 2e-3 - 1) < 0.05), (nd, na)
    assert "gyroscope_noise_density: 0 " not in open(yaml).read()


def test_level_and_raw_refuse_what_they_cannot_read(run, workdir):
    # Review, 2026-11-27: --level on a device lying upside down wrote a turn-on bias of -2 g;
    # --raw on an MCAP recording or EuRoC CSV took SI values for counts (raw_counts: true).
    rng = np.random.default_rng(11)
    t = np.arange(6000) / 100.0
    src = os.path.join(workdir, "upside_down.txt")
    np.savetxt(src, np.column_stack([t, rng.normal(0, 0.01, (6000, 3)),
                                     rng.normal(0, 0.02, (6000, 3)) + [0, 0, -9.80665]]), fmt="%.9f")
    out = os.path.join(workdir, "level.json")
    r = run("characterize", src, "--columns", "t,gx,gy,gz,ax,ay,az", "-o", out, "--level")
    assert r.returncode == 1 and "did not lie level, z up" in r.stderr and not os.path.exists(out), r.stderr
    r = run("calibrate", os.path.join(workdir, "recording.mcap"), "--raw", "-o", os.path.join(workdir, "c.json"))
    assert r.returncode == 2 and "--raw reads ADC counts from text files mapped with --columns" in r.stderr, \
        r.stderr
