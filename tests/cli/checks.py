"""Shared by the CLI test scripts: named checks that print one line each and a closing
'N passed, N failed' line, and an exit code that fails the ctest entry on any failed check."""
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
