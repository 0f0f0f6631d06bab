"""End-to-end tests of imukit-protocol replays through the real binary (`devices --read`, `record`,
`info`), on streams made with the independent reference framing of docs/protocol.md section 8:
the defects found by review on 2026-11-26, each as it was reproduced.

run: pytest (tests/pytest.ini), $IMUKIT_CLI the command under test
"""
import os
import re
import socket
import struct
import subprocess

# docs/protocol.md section 8: the golden DeviceInfo (1 MHz clock, 100 Hz its first rate).
DEVICE_INFO = bytes.fromhex(
    "03 01 81 01 13 06 69 6d 75 6b 69 74 04 47 46 2d 31 02 34 32 01 02 03 04 40 42 0f 05 02 a0 86 01"
    " 04 40 42 0f 02 03 02 03 01 01 01 02 02 01 03 80 41 01 01 02 3a 01 01 02 43 01 05 80 3b 01 03 01"
    " 01 01 02 01 01 01 02 41 01 05 80 39 03 01 01 04 c8 41 01 01 01 02 43 01 07 80 3b e1 40 60 6a 00")


def crc32c(data):
    crc = 0xFFFFFFFF
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = (crc >> 1) ^ (0x82F63B78 if crc & 1 else 0)
    return crc ^ 0xFFFFFFFF


def cobs(data):
    out, run = bytearray(), bytearray()
    for byte in data + b"\x00":
        if byte == 0:
            out += bytes([len(run) + 1]) + run
            run = bytearray()
        else:
            run.append(byte)
            if len(run) == 254:
                out += b"\xff" + run
                run = bytearray()
    return bytes(out)


def frame(msg_type, seq, payload):
    body = struct.pack("<BBH", 1, msg_type, seq & 0xFFFF) + payload
    return cobs(body + struct.pack("<I", crc32c(body))) + b"\x00"


def blocks_of(blocks):
    """A SampleBlock of 8 samples (accel, gyro; at rest, z up) per (frame sequence, sample index), at
    100 Hz on the 1 MHz clock: first tick 10 000 per index."""
    sample = struct.pack("<6h", 0, 0, 2048, 0, 0, 0)
    return b"".join(frame(0x82, seq, struct.pack("<IIBB", index & 0xFFFFFFFF, (index * 10000) & 0xFFFFFFFF, 8, 3)
                          + sample * 8) for seq, index in blocks)


def stream(blocks):
    """DeviceInfo, then the SampleBlocks of blocks_of(blocks)."""
    return DEVICE_INFO + blocks_of(blocks)


def write(workdir, name, data):
    path = os.path.join(workdir, name)
    with open(path, "wb") as f:
        f.write(data)
    return path


def read(imukit, path):
    return subprocess.run([imukit, "devices", "--read", f"file:{path}?codec=imukit"], capture_output=True,
                          text=True)


def test_a_replay_keeps_a_gap_of_seconds_in_its_times(imukit, workdir):
    # Found in review: 50 blocks, 25 lost (2 s), 50 more; the record said "missing 200" and "1
    # restart(s) of the device clock", and the file was uniformly sampled: the samples after the
    # gap stamped 10 ms after those before it. Now one stretch of clock, and the gap is 2.01 s.
    for lost in (25, 100):
        path = write(workdir, f"gap{lost}.bin", stream([(k + 1, 8 * k) for k in range(50)]
                                                       + [(k + 1 + lost, 8 * (k + lost)) for k in range(50, 100)]))
        out = os.path.join(workdir, f"gap{lost}.mcap")
        r = subprocess.run([imukit, "record", f"file:{path}?codec=imukit", "-o", out], capture_output=True,
                           text=True)
        assert r.returncode == 0, r.stderr
        assert f"missing (counter gaps) {8 * lost}," in r.stdout and "restart" not in r.stdout, r.stdout
        r = subprocess.run([imukit, "info", out], capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
        assert f"max {(8 * lost + 1) * 10}.000000 ms" in r.stdout, r.stdout
        assert "NOT uniformly sampled: 1 gaps" in r.stdout, r.stdout
        assert f"metadata imukit.clock.gap{lost}_bin.segments = 1\n" in r.stdout, r.stdout
        span = re.search(r"800 samples over ([0-9.]+) s", r.stdout)
        assert span and float(span.group(1)) == 7.99 + 8 * lost * 0.01, r.stdout


def test_a_repeated_or_late_block_is_stale_not_a_restart(imukit, workdir):
    # Found in review: block 24 (frame 25, index 192) sent twice gave 408 samples, missing 0 and a
    # clock restart that moved every later time by 80 ms; block 22 again after block 24 gave
    # "counter resets 1, dropped 16". Now 400 samples, 8 stale, nothing dropped, one clock.
    first = [(k + 1, 8 * k) for k in range(25)]
    rest = [(k + 1, 8 * k) for k in range(25, 50)]
    for name, again in (("dup", (25, 192)), ("late", (23, 176))):
        path = write(workdir, f"{name}.bin", stream(first + [again] + rest))
        r = read(imukit, path)
        assert r.returncode == 0, r.stderr
        assert ": 400 samples\n  rate 100.000 Hz by the device clock\n" in r.stdout, r.stdout
        assert "samples decoded 400, dropped 0 (with a non-finite value 0), counter resets 0," in r.stdout, r.stdout
        assert "  stale samples 8 (" in r.stdout, r.stdout
        out = os.path.join(workdir, f"{name}.mcap")
        r = subprocess.run([imukit, "record", f"file:{path}?codec=imukit", "-o", out], capture_output=True,
                           text=True)
        assert r.returncode == 0 and "restart" not in r.stdout, r.stdout + r.stderr
        r = subprocess.run([imukit, "info", out], capture_output=True, text=True)
        assert "400 samples over 3.990 s" in r.stdout and "uniformly sampled: 0 gaps" in r.stdout, r.stdout
        assert f"metadata imukit.session.{name}_bin.samples_stale = 8\n" in r.stdout, r.stdout


def test_a_loss_of_more_than_2_31_ticks_keeps_the_rate(imukit, workdir):
    # Found in review (bigloss.bin): 10^6 samples lost at 100 Hz on a 1 MHz clock (10^4 s) read as
    # "rate 705.755 Hz by the device clock"; the dropped count was right.
    path = write(workdir, "bigloss.bin", stream([(k + 1, 8 * k) for k in range(50)]
                                                + [(51 + 125000 + k, 8 * (50 + 125000 + k)) for k in range(50)]))
    r = read(imukit, path)
    assert r.returncode == 0, r.stderr
    assert "  rate 100.000 Hz by the device clock\n" in r.stdout, r.stdout
    assert "samples decoded 800, dropped 1000000 (" in r.stdout, r.stdout


def test_a_read_that_decodes_no_sample_fails(imukit, workdir):
    # Found in review: garbage read as "0 samples", corrupt 1, exit 0, where `record` exits 3.
    path = write(workdir, "g.bin", b"garbage")
    r = read(imukit, path)
    assert r.returncode == 3, r.stdout + r.stderr
    assert ": 0 samples\n" in r.stdout and "corrupt 1," in r.stdout, r.stdout
    assert r.stderr == (f"imukit: error: devices: no samples from file:{path}?codec=imukit (see the counts "
                        "and the end above)\n"), r.stderr


def test_record_names_the_samples_before_the_start_and_the_stale_ones(imukit, workdir):
    # Found in review (2026-11-26): the record summary named neither the samples of an earlier
    # session's stream nor the stale ones (the metadata, `info` and `devices --read` did). A live
    # device on a socket: 2 blocks of its earlier stream, its DeviceInfo, the Ack of our Start
    # (GetDeviceInfo was frame 0, Stop 1, Configure 2, Start 3), then our 50 blocks with block 24
    # sent twice.
    ack = frame(0x85, 1, struct.pack("<BH", 0x03, 3))
    ours = [(k + 2, 8 * k) for k in range(25)] + [(26, 192)] + [(k + 2, 8 * k) for k in range(25, 50)]
    host, device = socket.socketpair()
    fd = host.fileno()
    with host, device:
        device.sendall(blocks_of([(100, 5000), (101, 5008)]) + DEVICE_INFO + ack + blocks_of(ours))
        device.shutdown(socket.SHUT_WR)  # the end of the stream; the host's commands still go in
        out = os.path.join(workdir, "live.mcap")
        r = subprocess.run([imukit, "record", f"fd:{fd}?codec=imukit", "-o", out], capture_output=True, text=True,
                           pass_fds=(fd,), timeout=60)
    assert r.returncode == 0, r.stdout + r.stderr
    assert f"{fd}: 400 samples at 100.000 Hz; missing (counter gaps) 0, lost as the codec counts them 0, " \
        in r.stdout, r.stdout
    assert "\n  samples before the stream's start 16 (not losses)\n" in r.stdout, r.stdout
    assert ("\n  stale samples 8 (frames repeated or delivered late: not handed out again, not losses)\n"
            in r.stdout), r.stdout
    assert "non-finite" not in r.stdout, r.stdout
