"""Issue 16's defects, each as found by hand, run through the real binary: every one must now end
in a one-line message and the documented exit code (0 done, 1 bad input, 2 usage error, 3 I/O
error; never a signal, a hang or 4, an internal error). tests/cli/bad_input_sweep.py attacks
every command systematically; this file keeps the issue's own cases and the newcomer path.

run: pytest (tests/pytest.ini), $IMUKIT_CLI the command under test
"""
import json
import os
import re
import shutil
import subprocess

import pytest

from conftest import imukit_binary

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
WALK = os.path.join(ROOT, "examples", "motion", "cmu_131_01_walk_2s.bvh")
PROFILE = os.path.join(ROOT, "examples", "profiles", "wrist_watch_imu.json")
SCENE = os.path.join(ROOT, "examples", "scenes", "walk_left_wrist.json")
EUROC_HEADER = ("#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
                "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]\n")


def run(*args, timeout=60, **kw):
    """(exit code, stdout, stderr); a timeout is exit code 'timeout', a signal a negative code."""
    try:
        r = subprocess.run([imukit_binary(), *args], capture_output=True, timeout=timeout, **kw)
    except subprocess.TimeoutExpired:
        return "timeout", "", ""
    return r.returncode, r.stdout.decode(errors="replace"), r.stderr.decode(errors="replace")


def one_line_error(rc, err, code, *parts):
    """The command failed with `code` and said so in one line holding every part."""
    lines = err.strip().splitlines()
    errors = [l for l in lines if l.startswith("imukit: error: ")]
    return rc == code and len(errors) == 1 and all(p in errors[0] for p in parts)


def write(path, text):
    with open(path, "w") as f:
        f.write(text)
    return path


@pytest.fixture(scope="module")
def t(workdir):
    """t(name): a path in the file's temporary folder."""
    return lambda name: os.path.join(workdir, name)


def test_item_1_identify_on_a_header_only_csv(t):
    # Item 1: identify on a header-only EuRoC CSV segfaulted (imu.t.front() of an empty series).
    write(t("h.csv"), EUROC_HEADER)
    rc, out, err = run("identify", "--imu", t("h.csv"), "--motion", WALK, "--init", "left_wrist_watch",
                       "-o", t("p.json"))
    assert one_line_error(rc, err, 1, "h.csv: holds 0 IMU sample(s)"), \
        f"1. identify on a header-only CSV: exit 1, says so ({rc}: {err.strip()})"


@pytest.fixture(scope="module")
def poses(t):
    # A short guided capture serves items 2, 11 and 13.
    poses = t("poses.mcap")
    rc, out, err = run("record", f"mock:poses?clock=virtual&poses=12&profile={PROFILE}", "--guide", "multipos",
                       "--poses", "12", "--duration", "300", "-o", poses)
    assert rc == 0 and "12 distinct poses held" in out and "(the initial static period)" in out, \
        f"11. record --guide multipos asks for the initial still period and holds 12 poses ({rc}: {err.strip()})"
    return poses


def test_item_2_calibrate_checks_its_numeric_options(t, poses):
    # Item 2: calibrate's numeric options, checked when the command line is parsed.
    for value in ["-5", "1e300", "nan", "0"]:
        rc, out, err = run("calibrate", poses, "--init-static", value, "-o", t("c.json"))
        assert one_line_error(rc, err, 2, "--init-static: must be a", "number in (0, 3600] s", f"got '{value}'"), \
            f"2. calibrate --init-static {value}: exit 2 naming the option, range and unit ({rc})"
    for value in ["0", "1e300", "-9.8"]:
        rc, out, err = run("calibrate", poses, "--gravity", value, "-o", t("c.json"))
        assert one_line_error(rc, err, 2, "--gravity", "[0.1, 100] m/s^2"), \
            f"2. calibrate --gravity {value}: exit 2 ({rc})"


def test_item_3_an_absurd_policy_parameter_is_refused_when_read(t):
    # Item 3: a policy parameter far beyond plausible aborted in so3_log when applied.
    write(t("pol.json"), json.dumps({"schema": "imukit.policy/1",
                                     "sub_policies": [{"amplitude": {"method": "scaling", "sigma": 1e300}}]}))
    rc, out, err = run("augment", "--scene", SCENE, "--policy", t("pol.json"), "-o", t("ds"))
    assert one_line_error(rc, err, 1, "pol.json: sub_policies[0].amplitude.sigma: expected a number in [0, 2]"), \
        f"3. a policy with sigma 1e300 is refused when read ({rc}: {err.strip()})"


def test_item_4_negative_seed_and_nan_time_offset(t):
    # Item 4: UBSan on a scene seed of -1 and on identify --time-offset nan.
    write(t("h.csv"), EUROC_HEADER)
    write(t("seed.json"), json.dumps({"schema": "imukit.scene/1",
                                      "motion": {"procedural": {"rate_hz": 100, "duration_s": 1, "seed": -1}},
                                      "sensors": [{"preset": "left_wrist_watch"}]}))
    rc, out, err = run("simulate", t("seed.json"), "-o", t("sim_seed"))
    assert one_line_error(rc, err, 1, "motion.procedural.seed: expected an integer in [0, 9223372036854775807], "
                                      "got -1"), \
        f"4. a scene seed of -1 is refused ({rc}: {err.strip()})"
    rc, out, err = run("identify", "--imu", t("h.csv"), "--motion", WALK, "--init", "left_wrist_watch",
                       "-o", t("p.json"), "--time-offset", "nan")
    assert one_line_error(rc, err, 2, "--time-offset: must be a finite number in [-86400, 86400] s"), \
        f"4. identify --time-offset nan: exit 2 ({rc})"


def test_item_5_bvh_frame_time_and_magnitudes_are_bounded(t):
    # Item 5: a BVH's own frame rate is bounded like --rate; absurd magnitudes are refused.
    bvh = open(WALK).read()
    for dt in ["1e-12", "1e-18"]:
        write(t(f"fast{dt}.bvh"), re.sub(r"Frame Time:.*", f"Frame Time: {dt}", bvh))
        rc, out, err = run("simulate", "--bvh", t(f"fast{dt}.bvh"), "--preset", "left_wrist_watch", "-o", t("sim_fast"),
                           timeout=20)
        assert one_line_error(rc, err, 1, f"fast{dt}.bvh:", "frame time", "is outside [1e-06, 3600] s"), \
            f"5. BVH Frame Time {dt}: exit 1 naming file:line:column ({rc}: {err.strip()})"
    lines = bvh.split("\n")
    i = next(k for k, l in enumerate(lines) if l.startswith("Frame Time"))
    values = lines[i + 1].split()
    lines[i + 1] = " ".join(["1e300"] + values[1:])
    write(t("far.bvh"), "\n".join(lines))
    rc, out, err = run("simulate", "--bvh", t("far.bvh"), "--preset", "left_wrist_watch", "-o", t("sim_far"))
    assert one_line_error(rc, err, 1, f"far.bvh:{i + 2}:1: the root position of frame 0", "beyond 10000 m"), \
        f"5. a root translation of 1e300: exit 1 ({rc}: {err.strip()})"
    for option, value, unit in [("--gravity", "1e300", "m/s^2"), ("--bvh-scale", "1e300", "m per BVH unit")]:
        rc, out, err = run("simulate", "--bvh", WALK, "--preset", "left_wrist_watch", option, value, "-o", t("sim_x"))
        assert one_line_error(rc, err, 2, option, unit), f"5. simulate {option} {value}: exit 2 ({rc})"


def test_item_6_devices_pipes_and_foreign_files(t, poses):
    # Item 6: outputs read back and inputs that are devices, pipes or folders.
    for cmd in [["characterize", poses], ["calibrate", poses]]:
        try:
            p = subprocess.run(["bash", "-c", f"set -o pipefail; '{imukit_binary()}' {cmd[0]} '{cmd[1]}' -o /dev/stdout | cat"],
                               capture_output=True, text=True, timeout=30)
            ok = p.returncode == 3 and "is a pipe (FIFO), not a file" in p.stderr
        except subprocess.TimeoutExpired:
            ok = False
        assert ok, f"6. {cmd[0]} -o /dev/stdout | cat: refused at once, no hang"
        rc, out, err = run(*cmd, "-o", "/dev/zero", timeout=30)
        assert one_line_error(rc, err, 3, "/dev/zero: is a character device, not a file"), \
            f"6. {cmd[0]} -o /dev/zero: exit 3 ({rc})"
    write(t("zero_scene.json"), json.dumps({"schema": "imukit.scene/1", "motion": {"bvh": "/dev/zero"},
                                            "sensors": [{"preset": "left_wrist_watch"}]}))
    rc, out, err = run("simulate", t("zero_scene.json"), "-o", t("sim_zero"), timeout=30)
    assert one_line_error(rc, err, 3, "/dev/zero: is a character device"), \
        f"6. a scene naming /dev/zero: exit 3 ({rc})"
    rc, out, err = run("simulate", "--bvh", WALK, "--preset", "left_wrist_watch", "--hardware", "/dev/zero",
                       "-o", t("sim_zero"), timeout=30)
    assert one_line_error(rc, err, 3, "/dev/zero"), f"6. --hardware /dev/zero: exit 3 ({rc})"
    rc, out, err = run("augment", "--scene", SCENE, "--policy", "/dev/zero", "-o", t("ds"), timeout=30)
    assert one_line_error(rc, err, 3, "/dev/zero"), f"6. --policy /dev/zero: exit 3 ({rc})"
    os.mkfifo(t("fifo.csv"))
    rc, out, err = run("info", t("fifo.csv"), timeout=30)
    assert one_line_error(rc, err, 3, "fifo.csv: is a pipe (FIFO), not a file"), \
        f"6. a FIFO as input: exit 3, no hang ({rc})"
    secret = "root:x:0:0:root:/root:/bin/bash-and-a-long-line-nobody-should-see-echoed"
    write(t("secret"), secret + "\n")
    write(t("secret_scene.json"), json.dumps({"schema": "imukit.scene/1", "motion": {"bvh": t("secret")},
                                              "sensors": [{"preset": "left_wrist_watch"}]}))
    rc, out, err = run("simulate", t("secret_scene.json"), "-o", t("sim_secret"))
    assert rc == 1 and secret not in err and secret[:24] in err and "(72 bytes)" in err, \
        f"6. a scene naming another file echoes at most a short excerpt of it ({err.strip()})"
    with open(t("binary.csv"), "wb") as f:
        f.write(EUROC_HEADER.encode() + b"1,\x1b[2J\x00\xff\xfe,2,3,4,5,6\n")
    rc, out, err = run("info", t("binary.csv"))
    # Since review 41 a control byte makes the file binary, said without quoting it.
    assert rc == 1 and "binary.csv:2:3: control byte 0x1B: a binary file, not text" in err and "\x1b" not in err, \
        f"6. control bytes of an input are never echoed ({err.strip()})"


def test_item_7_record_limits_and_a_silent_device(t):
    # Item 7: record limits that meant forever, a silent device, and zero samples.
    for option, value in [("--duration", "0"), ("--duration", "-5"), ("--duration", "nan"), ("--samples", "0"),
                          ("--rate", "0"), ("--rate", "-5")]:
        rc, out, err = run("record", "mock:static?clock=virtual", option, value, "-o", t("r.mcap"), timeout=20)
        assert one_line_error(rc, err, 2, option), f"7. record {option} {value}: exit 2 ({rc})"
    rc, out, err = run("record", "mock:static?clock=virtual", "-o", t("r.mcap"), timeout=20)
    assert one_line_error(rc, err, 2, "virtual-clock mock", "--duration or --samples"), \
        f"7. a virtual-clock mock without a limit is refused, not a disk filler ({rc})"
    rc, out, err = run("record", "mock:static?drop=1&clock=virtual", "-o", t("r.mcap"), "--duration", "5",
                       "--no-data-timeout", "1", timeout=20)
    assert one_line_error(rc, err, 3, "record: no samples from mock_static") \
        and "no data for 1 s since the start" in out, \
        f"7. a silent device stops after the no-data timeout and the command fails ({rc}: {err.strip()})"


def test_item_8_augment_sizes_and_seed(t):
    # Item 8: augment sizes checked up front; a negative seed is an error, not 0.
    for value, code, part in [("-1", 2, "--count: must be a whole number"), ("1e8", 2, "--count"),
                              ("100000000000", 1, "GiB in memory")]:
        rc, out, err = run("augment", "--scene", SCENE, "--count", value, "-o", t("ds"))
        assert one_line_error(rc, err, code, part), \
            f"8. augment --count {value}: exit {code} ({rc}: {err.strip()})"
    rc, out, err = run("augment", "--scene", SCENE, "--seed", "-1", "-o", t("ds"))
    assert one_line_error(rc, err, 2, "--seed: must be a whole number in [0, 9223372036854775807]"), \
        f"8. augment --seed -1: exit 2 ({rc})"


def test_item_11_calibrate_reads_the_guided_capture(t, poses):
    # Item 11: calibrate reads the guided capture's initial still period; a wrong one says why.
    rc, out, err = run("calibrate", poses, "-o", t("cal.json"))
    n = re.search(r"(\d+) static poses", out)
    assert rc == 0 and "initial static period: 10 s" in out and n and int(n.group(1)) >= 9, \
        f"11. calibrate on the guided capture works with its defaults ({out.splitlines()[:2]}, {err.strip()})"
    rc, out, err = run("calibrate", poses, "--init-static", "30", "-o", t("cal30.json"))
    assert one_line_error(rc, err, 1, "with the first 30 s as the initial static period",
                          "the device was not still for all of them (with --init-static"), \
        f"11. too long an initial period: the error names a --init-static ({err.strip()})"
    # The period it names works (found in review: the hint once halved the period every time,
    # never one that calibrated).
    named = re.search(r"with --init-static ([0-9.]+) the accelerometer calibrates", err)
    rc, out, err = run("calibrate", poses, "--init-static", named.group(1) if named else "0", "-o", t("calN.json"))
    assert rc == 0, f"11. the named --init-static calibrates ({err.strip()})"


def test_item_12_bundled_profile_walk_and_scene(t):
    # Item 12: the bundled profile on the bundled walk hints at --rate; the shipped scene works.
    rc, out, err = run("simulate", "--bvh", WALK, "--preset", "left_wrist_watch", "--hardware", PROFILE, "-o", t("s1"))
    assert one_line_error(rc, err, 1, "bandwidth", "(the profile's own rate: --rate 400)"), \
        f"12. profile bandwidth above the walk's Nyquist: the error says --rate 400 ({err.strip()})"
    rc, out, err = run("simulate", "--bvh", WALK, "--preset", "left_wrist_watch", "--hardware", PROFILE,
                       "--rate", "400", "-o", t("s1"))
    assert rc == 0, f"12. with --rate 400 it simulates ({err.strip()})"
    rc, out, err = run("augment", "--scene", SCENE, "--policy", "imukit", "--window", "100", "--stride", "25",
                       "--count", "200", "-o", t("ds_scene"))
    assert rc == 0 and "200 windows x 100 samples x 6 channels" in out, \
        f"12. examples/scenes/walk_left_wrist.json (the README's scene) augments ({err.strip()})"


def test_item_13_messages_and_exit_codes(t, poses, still):
    # Item 13: messages and exit codes.
    write(t("one.csv"), EUROC_HEADER + "0,0,0,0,0,0,9.8\n")
    rc, out, err = run("calibrate", t("one.csv"), "-o", t("c1.json"))
    assert one_line_error(rc, err, 1, "one.csv"), \
        f"13. calibrate on a one-row CSV says what is missing ({err.strip()})"
    rows = "".join(f"{k * 10_000_000},0.1,0.2,0.3,0,0,9.8\n" for k in range(200))
    write(t("far.csv"), EUROC_HEADER + rows)
    rc, out, err = run("identify", "--imu", t("far.csv"), "--motion", WALK, "--init", "left_wrist_watch",
                       "--motion-start", "-1000", "-o", t("p.json"))
    assert rc == 1 and "best r = -2" not in err and "-2 iterations" not in out, \
        f"13. identify without overlap: no 'best r = -2' ({err.strip()})"
    write(t("back.csv"), EUROC_HEADER + "2000000000,0,0,0,0,0,9.8\n1000000000,0,0,0,0,0,9.8\n")
    rc, out, err = run("info", t("back.csv"))
    assert one_line_error(rc, err, 1, "time goes backwards ('1000000000' after 2000000000 on the row before, in ns)"), \
        f"13. time going backwards: both times in the file's unit ({err.strip()})"
    os.mkdir(t("outdir"))
    rc, out, err = run("characterize", poses, "-o", t("outdir") + "/")
    assert one_line_error(rc, err, 3, "is a folder, not a file"), \
        f"13. characterize -o dir/: exit 3 ({err.strip()})"
    write(t("existing"), "x")
    rc, out, err = run("simulate", "--bvh", WALK, "--preset", "left_wrist_watch", "-o", t("existing"))
    assert one_line_error(rc, err, 2, "is an existing file") and "internal error" not in err, \
        f"13. simulate -o existing_file: a usage error ({err.strip()})"
    rc, out, err = run("characterize", still, "-o", t("ch.json"), "--kalibr", t("imu.yaml"))
    assert rc == 0 and "spread not measured (needs recordings from 2 or more power cycles)" in out, \
        f"13. one recording: the turn-on bias spread is not claimed ({err.strip()})"
    assert "random walk seen" in err and "_random_walk is 0" in err, \
        f"13. Kalibr random_walk 0 comes with a warning ({err.strip()})"
    write(t("empty.mcap"), "")
    rc, out, err = run("info", t("empty.mcap"))
    assert one_line_error(rc, err, 1, "empty.mcap: holds no IMU samples"), \
        f"13. a 0-byte .mcap fails info ({rc})"
    rc, out, err = run("characterize", still, "--points-per-decade", "1000", "-o", t("ch.json"))
    assert one_line_error(rc, err, 2, "--points-per-decade: must be a whole number in [1, 100]"), \
        f"13. --points-per-decade is bounded ({rc})"
    rc, out, err = run("nosuchcommand")
    assert one_line_error(rc, err, 2, "unknown command 'nosuchcommand'"), \
        f"13. an unknown command is a usage error ({rc})"
    rc, out, err = run("--help")
    assert rc == 0 and "Exit codes: 0 done, 1 bad input" in out and "3 I/O error" in out, \
        "13. imukit --help documents the exit codes"


@pytest.fixture(scope="module")
def still(t):
    still = t("still.mcap")
    rc, out, err = run("record", f"mock:static?clock=virtual&profile={PROFILE}", "--duration", "60",
                       "-o", still)
    assert rc == 0 and re.search(r"largest backlog \d+ of 32768 samples", out) is not None, \
        f"13. record explains its queue figure ({out.strip().splitlines()[-2:]})"
    return still


def test_item_14_allan_plots(t, still):
    # Item 14: Allan plots: every axis drawn distinguishably, reference lines per fitted term and
    # axis, powers of ten, a script that runs from any folder.
    rc, out, err = run("characterize", still, "-o", t("ch2.json"), "--plot", t("plots"))
    if rc == 0 and os.path.isfile(t("plots/gyroscope_allan.gp")) and shutil.which("gnuplot"):
        gp = open(t("plots/gyroscope_allan.gp")).read()
        assert "10^{%L}" in gp and all(f"t '{a}'" in gp for a in "xyz") \
            and len(set(re.findall(r" pt (\d+) ", gp))) == 3, \
            "14. Allan plot: three point shapes, powers-of-ten ticks"
        assert all(f"{a}: N/sqrt(tau)" in gp for a in "xyz") and "K sqrt" not in gp and "1/0" not in gp, \
            "14. reference lines for every axis's fitted terms, no legend entry for a term not fitted (1 min: no K)"
        os.remove(t("plots/gyroscope_allan.svg"))
        g = subprocess.run(["gnuplot", t("plots/gyroscope_allan.gp")], cwd="/", capture_output=True, text=True)
        assert g.returncode == 0 and os.path.isfile(t("plots/gyroscope_allan.svg")), \
            f"14. the .gp script runs from another folder ({g.stderr.strip()})"
    else:
        assert rc == 0, f"14. characterize --plot ({err.strip()})"


# Review 41: defects found by hand, each case as reproduced.
IMU_ROWS = "".join(f"{i / 100:.3f},0.01,0.02,9.8,0.001,0.002,0.003\n" for i in range(5))


def test_command_line_mistakes_are_usage_errors(t):
    rc, _, err = run("simulate", "--bvh", WALK, "--preset", "nope", "-o", t("s41"))
    assert one_line_error(rc, err, 2, "simulate --preset: unknown placement preset 'nope' (presets: "), \
        f"an unknown --preset is a usage error like an unknown --method ({rc}: {err.strip()})"
    # Said before the BVH is read: a missing BVH does not hide it.
    rc, _, err = run("simulate", "--bvh", t("missing.bvh"), "--preset", "nope", "-o", t("s41"))
    assert one_line_error(rc, err, 2, "unknown placement preset 'nope'"), f"{rc}: {err.strip()}"
    a = write(t("a41.txt"), IMU_ROWS)
    for columns in ("t,ax,_*", "t,ax"):
        rc, _, err = run("info", a, "--columns", columns)
        assert one_line_error(rc, err, 2, f"{a}: --columns '{columns}': the accelerometer needs all three "
                                          "columns ax,ay,az"), \
            f"--columns {columns}: the partial triad is a usage error, said before any row ({rc}: {err.strip()})"
    rc, _, err = run("info", a, "--columns", "t,ax,ay,az,gx,gy")
    assert one_line_error(rc, err, 2, "the gyroscope needs all three columns gx,gy,gz"), f"{rc}: {err.strip()}"


def test_profile_ranges_are_checked_where_the_file_says_them(t):
    jitter = write(t("clk.json"), '{"schema": "imukit.profile/1", "clock": {"jitter_s": 1}}')
    ppm = write(t("ppm.json"), '{"schema": "imukit.profile/1",\n "clock": {"error_ppm": 1e5}}')
    # Found in review (2026-11-26): the model's magnitude limit was said in its words, naming no
    # file ("hardware model: accelerometer.noise_density[1] is 10000000000000, ...").
    huge = write(t("huge.json"), '{"schema": "imukit.profile/1",\n'
                                 ' "accelerometer": {"noise": {"noise_density": [0.001, 1e13, 0.001]}}}')
    watch = PROFILE
    cases = [
        (huge, f"imukit: error: {huge}:2:55: accelerometer.noise.noise_density[1]: 10000000000000 is beyond "
               "any sensor's (at most 1e+12 in magnitude)"),
        (jitter, f"imukit: error: {jitter}:1:54: clock.jitter_s: 1 s is more than a tenth of the sample period "
                 "at the rate the model runs at (120 Hz: 0.000833 s)"),
        (ppm, f"imukit: error: {ppm}:2:25: clock.error_ppm: 100000 ppm is not within +-10000 ppm"),
        (watch, f"imukit: error: {watch}:32:96: accelerometer.limits.bandwidth: 80 Hz is not below half the "
                "rate the model runs at (60 Hz); simulate at a rate above twice the bandwidth with --rate "
                "(the profile's own rate: --rate 400)"),
    ]
    for profile, message in cases:
        rc, _, err = run("simulate", "--bvh", WALK, "--preset", "left_wrist_watch", "--hardware", profile,
                         "-o", t("s41"))
        assert rc == 1 and err.strip() == message, f"{profile}: {rc}: {err.strip()}"


def help_examples(command):
    """The example commands of `imukit COMMAND --help`, each as its list of printed lines."""
    rc, out, _ = run(command, "--help")
    assert rc == 0, command
    examples, inside = [], False
    for line in out.splitlines():
        if line.startswith("Example"):
            inside = True
        elif inside and line.startswith("  imukit "):
            examples.append([line])
        elif inside and line.startswith("      ") and examples:
            examples[-1].append(line)
        elif inside and line.strip():
            inside = line.startswith("  ")  # a note inside the block; a paragraph ends it
    return examples


def test_every_help_example_pastes_into_a_shell():
    rc, out, _ = run("--help")
    commands = [l.split()[0] for l in out.split("Subcommands:")[1].split("\n\n")[0].splitlines() if l.strip()]
    assert "identify" in commands and len(commands) == 11, commands
    for command in commands:
        for lines in help_examples(command):
            # Every line but the last ends with " \" (found in review: identify's second example did
            # not), and no *, & or ? is left unquoted (zsh refuses an unmatched `_*` or `?`).
            assert all(l.endswith(" \\") for l in lines[:-1]) and not lines[-1].endswith("\\"), \
                f"{command} --help: {lines}"
            text = re.sub(r"'[^']*'|\"[^\"]*\"", "", "\n".join(lines))
            assert not re.search(r"[*&?]", text), f"{command} --help: {lines}"
    assert ["  imukit identify --imu 02_undisturbed_slow_rotation_B.csv --columns 't,ax,ay,az,gx,gy,gz,_*' \\",
            "      --pose 02_undisturbed_slow_rotation_B.csv --columns t,_9,qw,qx,qy,qz,px,py,pz,_ \\",
            "      --gaps qw,qx,qy,qz,px,py,pz -o placement.json"] in help_examples("identify")


def test_an_unknown_per_file_option_is_unknown_wherever_it_stands(t):
    a = write(t("a41.txt"), IMU_ROWS)
    for args in (["info", "--frobnicate"], ["info", a, "--frobnicate"], ["info", a, "--frobnicate", "x"],
                 ["info", "--frobnicate=1", a]):
        rc, _, err = run(*args)
        assert rc == 2 and err.strip() == \
            "imukit: error: unknown option --frobnicate (see --help); see `imukit info --help`", f"{args}: {err}"
    rc, _, err = run("info", a, "--columns")
    assert rc == 2 and "option --columns needs a value" in err, err


def test_npy_header_is_a_strict_python_dict(t):
    def npy(name, header, data=b"\0" * 24):
        header = header.encode() + b"\n"
        path = t(name)
        with open(path, "wb") as f:
            f.write(b"\x93NUMPY\x01\x00" + len(header).to_bytes(2, "little") + header + data)
        return path
    space = npy("space41.npy", "{'descr': '<f8', 'fortran_order': False, 'shape': (1 1 3), }")
    cut = t("cut41.npy")
    with open(cut, "wb") as f:
        f.write(b"\x93NUMPY\x01\x00v")
    for path, message in (
            (space, f"{space}: byte 63: not a valid .npy: expected ',' or ')' after a dimension of the shape"),
            (cut, f"{cut}: byte 9: not a valid .npy: truncated: 9 bytes, but the magic, version and header "
                  "length take 10")):
        rc, _, err = run("motion", "--keypoints", path, "--rate", "50", "--topology", "h36m_17", "-o", t("m41.csv"))
        assert rc == 1 and err.strip() == f"imukit: error: {message}", f"{rc}: {err.strip()}"


def test_text_readers_say_what_the_file_is(t):
    header = EUROC_HEADER
    for stamp in ("1000.5", "1e3"):
        path = write(t("ts41.csv"), header + f"{stamp},0,0,0,0,0,9.8\n2000,0,0,0,0,0,9.8\n")
        rc, _, err = run("info", path)
        assert rc == 1 and err.strip() == (
            f"imukit: error: {path}:2:1: column 1 (t): '{stamp}' is not an integer number of ns (this "
            "format's times are written as integers)"), err
    cr = write(t("cr41.txt"), IMU_ROWS.replace("\n", "\r"))
    rc, _, err = run("info", cr, "--columns", "t,ax,ay,az,gx,gy,gz")
    assert rc == 1 and err.strip() == (
        f"imukit: error: {cr}:1:38: a carriage return (\\r) inside a line: the file's lines end with a bare "
        "CR (classic Mac OS); save it with \\n or \\r\\n line ends"), err
    # An MCAP recording (whatever its name) with a column map, and another binary file.
    csv = write(t("ok41.csv"), header + "".join(f"{i * 10000000},0,0,0,0,0,9.8\n" for i in range(20)))
    rec = t("rec41.dat")
    rc, _, err = run("convert", csv, "-o", t("rec41.mcap"))
    assert rc == 0, err
    shutil.copy(t("rec41.mcap"), rec)
    for path in (t("rec41.mcap"), rec):
        rc, out, err = run("info", path, "--columns", "t,ax,ay,az,gx,gy,gz")
        assert rc == 2 and err.strip() == (
            f"imukit: error: {path}: an MCAP recording states its own layout: give it without --columns; "
            "see `imukit info --help`"), err
        assert "MCAP0" not in err and "\\x" not in err
    binary = t("bin41.txt")
    with open(binary, "wb") as f:
        f.write(bytes(range(256)) * 4)
    rc, _, err = run("info", binary, "--columns", "t,ax,ay,az,gx,gy,gz")
    assert rc == 1 and err.strip() == f"imukit: error: {binary}:1:1: control byte 0x00: a binary file, not text", err
