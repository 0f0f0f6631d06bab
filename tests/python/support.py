"""Shared by the Python-package tests: the `imukit` command for the comparisons with the CLI, the
shared data folder (both from tests/conftest.py, which pytest loads and puts on sys.path), and a
EuRoC CSV reader in plain NumPy."""
import subprocess
import threading
import time

import numpy as np

from conftest import DATA_DIR as DATA, CLI_ENV, data_file, imukit_binary, quick_mode, run_imukit as run_cli  # noqa: F401


def cli_error(*args):
    """The one error line the command prints, without its 'imukit: error: ' prefix."""
    r = subprocess.run([imukit_binary(), *map(str, args)], capture_output=True, text=True, env=CLI_ENV)
    assert r.returncode != 0, f"expected imukit {' '.join(map(str, args))} to fail"
    line = r.stderr.strip().splitlines()[-1]
    prefix = "imukit: error: "
    assert line.startswith(prefix), line
    return line[len(prefix):]


def euroc(path):
    """(t int64 ns, gyro (n, 3), accel (n, 3)) as written by the command (17 digits: exact)."""
    d = np.loadtxt(path, delimiter=",", comments="#", dtype=np.float64, ndmin=2)
    t = np.loadtxt(path, delimiter=",", comments="#", dtype=np.int64, usecols=0, ndmin=1)
    return t, d[:, 1:4], d[:, 4:7]


def python_steps_during(call):
    """Runs call() in another thread while this one spins a Python loop: (how many of the loop's
    time stamps fell in the middle half of the call, the call's duration in s). Only the middle
    half counts: at its ends the worker runs Python itself. With the GIL held by the C++ code for
    the whole call the count is 0, whatever the machine's load; with it released this thread
    steps whenever the scheduler gives it a core (a CPU-share threshold failed under heavy load).
    An exception of call() is raised here, after the loop has stopped."""
    span, failed, done = [], [], threading.Event()

    def work():
        t0 = time.perf_counter()
        try:
            call()
        except BaseException as e:  # handed to the caller's thread below
            failed.append(e)
        finally:
            span.extend((t0, time.perf_counter()))
            done.set()

    worker = threading.Thread(target=work)
    stamps, n = [], 0
    worker.start()
    while not done.is_set():
        n += 1
        if n % 256 == 0:
            stamps.append(time.perf_counter())
    worker.join()
    if failed:
        raise failed[0]
    t0, t1 = span
    quarter = 0.25 * (t1 - t0)
    return sum(1 for t in stamps if t0 + quarter < t < t1 - quarter), t1 - t0
