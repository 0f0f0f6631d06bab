"""Crash safety of recordings through the real binary (issue 16, items 9 and 10):
- a --no-refit recording (the online clock map) converts and characterizes;
- `imukit record` killed with SIGKILL at several moments: the live file, `convert --recover`,
  `convert` and `characterize` all succeed, and each keeps exactly the samples of the complete
  chunks, counted here by an MCAP walker of this file's own (with zlib's CRC-32 and the zstd
  command), not by imukit;
- a closed recording damaged in a message index, a chunk header or a Channel record: plain
  reading fails with an error naming the file, recovery keeps every intact chunk.

run: pytest (tests/pytest.ini), $IMUKIT_CLI the command under test
"""
import json
import os
import signal
import subprocess
import time
import zlib
from types import SimpleNamespace

import numpy as np
import pytest

from conftest import imukit_binary, run_imukit as run

HERE = os.path.dirname(os.path.abspath(__file__))
PROFILE = os.path.join(HERE, "..", "..", "examples", "profiles", "wrist_watch_imu.json")
TOPIC = "/imu/mock_static"


def u64(b, at):
    return int.from_bytes(b[at:at + 8], "little")


def u32(b, at):
    return int.from_bytes(b[at:at + 4], "little")


def walk(path):
    """The complete top-level records of an MCAP file: (opcode, offset, body), stopping where the
    file is cut or at Data End."""
    data = open(path, "rb").read()
    pos, out = 8, []
    while pos + 9 <= len(data):
        op, n = data[pos], u64(data, pos + 1)
        if pos + 9 + n > len(data):
            break
        out.append((op, pos, data[pos + 9:pos + 9 + n]))
        if op == 0x0F:
            break
        pos += 9 + n
    return out


def topic_messages_per_chunk(path, topic):
    """Per complete chunk of an MCAP file, in file order: the bodies of its Message records on
    `topic`, or None for a chunk whose records fail their CRC-32."""
    channel, chunks = None, []
    for op, _, body in walk(path):
        if op == 0x04:  # Channel: id 2, schema id 2, topic (length-prefixed)
            n = u32(body, 4)
            if body[8:8 + n].decode(errors="replace") == topic:
                channel = int.from_bytes(body[0:2], "little")
        if op != 0x06:
            continue
        size, crc, clen = u64(body, 16), u32(body, 24), u32(body, 28)
        compression = body[32:32 + clen]
        rlen = u64(body, 32 + clen) if 40 + clen <= len(body) else 0
        records_bytes = body[40 + clen:40 + clen + rlen]
        if compression == b"zstd":
            z = subprocess.run(["zstd", "-d", "-c", "-q"], input=records_bytes, capture_output=True)
            plain = z.stdout if z.returncode == 0 else b""
        else:
            plain = records_bytes
        if len(plain) != size or zlib.crc32(plain) != crc:
            chunks.append(None)
            continue
        messages, at = [], 0
        while at + 9 <= len(plain):
            rop, rn = plain[at], u64(plain, at + 1)
            rec = plain[at + 9:at + 9 + rn]
            if rop == 0x05 and int.from_bytes(rec[0:2], "little") == channel:
                messages.append(rec)
            at += 9 + rn
        chunks.append(messages)
    return chunks


def chunk_counts(path, topic=TOPIC):
    """Messages of `topic` in each complete chunk whose records pass their CRC-32 (None for a chunk
    that does not), in file order."""
    return [None if m is None else len(m) for m in topic_messages_per_chunk(path, topic)]


def kept(path):
    return sum(c for c in chunk_counts(path) if c is not None)


def info_samples(path):
    r = subprocess.run([imukit_binary(), "info", path], capture_output=True, text=True)
    for line in r.stdout.splitlines():
        if ": " in line and " samples over " in line:
            return int(line.split(": ", 1)[1].split()[0]), r
    return (0 if r.returncode == 0 else -1), r


def csv_times(path):
    rows = np.loadtxt(path, delimiter=",", comments="#", ndmin=2)
    return rows[:, 0].astype(np.int64) if rows.size else np.zeros(0, dtype=np.int64)


def gyro_density_ok(profile_json, what):
    got = json.load(open(profile_json))["gyroscope"]["noise"]["noise_density"]
    want = json.load(open(PROFILE))["gyroscope"]["noise"]["noise_density"]
    worst = max(abs(g / w - 1) for g, w in zip(got, want))
    assert worst < 0.15, f"{what}: gyroscope noise density within 15 % of the mock's profile " \
                         f"(worst {worst * 100:.1f} %)"


def test_no_refit_recording_converts_and_characterizes(workdir):
    """The issue's repro: a --no-refit recording carries the online clock map's times."""
    tmp = workdir
    out = os.path.join(tmp, "n.mcap")
    r = run("record", f"mock:static?rate=1000&clock=virtual&profile={PROFILE}", "-o", out,
            "--duration", "5", "--no-refit")
    assert r.returncode == 0, "record --no-refit succeeds"
    csv = os.path.join(tmp, "n.csv")
    r = run("convert", out, "-o", csv)
    assert r.returncode == 0, f"convert reads the --no-refit recording ({r.stderr.strip()})"
    t = csv_times(csv)
    assert len(t) == kept(out) and len(t) > 4900, f"with every sample ({len(t)} rows, {kept(out)} in the file's chunks)"
    steps = np.diff(t)
    assert len(steps) > 0 and steps.min() >= 0, "and times that never go back"
    # Each interval within 10 % of the device's 1 ms, the slew's bound.
    assert len(steps) > 0 and 0.9e6 - 1e3 <= steps.min() and steps.max() <= 1.1e6 + 1e3, \
        f"each interval within 10 % of 1 ms ({steps.min() / 1e3:.1f}..{steps.max() / 1e3:.1f} us)"
    profile = os.path.join(tmp, "n.json")
    r = run("characterize", out, "-o", profile)
    assert r.returncode == 0, "characterize reads it"
    gyro_density_ok(profile, "--no-refit")


DELAYS = (0.2, 1.5, 3.0)


@pytest.fixture(scope="module")
def killed_recordings(imukit, workdir):
    """`imukit record` of a real-time 1 kHz mock killed with SIGKILL after each delay: {delay: (the
    final file's path, the live file's path)}."""
    files = {}
    for delay in DELAYS:
        out = os.path.join(workdir, f"k{delay}.mcap")
        live = os.path.join(workdir, f"k{delay}.partial.mcap")
        p = subprocess.Popen([imukit, "record", f"mock:static?rate=1000&clock=real&profile={PROFILE}",
                              "-o", out, "--duration", "60"],
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(delay)
        p.send_signal(signal.SIGKILL)
        p.wait()
        files[delay] = out, live
    return files


@pytest.mark.parametrize("delay", DELAYS)
def test_killed_recording_reads_converts_and_recovers(workdir, killed_recordings, delay):
    tmp = workdir
    out, live = killed_recordings[delay]
    what = f"kill -9 after {delay} s"
    assert os.path.exists(live) and not os.path.exists(out), f"{what}: the live file is left"
    n = kept(live)
    # At most what 1 kHz gives in the time, at least all but the chunk being filled (250 ms)
    # and the start-up (generous: sanitizer builds start slowly).
    assert n <= 1000 * delay + 20 and (delay < 1 or n >= 1000 * (delay - 1.0)), \
        f"{what}: {n} samples in complete chunks"
    count, r = info_samples(live)
    assert r.returncode == 0 and count == n, f"{what}: info reads {count} samples"
    direct = os.path.join(tmp, f"k{delay}_direct.csv")
    r = run("convert", live, "-o", direct)
    assert r.returncode == 0 and len(csv_times(direct)) == n, \
        f"{what}: convert reads the live file as it is (online times)"
    fixed = os.path.join(tmp, f"k{delay}_fixed.mcap")
    r = run("convert", "--recover", live, "-o", fixed)
    assert r.returncode == 0, f"{what}: convert --recover succeeds"
    assert n == 0 or "clock refitted" in r.stdout, f"{what}: and refits the clock"
    count, r = info_samples(fixed)
    assert count == n and "the file ends" not in r.stderr and kept(fixed) == n, \
        f"{what}: the recovered file is complete, with the same {count} samples"
    fixed_csv = os.path.join(tmp, f"k{delay}_fixed.csv")
    r = run("convert", fixed, "-o", fixed_csv)
    t = csv_times(fixed_csv) if r.returncode == 0 else np.zeros(0, dtype=np.int64)
    assert r.returncode == 0 and len(t) == n and (n < 2 or np.diff(t).min() >= 0), \
        f"{what}: convert writes {len(t)} rows, times never going back"
    if delay >= 1.5:
        profile = os.path.join(tmp, f"k{delay}.json")
        r = run("characterize", fixed, "-o", profile)
        assert r.returncode == 0, f"{what}: characterize reads the recovered file"
        gyro_density_ok(profile, what)


def test_a_longer_run_keeps_no_fewer_samples(killed_recordings):
    previous = -1
    for delay in DELAYS:
        live = killed_recordings[delay][1]
        if not os.path.exists(live):
            continue
        n = kept(live)
        assert n >= previous, f"kill -9 after {delay} s: no fewer than after a shorter run ({previous})"
        previous = n


@pytest.fixture(scope="module")
def closed_recording(workdir):
    """A closed 3 s recording to damage, and what this file's own MCAP walker finds in it."""
    good = os.path.join(workdir, "good.mcap")
    r = run("record", "mock:static?rate=1000&clock=virtual", "-o", good, "--duration", "3")
    assert r.returncode == 0, "a 3 s recording to damage"
    records = walk(good)
    per_chunk = chunk_counts(good)
    chunks = [(pos, body) for op, pos, body in records if op == 0x06]
    return SimpleNamespace(data=open(good, "rb").read(), records=records, per_chunk=per_chunk,
                           total=sum(per_chunk), chunks=chunks)


def test_closed_recording_has_chunks_to_damage(closed_recording):
    c = closed_recording
    assert len(c.chunks) >= 4 and c.total > 2900, f"{len(c.chunks)} chunks, {c.total} samples"


@pytest.mark.parametrize("case", ["index", "chunk", "channel"])
def test_damaged_recording(workdir, closed_recording, case):
    """A closed recording damaged on disk: plain reading refuses it naming the file; recovery keeps
    every intact chunk."""
    tmp, c = workdir, closed_recording
    total, per_chunk, chunks, records = c.total, c.per_chunk, c.chunks, c.records
    if case == "index":
        index = next(pos for op, pos, _ in records if op == 0x07)
        what, at, xor, error, expected = ("a message index", index + 9 + 6 + 3, 0x40, "data section CRC-32", total)
    elif case == "chunk":
        what, at, xor, error, expected = ("the compression of chunk 3", chunks[2][0] + 9 + 30, 0x01,
                                          "needs 65540 bytes", total - per_chunk[2])
    else:
        channel = next(pos for op, pos, body in records
                       if op == 0x04 and body[8:8 + u32(body, 4)] == TOPIC.encode())
        what, at, xor, error, expected = ("the IMU Channel record's opcode", channel, 0xFF, "", total)
    os.makedirs(os.path.join(tmp, case))
    damaged = os.path.join(tmp, case, "damaged.mcap")
    bad = bytearray(c.data)
    bad[at] ^= xor
    open(damaged, "wb").write(bad)
    r = subprocess.run([imukit_binary(), "convert", damaged, "-o", os.path.join(tmp, case, "d.csv")],
                       capture_output=True, text=True)
    if error:
        assert r.returncode != 0 and error in r.stderr and damaged in r.stderr, \
            f"{what} damaged: plain convert fails naming the file ({r.stderr.strip()})"
    fixed = os.path.join(tmp, case, "damaged_fixed.mcap")
    r = run("convert", "--recover", damaged, "-o", fixed)
    count, _ = info_samples(fixed)
    assert r.returncode == 0 and "damaged:" in r.stdout and count == expected, \
        f"{what} damaged: recovery keeps {count} of {total} samples (expected {expected})"


def raw_sample_indices(path, topic=TOPIC + "/raw"):
    """sample_index of every RawImu message of `topic` in the complete, intact chunks of an MCAP
    file, in file order (CDR: 4-byte header, stamp 8, host_receive_time_ns 8, then the index)."""
    return [u64(rec, 22 + 4 + 16)  # after channel 2, sequence 4, two times 16
            for messages in topic_messages_per_chunk(path, topic) if messages is not None
            for rec in messages]


def test_recovery_after_kill_9_reports_the_samples_missing_by_index(imukit, workdir):
    """Found in review: after kill -9 every loss count was gone (they are written at close) and
    `convert --recover` rebuilt none: `info` showed no dropped count though sample_index showed 312
    missing. The recovered file now has, per device, the samples kept and those missing by
    sample_index gaps (equal to the gaps of the recovered file's own raw messages, counted here),
    and says the other counts were lost with the crash."""
    out = os.path.join(workdir, "kd.mcap")
    live = os.path.join(workdir, "kd.partial.mcap")
    p = subprocess.Popen([imukit, "record", "mock:static?rate=1000&drop=0.1&seed=4", "-o", out],
                         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL)
    time.sleep(3.0)
    p.send_signal(signal.SIGKILL)
    p.wait()
    fixed = os.path.join(workdir, "kd_rec.mcap")
    r = run("convert", "--recover", live, "-o", fixed)
    assert r.returncode == 0, r.stderr
    index = raw_sample_indices(fixed)
    missing = sum(b - a - 1 for a, b in zip(index, index[1:]) if b > a)
    assert len(index) > 1000 and missing > 0, (len(index), missing)
    assert (f"mock_static: {len(index)} samples kept, {missing} missing by sample_index gaps; the "
            "codec's, corrupt-frame and recorder loss counts were lost with the crash") in r.stdout, r.stdout
    r = run("info", fixed)
    assert r.returncode == 0, r.stderr
    assert f"metadata imukit.session.mock_static.samples = {len(index)}\n" in r.stdout, r.stdout
    assert f"metadata imukit.session.mock_static.samples_dropped = {missing}\n" in r.stdout, r.stdout
    for key in ("codec_samples_dropped", "frames_corrupt", "backpressure_dropped"):
        assert f"metadata imukit.session.mock_static.{key} = unknown: lost with the crash\n" in r.stdout, r.stdout
