"""End-to-end tests of `imukit convert` and `imukit info` through the real binary, with NumPy
(Debian's python3-numpy) as an independent reader of the .npy files imukit writes.

run: pytest (tests/pytest.ini), $IMUKIT_CLI the command under test
"""
import json
import os
import resource
import signal
from types import SimpleNamespace

import numpy as np
import pytest


@pytest.fixture(scope="module")
def converted(run, workdir):
    """A 200 Hz stream in g and deg/s with blank separators and a header row, converted to .npy and
    to a EuRoC CSV."""
    tmp = workdir
    src = os.path.join(tmp, "log.txt")
    rng = np.random.default_rng(3)
    acc_g = rng.normal(0, 0.01, (500, 3)) + [0, 0, 1]
    gyr_dps = rng.normal(0, 0.5, (500, 3))
    with open(src, "w") as f:
        f.write("time ax ay az gx gy gz\n")
        for i in range(500):
            f.write(f"{1700000000 + i // 200}.{(i % 200) * 5:03d} "
                    + " ".join(repr(v) for v in acc_g[i]) + " "
                    + " ".join(repr(v) for v in gyr_dps[i]) + "\n")
    out_npy = os.path.join(tmp, "imu.npy")
    r_npy = run("convert", src, "--columns", "t,ax,ay,az,gx,gy,gz", "--accel-unit", "g",
                "--gyro-unit", "deg/s", "-o", out_npy)
    out_csv = os.path.join(tmp, "imu0.csv")
    r_csv = run("convert", src, "--columns", "t,ax,ay,az,gx,gy,gz", "-o", out_csv)
    return SimpleNamespace(tmp=tmp, acc_g=acc_g, gyr_dps=gyr_dps, out_npy=out_npy, r_npy=r_npy, out_csv=out_csv,
                           r_csv=r_csv)


def test_npy_holds_si_units_and_exact_times(converted):
    c = converted
    r = c.r_npy
    assert r.returncode == 0, f"convert to .npy exits 0 ({r.stderr.strip()})"
    x = np.load(c.out_npy)
    ts = np.load(os.path.join(c.tmp, "imu_t.npy"))
    assert x.dtype == np.float64 and x.shape == (500, 6), f"X is float64 (500, 6): {x.dtype} {x.shape}"
    assert ts.dtype == np.int64 and ts.shape == (500,), "t is int64 (500,)"
    assert ts[0] == 1700000000 * 10**9 and ts[499] == 1700000000 * 10**9 + 499 * 5000000, \
        "time stamps exact to the nanosecond"
    assert np.array_equal(x[:, 0:3], c.acc_g * 9.80665), "accelerometer converted from g exactly"
    assert np.array_equal(x[:, 3:6], c.gyr_dps * (np.pi / 180.0)), "gyroscope converted from deg/s exactly"


def test_euroc_csv_round_trips_values(converted):
    c = converted
    assert c.r_csv.returncode == 0, "convert to EuRoC CSV exits 0"
    rows = np.loadtxt(c.out_csv, delimiter=",", skiprows=1)
    assert rows.shape == (500, 7), "EuRoC CSV has 500 rows of 7 columns"
    assert np.array_equal(rows[:, 4:7], c.acc_g) and np.array_equal(rows[:, 1:4], c.gyr_dps), \
        "EuRoC CSV holds gyro then accel, values round-trip exactly"


def test_info_reports_the_rate(run, converted):
    r = run("info", converted.out_csv)
    assert r.returncode == 0 and "200.0000 Hz" in r.stdout and "uniformly sampled" in r.stdout, \
        "info reports the measured 200 Hz rate"


def test_bad_input_messages(run, converted):
    tmp = converted.tmp
    bad = os.path.join(tmp, "bad.txt")
    with open(bad, "w") as f:
        f.write("0 1 2 3\n0.005 1 x 3\n")
    r = run("info", bad, "--columns", "t,ax,ay,az")
    assert r.returncode == 1, f"bad input exits 1 (got {r.returncode})"
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and f"{bad}:2:9: column 3 (ay): 'x' is not a number" in lines[0], \
        f"bad input gives one line naming file:line:column ({r.stderr.strip()})"
    r = run("info", bad)
    assert r.returncode == 2 and "--columns" in r.stderr, \
        "a file without a column map says how to give one (usage, exit 2)"
    r = run("convert", converted.out_csv, "-o", os.path.join(tmp, "x.bin"))
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1 and "OUT.mcap" in r.stderr, \
        "unknown output format is a one-line usage error (exit 2)"


def test_found_in_review_2026_11_26(run, converted):
    tmp = converted.tmp
    # A failed convert leaves the file it was to replace (it truncated it).
    keep = os.path.join(tmp, "keep.csv")
    with open(keep, "w") as f:
        f.write("keep me\n")
    acc = os.path.join(tmp, "acc_only.txt")
    with open(acc, "w") as f:
        f.write("0 0 0 9.8\n0.01 0 0 9.8\n")
    r = run("convert", acc, "--columns", "t,ax,ay,az", "-o", keep)
    assert r.returncode == 1 and open(keep).read() == "keep me\n", r.stderr
    assert sorted(os.listdir(tmp)).count("keep.csv") == 1 and not [n for n in os.listdir(tmp) if n.endswith(".tmp")]
    # Channels the output cannot hold are named (they were dropped silently).
    mag = os.path.join(tmp, "mag.txt")
    with open(mag, "w") as f:
        f.write("0 0 0 9.8 0 0 0 20 0 40 25\n0.01 0 0 9.8 0 0 0 20 0 40 25\n")
    r = run("convert", mag, "--columns", "t,ax,ay,az,gx,gy,gz,mx,my,mz,temp", "-o", os.path.join(tmp, "mag.csv"))
    assert r.returncode == 0 and "mag's magnetometer and temperature not written" in r.stderr, r.stderr
    r = run("convert", mag, "--columns", "t,ax,ay,az,gx,gy,gz,mx,my,mz,temp", "-o", os.path.join(tmp, "mag.mcap"))
    assert r.returncode == 0 and "mag's temperature not written (MCAP holds" in r.stderr, r.stderr
    pose = os.path.join(tmp, "pose.txt")
    with open(pose, "w") as f:
        f.write("0 1 0 0 0 0 0 0 0 0 9.8 0 0 0\n0.01 1 0 0 0 0 0 0 0 0 9.8 0 0 0\n")
    r = run("convert", pose, "--columns", "t,qw,qx,qy,qz,px,py,pz,ax,ay,az,gx,gy,gz", "-o",
            os.path.join(tmp, "pose.mcap"))
    assert r.returncode == 0 and "the pose columns qw,qx,qy,qz,px,py,pz are not written" in r.stderr, r.stderr
    # Unit options without --columns are refused, not ignored.
    r = run("convert", converted.out_csv, "--accel-unit", "g", "-o", os.path.join(tmp, "g.csv"))
    assert r.returncode == 2 and "--accel-unit describe(s) column-mapped text" in r.stderr, r.stderr
    # info leaves gaps out of its figures, and a value its unit makes infinite is an error.
    gappy = os.path.join(tmp, "gappy.txt")
    with open(gappy, "w") as f:
        f.write("0 nan 0 9.8\n0.01 0.1 0 9.8\n0.02 0.3 0 9.7\n")
    r = run("info", gappy, "--columns", "t,ax,ay,az", "--gaps", "ax")
    assert r.returncode == 0 and "nan" not in r.stdout and "1 of 3 samples are gaps" in r.stdout, r.stdout
    assert "mean          0.2" in r.stdout, r.stdout
    big = os.path.join(tmp, "big.txt")
    with open(big, "w") as f:
        f.write("0 1e308 0 1\n0.01 1 0 1\n")
    r = run("info", big, "--columns", "t,ax,ay,az", "--accel-unit", "g")
    assert r.returncode == 1 and "big.txt:1: ax = 1e+308 times 9.80665" in r.stderr, r.stderr


@pytest.fixture(scope="module")
def mcap_file(run, converted):
    out_mcap = os.path.join(converted.tmp, "imu0.mcap")
    r = run("convert", converted.out_csv, "-o", out_mcap)
    return out_mcap, r


def test_mcap_round_trip_is_byte_identical(run, converted, mcap_file):
    """CSV -> MCAP -> CSV keeps every value bit for bit."""
    out_mcap, r = mcap_file
    assert r.returncode == 0, f"convert to MCAP exits 0 ({r.stderr.strip()})"
    back_dir = os.path.join(converted.tmp, "back")
    r = run("convert", out_mcap, "-o", back_dir)
    assert r.returncode == 0, "convert MCAP to a folder exits 0"
    with open(converted.out_csv) as a, open(os.path.join(back_dir, "imu0.csv")) as b:
        assert a.read() == b.read(), "CSV -> MCAP -> CSV is byte-identical"


def test_mcap_to_mcap_names_what_it_leaves_and_never_overwrites_its_input(run, converted, mcap_file):
    # Review, 2026-11-27: `convert rec.mcap -o rec.mcap` rewrote the only copy in place, and an
    # MCAP converted to MCAP lost its /raw and /time_sync topics without a word.
    out_mcap, _ = mcap_file
    before = open(out_mcap, "rb").read()
    r = run("convert", out_mcap, "-o", out_mcap)
    assert r.returncode == 2 and "is the input; write to a new name" in r.stderr, r.stderr
    assert open(out_mcap, "rb").read() == before
    copy = os.path.join(converted.tmp, "copy.mcap")
    r = run("convert", out_mcap, "-o", copy)
    assert r.returncode == 0 and "warning" not in r.stderr, r.stderr  # nothing but the stream to leave
    rec = os.path.join(converted.tmp, "rec.mcap")
    assert run("record", "mock:static?clock=virtual", "--duration", "1", "-o", rec).returncode == 0
    r = run("convert", rec, "-o", copy)
    assert r.returncode == 0 and "its other topics are not written: /imu/mock_static/raw, " \
        "/imu/mock_static/time_sync" in r.stderr, r.stderr
    # A simulation's true orientation rides in the kept /imu/<name> messages: it was dropped
    # without a word (found in review, 2026-11-27).
    scene = os.path.join(converted.tmp, "orientation.json")
    with open(scene, "w") as f:
        json.dump({"schema": "imukit.scene/1",
                   "motion": {"procedural": {"rate_hz": 100, "duration_s": 1, "seed": 3}},
                   "simulation": {"seed": 7, "rate_hz": 100},
                   "sensors": [{"name": "w", "preset": "left_wrist_watch",
                                "outputs": ["accelerometer", "gyroscope", "orientation"]}]}, f)
    sim = os.path.join(converted.tmp, "orientation.mcap")
    assert run("simulate", scene, "-o", sim).returncode == 0
    r = run("convert", sim, "-o", copy)
    assert r.returncode == 0 and "its other topics are not written: the orientation of /imu/w" in r.stderr, r.stderr
    r = run("convert", sim, "-o", os.path.join(converted.tmp, "orientation.csv"))
    assert r.returncode == 0 and "the orientation of /imu/w is not written (.csv holds" in r.stderr, r.stderr


def test_cut_recording_reads_with_a_note_and_recovers(run, converted, mcap_file):
    """A recording cut short: read to its last complete chunk with a note, then recovered."""
    tmp = converted.tmp
    with open(mcap_file[0], "rb") as f:
        data = f.read()
    cut = os.path.join(tmp, "cut.mcap")
    with open(cut, "wb") as f:
        f.write(data[: len(data) // 2])
    r = run("info", cut)
    assert r.returncode == 0 and "the file ends at byte" in r.stderr and "--recover" in r.stderr, \
        "a cut MCAP file is read with a note, not an error"
    fixed = os.path.join(tmp, "fixed.mcap")
    r = run("convert", "--recover", cut, "-o", fixed)
    assert r.returncode == 0, "convert --recover exits 0"
    # Nothing to recover (cut inside the first record) is an error, not exit 0 beside an empty
    # file (review, 2026-11-27).
    head = os.path.join(tmp, "head.mcap")
    with open(head, "wb") as f:
        f.write(data[:200])
    r2 = run("convert", "--recover", head, "-o", os.path.join(tmp, "nothing.mcap"))
    assert r2.returncode == 1 and "could be read; nothing written" in r2.stderr \
        and not os.path.exists(os.path.join(tmp, "nothing.mcap")), r2.stderr
    r = run("info", fixed)
    assert r.returncode == 0 and "the file ends" not in r.stderr, "the recovered file is complete"


def limited_file_size(limit_bytes):
    """A preexec_fn: files may grow to limit_bytes (writes past it fail with EFBIG, as on a full
    disk; SIGXFSZ ignored, so the failure is a write error and not a killed process)."""
    def apply():
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit_bytes, limit_bytes))
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    return apply


@pytest.mark.parametrize("recover", [False, True], ids=["convert", "convert_recover"])
def test_a_failed_mcap_write_leaves_the_earlier_file(run, workdir, recover):
    """`convert` to .mcap (and `convert --recover`) that runs out of space mid-file: exit 3 naming
    the output, the file that was there before unchanged, no temporary left behind."""
    folder = os.path.join(workdir, "atomic_" + ("recover" if recover else "convert"))
    os.makedirs(folder)
    src = os.path.join(folder, "src.mcap")
    out = os.path.join(folder, "out.mcap")
    assert run("record", "mock:static?rate=1000&clock=virtual", "--duration", "20", "-o", src).returncode == 0
    assert run("record", "mock:static?rate=100&clock=virtual", "--duration", "1", "-o", out).returncode == 0
    earlier = open(out, "rb").read()
    assert os.path.getsize(src) > 200_000 and len(earlier) < 50_000
    args = ["convert", "--recover", src, "-o", out] if recover else ["convert", src, "-o", out]
    r = run(*args, preexec_fn=limited_file_size(100_000))
    assert r.returncode == 3, f"a failed write exits 3 ({r.returncode}: {r.stderr.strip()})"
    assert "out.mcap" in r.stderr and "File too large" in r.stderr, r.stderr
    assert open(out, "rb").read() == earlier, "the earlier file is unchanged"
    assert sorted(os.listdir(folder)) == ["out.mcap", "src.mcap"], "and no temporary is left"


def test_a_failed_simulation_to_mcap_leaves_the_earlier_file(run, workdir):
    """Found in review: `simulate -o FILE.mcap` wrote in place, so a run that failed mid-file left
    a truncated file under the final name. Now it goes through a temporary like every finished
    MCAP file: exit 3, the file that was there before unchanged, no temporary left."""
    folder = os.path.join(workdir, "atomic_simulate")
    os.makedirs(folder)
    scene = os.path.join(folder, "scene.json")
    with open(scene, "w") as f:
        json.dump({"schema": "imukit.scene/1",
                   "motion": {"procedural": {"rate_hz": 100, "duration_s": 60, "seed": 1}},
                   "simulation": {"rate_hz": 400}, "sensors": [{"preset": "left_wrist_watch"}]}, f)
    out = os.path.join(folder, "out.mcap")
    assert run("record", "mock:static?rate=100&clock=virtual", "--duration", "1", "-o", out).returncode == 0
    earlier = open(out, "rb").read()
    r = run("simulate", scene, "-o", out, preexec_fn=limited_file_size(100_000))
    assert r.returncode == 3 and "File too large" in r.stderr, (r.returncode, r.stderr)
    assert open(out, "rb").read() == earlier, "the earlier file is unchanged"
    assert sorted(os.listdir(folder)) == ["out.mcap", "scene.json"], "and no temporary is left"


def test_a_failed_simulation_to_csv_leaves_the_earlier_files(run, workdir):
    """Found in review (2026-11-27): `simulate -o DIR` wrote its CSVs in place, so a run that
    failed mid-way left truncated files beside an earlier simulation.json. Now each CSV goes
    through a temporary renamed over its name when the whole run is done, simulation.json last:
    exit 3, the earlier files unchanged, no temporary left."""
    folder = os.path.join(workdir, "atomic_simulate_csv")
    scene = os.path.join(workdir, "csv_scene.json")
    with open(scene, "w") as f:
        json.dump({"schema": "imukit.scene/1",
                   "motion": {"procedural": {"rate_hz": 100, "duration_s": 60, "seed": 1}},
                   "simulation": {"rate_hz": 400},
                   "sensors": [{"preset": "left_wrist_watch"}, {"preset": "right_wrist_watch"}]}, f)
    small = os.path.join(workdir, "csv_scene_small.json")
    with open(small, "w") as f:
        json.dump({"schema": "imukit.scene/1",
                   "motion": {"procedural": {"rate_hz": 100, "duration_s": 1, "seed": 1}},
                   "sensors": [{"preset": "left_wrist_watch"}, {"preset": "right_wrist_watch"}]}, f)
    assert run("simulate", small, "-o", folder).returncode == 0
    names = sorted(os.listdir(folder))
    assert names == ["left_wrist_watch.csv", "right_wrist_watch.csv", "simulation.json"], names
    earlier = {n: open(os.path.join(folder, n), "rb").read() for n in names}
    r = run("simulate", scene, "-o", folder, preexec_fn=limited_file_size(200_000))
    assert r.returncode == 3 and "File too large" in r.stderr, (r.returncode, r.stderr)
    assert sorted(os.listdir(folder)) == names, "no temporary is left"
    for n in names:
        assert open(os.path.join(folder, n), "rb").read() == earlier[n], f"{n} is unchanged"
    assert run("simulate", scene, "-o", folder).returncode == 0  # and a run that ends replaces them
    assert open(os.path.join(folder, "simulation.json"), "rb").read() != earlier["simulation.json"]


def test_a_text_file_without_data_rows_is_an_error(run, workdir):
    # Review, 2026-11-27: it read as "0 samples over 0.000 s", exit 0.
    for name, text in (("empty.txt", ""), ("header_only.txt", "t,ax,ay,az\n")):
        path = os.path.join(workdir, name)
        open(path, "w").write(text)
        r = run("info", path, "--columns", "t,ax,ay,az")
        assert r.returncode == 1 and f"{path}: no data rows" in r.stderr, r.stderr
