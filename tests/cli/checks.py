"""Shared by the CLI test scripts: named checks that print one line each and a closing
'N passed, N failed' line, and an exit code that fails the ctest entry on any failed check;
and a runner for the imukit binary under test."""
import os
import subprocess
import sys


class Checks:
    def __init__(self):
        self.passed = 0
        self.failed = 0

    def __call__(self, condition, what):
        if condition:
            self.passed += 1
        else:
            self.failed += 1
        print(f"{'ok:  ' if condition else 'FAIL:'} {what}")

    def finish(self):
        print(f"{self.passed} passed, {self.failed} failed")
        sys.exit(1 if self.failed else 0)


def imukit_runner(binary):
    """run(*args): `binary args...` with stdout and stderr captured as text; prints both when the
    command fails, so the log of a failed check shows why."""
    def run(*args):
        r = subprocess.run([binary, *args], capture_output=True, text=True)
        if r.returncode != 0:
            print(r.stdout, r.stderr)
        return r
    return run


def data_dir():
    """The shared recordings: $IMUKIT_DATA_DIR, else ../shared/data beside the checkout."""
    here = os.path.dirname(os.path.abspath(__file__))
    return os.environ.get("IMUKIT_DATA_DIR", os.path.join(here, "..", "..", "..", "shared", "data"))
