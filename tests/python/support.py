"""Shared by the Python-package tests: the `imukit` command for the comparisons with the CLI, the
shared data folder (both from tests/conftest.py, which pytest loads and puts on sys.path), and a
EuRoC CSV reader in plain NumPy."""
import subprocess

import numpy as np

from conftest import DATA_DIR as DATA, CLI_ENV, data_file, imukit_binary, run_imukit as run_cli  # noqa: F401


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
