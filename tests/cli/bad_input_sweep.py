"""The bad-input sweep: every command that reads a file gets every kind of bad file in each file
role it has (missing, empty, random bytes, truncated, NaN, extreme magnitudes, a foreign file,
a device or pipe), and every numeric option gets non-numbers and values out of range. Each run
must end within the time limit, by itself (no signal: under the sanitizer build an ASan or UBSan
report aborts the process, so that is caught too), with a documented exit code (0 done, 1 bad
input, 2 usage, 3 I/O; 4, an internal error, is a failure), with at most one error line, and
without echoing the input: the output is printable text, and no 40-byte run of a foreign file
appears in it. The table of exit codes per input class and command is printed at the end (it is
the one in docs/validation.md, "Robustness").

run: pytest (tests/pytest.ini), $IMUKIT_CLI the command under test; quick mode ($IMUKIT_TEST_QUICK,
the sanitizer build) tries three values per numeric option instead of ten and allows 60 s per run.
As a script, for the table or every run's outcome:
  python3 bad_input_sweep.py IMUKIT_BINARY [--quick] [--jobs N] [--verbose]
  --verbose print every run: its exit code, command and first error line
"""
import concurrent.futures
import json
import os
import random
import re
import shutil
import subprocess
import sys
import tempfile
import time

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
WALK = os.path.join(ROOT, "examples", "motion", "cmu_131_01_walk_2s.bvh")
PROFILE = os.path.join(ROOT, "examples", "profiles", "wrist_watch_imu.json")
EUROC_HEADER = ("#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
                "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]\n")
# A foreign file's content (think /etc/passwd): no 40-byte run of it may appear in any output.
FOREIGN = ("root:x:0:0:root:/root:/bin/bash\n" + "s3cr3t-" * 12 + "\n").encode()
CLASSES = ["missing", "empty", "random", "truncated", "nan", "extreme", "foreign", "device"]


def prepare(tmp, imukit):
    """Good fixtures of every kind, then each bad variant: {kind: {class: path}}."""
    rng = random.Random(16)
    p = lambda name: os.path.join(tmp, name)
    good = {}
    rows = [f"{k * 10_000_000},{0.01 * rng.gauss(0, 1):.6f},{0.01 * rng.gauss(0, 1):.6f},"
            f"{0.01 * rng.gauss(0, 1):.6f},{0.05 * rng.gauss(0, 1):.6f},{0.05 * rng.gauss(0, 1):.6f},"
            f"{9.80665 + 0.05 * rng.gauss(0, 1):.6f}\n" for k in range(300)]
    good["csv"] = p("good.csv")
    open(good["csv"], "w").write(EUROC_HEADER + "".join(rows))
    good["txt"] = p("good.txt")
    open(good["txt"], "w").write("".join(r.replace(",", " ") for r in rows))
    good["mcap"] = p("good.mcap")
    subprocess.run([imukit, "convert", good["csv"], "-o", good["mcap"]], check=True, capture_output=True)
    good["bvh"] = p("good.bvh")
    shutil.copy(WALK, good["bvh"])
    good["scene"] = p("good_scene.json")
    json.dump({"schema": "imukit.scene/1", "motion": {"procedural": {"rate_hz": 50, "duration_s": 2, "seed": 1}},
               "simulation": {"seed": 3}, "sensors": [{"preset": "left_wrist_watch"}]}, open(good["scene"], "w"))
    good["policy"] = p("good_policy.json")
    json.dump({"schema": "imukit.policy/1", "sub_policies": [
        {"amplitude": {"method": "scaling", "sigma": 0.2}, "hardware": {"accel_noise": 0.05}}]},
        open(good["policy"], "w"))
    good["profile"] = p("good_profile.json")
    shutil.copy(PROFILE, good["profile"])
    good["labels"] = p("good_labels.csv")
    open(good["labels"], "w").write("start_s,end_s,label\n0,1,0\n1,2,1\n")

    # Where a NaN or an extreme magnitude goes in each kind of file.
    def numbers(kind, text, value):
        if kind in ("csv", "txt"):
            lines = text.split("\n")
            sep = "," if kind == "csv" else " "
            k = 1 if kind == "csv" else 0
            f = lines[k + 5].split(sep)
            f[2] = value
            lines[k + 5] = sep.join(f)
            if value != "nan":
                f = lines[k + 6].split(sep)
                f[0] = value  # a time stamp too
                lines[k + 6] = sep.join(f)
            return "\n".join(lines)
        if kind == "bvh":
            lines = text.split("\n")
            i = next(k for k, l in enumerate(lines) if l.startswith("Frame Time"))
            v = lines[i + 3].split()
            v[0], v[4] = value, value  # a root position and a rotation
            lines[i + 3] = " ".join(v)
            return "\n".join(lines)
        if kind == "labels":
            return text.replace("1,2,1", f"1,{value},1")
        if kind == "scene":
            return text.replace('"duration_s": 2', f'"duration_s": {value}').replace('"seed": 3', f'"seed": {value}')
        if kind == "policy":
            return text.replace('"sigma": 0.2', f'"sigma": {value}')
        if kind == "profile":
            return re.sub(r'"noise_density": \[[^]]*\]', f'"noise_density": [{value}, {value}, {value}]', text, count=1)
        return None

    files = {}
    os.mkfifo(p("fifo.csv"))
    for kind, path in good.items():
        data = open(path, "rb").read()
        ext = os.path.splitext(path)[1]
        v = {"missing": p(f"missing_{kind}{ext}"), "device": "/dev/zero" if kind != "csv" else p("fifo.csv")}
        for cls, content in [("empty", b""),
                             ("random", bytes(rng.randrange(256) for _ in range(3000))),
                             ("truncated", data[: len(data) * 2 // 5]),
                             ("foreign", FOREIGN)]:
            v[cls] = p(f"{cls}_{kind}{ext}")
            open(v[cls], "wb").write(content)
        for cls, value in [("nan", "nan"), ("extreme", "1e300")]:
            if kind == "mcap":  # made by imukit itself from text with the value in an accelerometer column
                source = p(f"{cls}_for_mcap.txt")
                lines = open(good["txt"]).read().split("\n")
                for k in (5, 6, 7):
                    lines[k] = lines[k].rsplit(" ", 1)[0] + " " + value
                open(source, "w").write("\n".join(lines))
                v[cls] = p(f"{cls}_mcap.mcap")
                subprocess.run([imukit, "convert", source, "--columns", "t,gx,gy,gz,ax,ay,az", "--time-unit", "ns",
                                "--gaps", "ax,ay,az", "-o", v[cls]], check=True, capture_output=True)
                continue
            v[cls] = p(f"{cls}_{kind}{ext}")
            open(v[cls], "w").write(numbers(kind, data.decode(), value))
        files[kind] = v
    return good, files


def roles(good):
    """(command, kind, argument list with {F} where the bad file goes, {O} the run's output folder)."""
    cols = ["--columns", "t,gx,gy,gz,ax,ay,az", "--time-unit", "ns"]
    return [
        ("info", "csv", ["info", "{F}"]),
        ("info", "mcap", ["info", "{F}"]),
        ("info", "txt", ["info", "{F}", *cols]),
        ("convert", "csv", ["convert", "{F}", "-o", "{O}/c.csv"]),
        ("convert", "mcap", ["convert", "{F}", "-o", "{O}/c.npy"]),
        ("convert", "mcap", ["convert", "--recover", "{F}", "-o", "{O}/r.mcap"]),
        ("characterize", "mcap", ["characterize", "{F}", "-o", "{O}/p.json"]),
        ("characterize", "txt", ["characterize", "{F}", *cols, "-o", "{O}/p.json"]),
        ("calibrate", "csv", ["calibrate", "{F}", "-o", "{O}/p.json", "--init-static", "1"]),
        ("simulate", "scene", ["simulate", "{F}", "-o", "{O}/sim"]),
        ("simulate", "bvh", ["simulate", "--bvh", "{F}", "--preset", "left_wrist_watch", "-o", "{O}/sim"]),
        ("simulate", "profile", ["simulate", "--bvh", good["bvh"], "--preset", "left_wrist_watch", "--hardware",
                                 "{F}", "--rate", "400", "-o", "{O}/sim.mcap"]),
        ("augment", "scene", ["augment", "--scene", "{F}", "--window", "20", "-o", "{O}/ds"]),
        ("augment", "policy", ["augment", "--scene", good["scene"], "--policy", "{F}", "--window", "20",
                               "-o", "{O}/ds"]),
        ("augment", "labels", ["augment", "--scene", good["scene"], "--labels", "{F}", "--window", "20",
                               "-o", "{O}/ds"]),
        ("augment", "csv", ["augment", "--input", "{F}", "--window", "20", "-o", "{O}/ds"]),
        ("identify", "csv", ["identify", "--imu", "{F}", "--motion", good["bvh"], "--init", "left_wrist_watch",
                             "-o", "{O}/pl.json"]),
        ("identify", "bvh", ["identify", "--imu", good["csv"], "--motion", "{F}", "--init", "left_wrist_watch",
                             "-o", "{O}/pl.json"]),
        ("record", "txt", ["record", "file:{F}?codec=text", "--duration", "1", "--no-data-timeout", "1",
                           "-o", "{O}/rec.mcap"]),
        ("devices", "txt", ["devices", "--read", "file:{F}?codec=witmotion", "--seconds", "1"]),
        ("demo", "bvh", ["demo", "--quick", "--motion", "{F}", "-o", "{O}/demo"]),
    ]


# Numeric options: (command, option, arguments that fail fast after parsing). Values are checked
# when the command line is parsed; a valid one then meets a missing input (exit 3) or a bad URI.
def option_cases(tmp):
    m = os.path.join(tmp, "no_such_input.csv")
    o = os.path.join(tmp, "opt_out")
    bad_uri = "mock:static?bogus_key=1"
    return [("calibrate", "--init-static", ["calibrate", m, "-o", o]),
            ("calibrate", "--gravity", ["calibrate", m, "-o", o]),
            ("characterize", "--gravity", ["characterize", m, "-o", o]),
            ("characterize", "--points-per-decade", ["characterize", m, "-o", o]),
            ("characterize", "--fit-tau-min", ["characterize", m, "-o", o]),
            ("simulate", "--rate", ["simulate", m, "-o", o]),
            ("simulate", "--seed", ["simulate", m, "-o", o]),
            ("simulate", "--gravity", ["simulate", m, "-o", o]),
            ("simulate", "--bvh-scale", ["simulate", "--bvh", m, "--preset", "left_wrist_watch", "-o", o]),
            ("augment", "--window", ["augment", "--scene", m, "-o", o]),
            ("augment", "--stride", ["augment", "--scene", m, "-o", o]),
            ("augment", "--count", ["augment", "--scene", m, "-o", o]),
            ("augment", "--batch-size", ["augment", "--scene", m, "-o", o]),
            ("augment", "--seed", ["augment", "--scene", m, "-o", o]),
            ("augment", "--threads", ["augment", "--scene", m, "-o", o]),
            ("augment", "--identity-fraction", ["augment", "--scene", m, "-o", o]),
            ("identify", "--bvh-scale", ["identify", "--imu", m, "--motion", m, "-o", o]),
            ("identify", "--height", ["identify", "--imu", m, "--motion", m, "-o", o]),
            ("identify", "--segment-prior", ["identify", "--imu", m, "--motion", m, "-o", o]),
            ("identify", "--time-offset", ["identify", "--imu", m, "--motion", m, "-o", o]),
            ("identify", "--max-time-offset", ["identify", "--imu", m, "--motion", m, "-o", o]),
            ("identify", "--motion-start", ["identify", "--imu", m, "--motion", m, "-o", o]),
            ("identify", "--gravity", ["identify", "--imu", m, "--motion", m, "-o", o]),
            ("identify", "--threads", ["identify", "--imu", m, "--motion", m, "-o", o]),
            ("record", "--duration", ["record", bad_uri, "-o", o + ".mcap"]),
            ("record", "--samples", ["record", bad_uri, "-o", o + ".mcap"]),
            ("record", "--rate", ["record", bad_uri, "-o", o + ".mcap"]),
            ("record", "--poses", ["record", bad_uri, "-o", o + ".mcap"]),
            ("record", "--no-data-timeout", ["record", bad_uri, "-o", o + ".mcap"]),
            ("record", "--init-static", ["record", bad_uri, "-o", o + ".mcap"]),
            ("devices", "--seconds", ["devices", "--read", bad_uri]),
            ("demo", "--seed", ["demo", "--motion", m, "-o", o])]


# Values every numeric option must refuse at parse time (exit 2), and values some accept.
NOT_NUMBERS = ["nan", "inf", "1e999", "abc", "", "0x10"]
OUT_OF_RANGE = ["1e300", "-1e300"]


def option_values(quick):
    return ["nan", "abc", "1e300"] if quick else NOT_NUMBERS + OUT_OF_RANGE + ["-1", "0"]


def timeout_s(quick):
    return 60 if quick else 20  # s per run; the sanitizer build is ~10x slower


def run(imukit, args, cwd, timeout):
    start = time.monotonic()
    try:
        r = subprocess.run([imukit, *args], capture_output=True, timeout=timeout, cwd=cwd, stdin=subprocess.DEVNULL)
        return r.returncode, r.stdout, r.stderr, time.monotonic() - start
    except subprocess.TimeoutExpired:
        return "hang", b"", b"", time.monotonic() - start


def problems(rc, out, err, foreign, timeout):
    """What is wrong with a run's outcome (empty: nothing)."""
    found = []
    if rc == "hang":
        return [f"no result within {timeout} s"]
    if rc < 0:
        found.append(f"killed by signal {-rc}")
    elif rc not in (0, 1, 2, 3):
        found.append(f"exit code {rc}" + (" (internal error)" if rc == 4 else ""))
    for name, stream in (("stdout", out), ("stderr", err)):
        try:
            text = stream.decode("utf-8")
        except UnicodeDecodeError as e:
            found.append(f"{name} is not UTF-8 text ({e})")
            continue
        if any(ord(c) < 32 and c not in "\n\t" or ord(c) == 127 for c in text):
            found.append(f"{name} holds control characters")
    if foreign:
        blob = out + err
        for k in range(0, len(FOREIGN) - 40):
            if FOREIGN[k:k + 40] in blob:
                found.append("echoes 40 bytes of the input")
                break
    errors = [l for l in err.decode(errors="replace").splitlines() if l.startswith("imukit: error:")]
    if rc not in (0, "hang") and len(errors) != 1:
        found.append(f"{len(errors)} error lines")
    return found


def sweep(imukit, quick, workers=2, verbose=False):
    """Runs every case (in `workers` threads), prints the table of exit codes; returns what went
    wrong, one line per failed run."""
    with tempfile.TemporaryDirectory() as tmp:
        good, files = prepare(tmp, imukit)
        jobs = []  # (table row, table column, args, foreign)
        for cls in CLASSES:
            for command, kind, template in roles(good):
                # Outputs in a folder per run: runs go in parallel.
                out = os.path.join(tmp, "out", str(len(jobs)))
                os.makedirs(out)
                args = [a.replace("{F}", files[kind][cls]).replace("{O}", out) for a in template]
                jobs.append((cls, command, args, cls == "foreign"))
        for command, option, base in option_cases(tmp):
            for value in option_values(quick):
                jobs.append(("option value", command, base[:1] + [f"{option}={value}"] + base[1:], False, value))
        start = time.monotonic()
        with concurrent.futures.ThreadPoolExecutor(workers) as pool:
            results = list(pool.map(lambda j: run(imukit, j[2], tmp, timeout_s(quick)), jobs))
        elapsed = time.monotonic() - start

        table = {}
        failures = []
        slowest = 0.0
        for job, (rc, out, err, seconds) in zip(jobs, results):
            row, column, args, foreign = job[:4]
            slowest = max(slowest, seconds)
            found = problems(rc, out, err, foreign, timeout_s(quick))
            if row == "option value" and job[4] in NOT_NUMBERS + OUT_OF_RANGE and rc != 2:
                found.append(f"{job[4]!r} is not refused as a usage error")
            table.setdefault(row, {}).setdefault(column, set()).add(str(rc))
            if verbose:
                first = err.decode(errors="replace").strip().splitlines()
                print(f"{rc} [{row}] {' '.join(args)}\n    {first[-1] if first else ''}")
            if found:
                failures.append(f"{' '.join(args)} -> {rc}: {'; '.join(found)} | "
                                f"{err.decode(errors='replace').strip()[:300]}")

        commands = ["info", "convert", "characterize", "calibrate", "simulate", "augment", "identify", "record",
                    "devices", "demo"]
        print(f"\n{len(jobs)} runs in {elapsed:.1f} s with {workers} workers (slowest {slowest:.2f} s)")
        print("exit codes seen (0 done, 1 bad input, 2 usage, 3 I/O):\n")
        print("| input | " + " | ".join(commands) + " |")
        print("|---|" + "---|" * len(commands))
        for row in CLASSES + ["option value"]:
            cells = [", ".join(sorted(table.get(row, {}).get(c, set()))) or "-" for c in commands]
            print(f"| {row} | " + " | ".join(cells) + " |")
        print()
    return failures


def test_every_bad_input_ends_in_a_documented_way(imukit, quick):
    failures = sweep(imukit, quick)
    assert not failures, f"{len(failures)} run(s) went wrong:\n" + "\n".join(failures)


if __name__ == "__main__":
    argv = sys.argv
    failed = sweep(os.path.abspath(argv[1]), "--quick" in argv[2:],
                   int(argv[argv.index("--jobs") + 1]) if "--jobs" in argv else 2, "--verbose" in argv[2:])
    print("\n".join(failed))
    print(f"{len(failed)} run(s) went wrong")
    sys.exit(1 if failed else 0)
