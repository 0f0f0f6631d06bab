"""Shared by the Python-package tests: the `imukit` command (argv[1]) for the comparisons with the
CLI, the shared data folder, a EuRoC CSV reader in plain NumPy, and a unittest runner that exits
non-zero on any failure (ctest reads the exit code)."""
import os
import subprocess
import sys
import unittest

import numpy as np

IMUKIT = sys.argv[1] if len(sys.argv) > 1 else os.environ.get("IMUKIT_CLI", "imukit")
DATA = os.environ.get("IMUKIT_DATA_DIR",
                      os.path.join(os.path.dirname(__file__), "..", "..", "..", "shared", "data"))


# Under ASan the tests preload the shared ASan runtime into python3; the command links its own
# (static) runtime and refuses to start with a second one, so it runs without the preload.
CLI_ENV = {k: v for k, v in os.environ.items() if k != "LD_PRELOAD"}


def run_cli(*args):
    r = subprocess.run([IMUKIT, *map(str, args)], capture_output=True, text=True, env=CLI_ENV)
    if r.returncode != 0:
        print(r.stdout, r.stderr)
    return r


def cli_error(*args):
    """The one error line the command prints, without its 'imukit: error: ' prefix."""
    r = subprocess.run([IMUKIT, *map(str, args)], capture_output=True, text=True, env=CLI_ENV)
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


def data_file(*parts):
    """A file of the shared data folder, or a skip (a failure under CI=true)."""
    path = os.path.join(DATA, *parts)
    if not os.path.exists(path):
        if os.environ.get("CI") == "true":
            raise AssertionError(f"shared data folder missing under CI: {path}")
        raise unittest.SkipTest(f"shared data folder missing (set IMUKIT_DATA_DIR): {path}")
    return path


def main():
    result = unittest.main(argv=[sys.argv[0], "-v"], exit=False).result
    sys.exit(0 if result.wasSuccessful() else 1)
