"""End-to-end tests of `imukit record` through the real binary: a recording cut by kill -9 reads
back to its last chunk; Ctrl-C (SIGINT) stops cleanly with a complete, refitted file; a
virtual-time recording has exactly the requested duration.

run: pytest (tests/pytest.ini), $IMUKIT_CLI the command under test
"""
import os
import re
import signal
import subprocess
import time


def samples_in(info_stdout):
    m = re.search(r": (\d+) samples over", info_stdout)
    return int(m.group(1)) if m else -1


def test_kill_9_keeps_the_last_chunk(imukit, workdir):
    """kill -9 in the middle of a real-time recording."""
    out = os.path.join(workdir, "crash.mcap")
    p = subprocess.Popen([imukit, "record", "mock:static?rate=1000&clock=real", "-o", out,
                          "--duration", "60"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    time.sleep(3.0)
    p.send_signal(signal.SIGKILL)
    p.wait()
    live = os.path.join(workdir, "crash.partial.mcap")
    assert os.path.exists(live), "the live file exists after kill -9"
    r = subprocess.run([imukit, "info", live], capture_output=True, text=True)
    n = samples_in(r.stdout)
    assert r.returncode == 0, f"info reads the killed recording (exit {r.returncode}: {r.stderr.strip()})"
    assert "the file ends at byte" in r.stderr, "with a note saying where the file ends"
    assert 1500 <= n <= 3000, f"and keeps the samples up to the last chunk ({n} of about 3000 sent)"
    fixed = os.path.join(workdir, "fixed.mcap")
    r = subprocess.run([imukit, "convert", "--recover", live, "-o", fixed], capture_output=True, text=True)
    assert r.returncode == 0, "convert --recover rewrites it"
    r = subprocess.run([imukit, "info", fixed], capture_output=True, text=True)
    assert samples_in(r.stdout) == n and "the file ends" not in r.stderr, "as a complete file with the same samples"


def test_ctrl_c_stops_cleanly(imukit, workdir):
    """Ctrl-C: clean stop, flushed, refitted, complete."""
    out = os.path.join(workdir, "sigint.mcap")
    p = subprocess.Popen([imukit, "record", "mock:static?rate=500&clock=real", "-o", out],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(2.0)
    p.send_signal(signal.SIGINT)
    stdout, stderr = p.communicate(timeout=30)
    assert p.returncode == 0, f"SIGINT ends the recording with exit 0 ({stderr.strip()})"
    assert "stopped by signal" in stdout, "and says it was stopped by the signal"
    assert os.path.exists(out) and not os.path.exists(os.path.join(workdir, "sigint.partial.mcap")), \
        "the final file replaces the live one"
    r = subprocess.run([imukit, "info", out], capture_output=True, text=True)
    assert r.returncode == 0 and "the file ends" not in r.stderr and samples_in(r.stdout) > 500, \
        f"the file is complete ({samples_in(r.stdout)} samples)"


def test_virtual_time_gives_the_exact_duration(imukit, workdir):
    """Virtual time: exactly the requested duration, faster than real time."""
    out = os.path.join(workdir, "virtual.mcap")
    start = time.monotonic()
    r = subprocess.run([imukit, "record", "mock:static?rate=200&clock=virtual", "-o", out,
                        "--duration", "30"], capture_output=True, text=True)
    elapsed = time.monotonic() - start
    assert r.returncode == 0, "a virtual-time recording succeeds"
    r = subprocess.run([imukit, "info", out], capture_output=True, text=True)
    n = samples_in(r.stdout)
    assert 6000 <= n <= 6001, f"30 s at 200 Hz gives 6000 samples ({n})"
    assert elapsed < 20, f"in less than real time ({elapsed:.1f} s)"


def test_unknown_uri_key_is_one_line(imukit, workdir):
    """Bad input: one line naming what is wrong."""
    r = subprocess.run([imukit, "record", "mock:static?rat=5", "-o", os.path.join(workdir, "x.mcap")],
                       capture_output=True, text=True)
    assert r.returncode != 0 and len(r.stderr.strip().splitlines()) == 1 and "rat" in r.stderr, \
        f"an unknown URI key is a one-line error ({r.stderr.strip()})"
