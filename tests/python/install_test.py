#!/usr/bin/env python3
"""`cmake --install --component python` puts a working package under the prefix's
lib/python3.X/dist-packages (docs/python.md), importable without the build tree.

usage: install_test.py CMAKE BUILD_DIR
"""
import os
import subprocess
import sys
import sysconfig
import tempfile

cmake, build = sys.argv[1], sys.argv[2]
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
print("ok: installed package imports and runs")
