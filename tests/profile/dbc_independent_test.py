#!/usr/bin/env python3
"""A DBC decoder written here from the format's description alone (not the project's code),
compared with the project's parser and codec (dbc_decode_tool) on random payloads of every
message of a DBC: the native docs/mrd.dbc and a driver DBC written by hand with Motorola and
Intel signals, offsets, signed values and an extended id.

Usage: dbc_independent_test.py DECODE_TOOL SOURCE_DIR
"""
import math
import random
import re
import subprocess
import sys
import tempfile

SG = re.compile(r'^\s*SG_\s+(\w+)\s*:\s*(\d+)\|(\d+)@([01])([+-])\s*\(([^,]+),([^)]+)\)\s*'
                r'\[([^|]+)\|([^\]]+)\]\s*"[^"]*"')
BO = re.compile(r'^BO_\s+(\d+)\s+(\w+)\s*:\s*(\d+)')

HAND_DBC = '''VERSION ""
NS_ :
\tCM_
BS_:
BU_: Ctrl Drive
BO_ 2566834709 DriveStatus: 8 Drive
 SG_ Current : 7|12@0+ (0.01,0) [0|40.95] "A" Ctrl
 SG_ Temperature : 11|8@0- (0.5,-20) [-84|43.5] "degC" Ctrl
 SG_ Faults : 32|8@1+ (1,0) [0|255] "" Ctrl
 SG_ Wide : 47|16@0- (0.25,10) [0|0] "" Ctrl
 SG_ Counter : 56|4@1+ (1,0) [0|15] "" Ctrl
BO_ 512 DriveCommand: 8 Ctrl
 SG_ CurrentSetpoint : 0|16@1- (0.001,0.5) [-32|32] "A" Drive
 SG_ Enable : 23|1@0+ (1,0) [0|1] "" Drive
 SG_ Odd : 17|5@1- (3,-1) [0|0] "" Drive
 SG_ Long : 24|40@1+ (1,0) [0|0] "" Drive
CM_ BO_ 512 "two
lines";
BA_ "GenMsgCycleTime" BO_ 512 2;
'''


def parse(text):
    """{message: [(signal, start, length, motorola, signed, factor, offset)]}"""
    msgs, cur = {}, None
    for line in text.splitlines():
        m = BO.match(line)
        if m:
            cur = m.group(2)
            msgs[cur] = []
            continue
        s = SG.match(line)
        if s and cur:
            msgs[cur].append((s.group(1), int(s.group(2)), int(s.group(3)), s.group(4) == '0',
                              s.group(5) == '-', float(s.group(6)), float(s.group(7))))
    return msgs


def decode(payload, start, length, motorola, signed, factor, offset):
    """Physical value: Intel as a little-endian integer shifted by start; Motorola as a
    big-endian integer of the 8 bytes where the MSB sits at the sawtooth position start."""
    if motorola:
        big = int.from_bytes(payload, 'big')
        msb_pos = (7 - start // 8) * 8 + (start % 8)  # position of the MSB counted from the LSB end
        raw = (big >> (msb_pos - length + 1)) & ((1 << length) - 1)
    else:
        raw = (int.from_bytes(payload, 'little') >> start) & ((1 << length) - 1)
    if signed and raw >> (length - 1):
        raw -= 1 << length
    return raw * factor + offset


def main():
    tool, src = sys.argv[1], sys.argv[2]
    with open(f"{src}/docs/mrd.dbc") as f:
        native = f.read()
    rng = random.Random(20261125)
    failures = 0
    for name, text in (("mrd.dbc", native), ("hand-written driver.dbc", HAND_DBC)):
        msgs = parse(text)
        with tempfile.NamedTemporaryFile("w", suffix=".dbc", delete=False) as f:
            f.write(text)
            path = f.name
        payloads = [(m, bytes(rng.randrange(256) for _ in range(8))) for m in msgs
                    for _ in range(200)]
        out = subprocess.run([tool, path], input="".join(f"{m} {p.hex()}\n" for m, p in payloads),
                             capture_output=True, text=True, check=False)
        if out.returncode != 0:
            print(f"{name}: the project's decoder refused it: {out.stdout}{out.stderr}")
            return 1
        got = iter(out.stdout.splitlines())
        compared = 0
        for m, p in payloads:
            for sig in msgs[m]:
                key, value = next(got).split()
                want = decode(p, *sig[1:])
                if key != f"{m}.{sig[0]}" or not math.isclose(float(value), want, rel_tol=1e-12,
                                                            abs_tol=1e-9):
                    failures += 1
                    if failures <= 10:
                        print(f"{name}: {m} {p.hex()} {key}: project {value}, independent {want}")
                compared += 1
        print(f"{name}: {len(msgs)} messages, {compared} signal values compared")
    print("dbc_independent_test: " + ("identical" if failures == 0 else f"{failures} differ"))
    return 0 if failures == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
