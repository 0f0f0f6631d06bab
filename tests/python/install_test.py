"""`cmake --install --component python` puts a working package under the prefix's
lib/python3.X/dist-packages (docs/python.md), importable without the build tree.

run: pytest (tests/pytest.ini); $IMUKIT_CMAKE the cmake command, $IMUKIT_BUILD_DIR the build folder
"""
import os
import subprocess
import sys
import sysconfig
import tempfile

import pytest


def test_installed_package_imports_and_runs():
    cmake, build = os.environ.get("IMUKIT_CMAKE"), os.environ.get("IMUKIT_BUILD_DIR")
    if not cmake or not build:
        pytest.fail("set IMUKIT_CMAKE (the cmake command) and IMUKIT_BUILD_DIR (the build folder)", pytrace=False)
    with tempfile.TemporaryDirectory() as prefix:
        r = subprocess.run([cmake, "--install", build, "--prefix", prefix, "--component", "python"],
                           capture_output=True, text=True)
        print(r.stdout, r.stderr)
        assert r.returncode == 0, "cmake --install failed"
        version = sysconfig.get_python_version()
        site = os.path.join(prefix, "lib", f"python{version}", "dist-packages")
        files = sorted(os.listdir(os.path.join(site, "imukit")))
        print("installed:", files)
        assert "__init__.py" in files and any(f.startswith("_imukit.") and f.endswith(".so") for f in files), files
        env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
        env["PYTHONPATH"] = site
        code = ("import imukit, numpy as np; assert imukit.__file__.startswith(%r), imukit.__file__; "
                "print(len(imukit.read_policy('imukit')), imukit.window_starts(10, 4, 3).tolist())" % site)
        r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=prefix)
        print(r.stdout, r.stderr)
        assert r.returncode == 0 and r.stdout.split() == ["810", "[0,", "3,", "6]"], r.stdout
