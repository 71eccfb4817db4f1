#!/usr/bin/env python3
"""Independent generator of the FRI 1.x pattern datagrams of fri-1x-protocol.md §7.

Packs the measurement (916 B) and command (376 B) pattern datagrams with Python's `struct`
from the spec's offset tables, checks the spec's byte excerpts, SHA-256 and CRC-32, and writes
them to fri/tests/fixtures/. It shares no code with the Rust codec; the Rust tests compare the
codec against these files. Run from the repository root: python3 tools/fri_golden_datagrams.py
"""
import hashlib
import pathlib
import struct
import zlib

# (name, number of f32) in table order; the pattern value of element e of field k is 100*k + 0.25*e.
MSR_FLOATS = [("realData", 16), ("timestamp", 1), ("desiredMsrSampleTime", 1),
              ("desiredCmdSampleTime", 1), ("safetyLimits", 1), ("answerRate", 1),
              ("latency", 1), ("jitter", 1), ("missRate", 1), ("temperature", 7),
              ("msrJntPos", 7), ("msrCartPos", 12), ("cmdJntPos", 7), ("cmdJntPosFriOffset", 7),
              ("cmdCartPos", 12), ("cmdCartPosFriOffset", 12), ("msrJntTrq", 7),
              ("estExtJntTrq", 7), ("estExtTcpFT", 6), ("jacobian", 42), ("massMatrix", 49),
              ("gravity", 7)]
CMD_FLOATS = [("realData", 16), ("jntPos", 7), ("cartPos", 12), ("addJntTrq", 7), ("addTcpFT", 6),
              ("jntStiffness", 7), ("jntDamping", 7), ("cartStiffness", 6), ("cartDamping", 6)]


def pattern(fields):
    """Dict name -> list of pattern floats."""
    return {name: [100.0 * k + 0.25 * e for e in range(n)]
            for k, (name, n) in enumerate(fields, start=1)}


def f32s(values):
    return struct.pack("<%df" % len(values), *values)


INT_DATA = [1000 * (e + 1) * (-1) ** e for e in range(16)]


def msr_datagram():
    v = pattern(MSR_FLOATS)
    b = b""
    b += struct.pack("<HHHH", 0x1234, 0x5678, 916, 0x2006)
    b += f32s(v["realData"]) + struct.pack("<16i", *INT_DATA) + struct.pack("<HH", 0xA5C3, 0)
    assert len(b) == 140
    b += f32s(v["timestamp"]) + struct.pack("<HH", 2, 3)
    for name in ["desiredMsrSampleTime", "desiredCmdSampleTime", "safetyLimits", "answerRate",
                 "latency", "jitter", "missRate"]:
        b += f32s(v[name])
    assert len(b) == 176
    b += struct.pack("<I", 0xDEADBEEF) + struct.pack("<HHHH", 0x007F, 3, 0x0011, 0x0022)
    assert len(b) == 188
    for name, _ in MSR_FLOATS[9:]:
        b += f32s(v[name])
    assert len(b) == 916
    return b


def cmd_datagram():
    v = pattern(CMD_FLOATS)
    b = struct.pack("<HHHH", 0x9ABC, 0x1234, 376, 0x1005)
    b += f32s(v["realData"]) + struct.pack("<16i", *INT_DATA) + struct.pack("<HH", 0x0001, 0)
    b += struct.pack("<I", 0x0035)
    assert len(b) == 144
    for name, _ in CMD_FLOATS[1:]:
        b += f32s(v[name])
    assert len(b) == 376
    return b


def check(b, excerpts, sha, crc):
    for off, hexbytes in excerpts:
        want = bytes.fromhex(hexbytes)
        assert b[off:off + len(want)] == want, (off, b[off:off + len(want)].hex(), hexbytes)
    assert hashlib.sha256(b).hexdigest() == sha, hashlib.sha256(b).hexdigest()
    assert "%08x" % zlib.crc32(b) == crc, "%08x" % zlib.crc32(b)


def main():
    msr = msr_datagram()
    check(msr, [(0, "3412785694030620"), (8, "0000C842"), (72, "E803000030F8FFFF"),
                (136, "C3A50000"), (140, "0000484302000300"), (176, "EFBEADDE7F00030011002200"),
                (912, "00980945")],
          "e578158753c026a15d70a95fac482483c493b443e3bb698272ac516870a60f73", "23cc8f68")
    cmd = cmd_datagram()
    check(cmd, [(0, "BC9A341278010510"), (140, "35000000"), (372, "00506144")],
          "5b4cef0ccc9754a0e08c15750e4715bde5d49e06e7946373481ac4211d0ed219", "fb7b2182")
    out = pathlib.Path(__file__).resolve().parent.parent / "fri" / "tests" / "fixtures"
    out.mkdir(parents=True, exist_ok=True)
    (out / "pattern_msr.bin").write_bytes(msr)
    (out / "pattern_cmd.bin").write_bytes(cmd)
    print("wrote", out / "pattern_msr.bin", out / "pattern_cmd.bin", "(hashes match the spec)")


if __name__ == "__main__":
    main()
