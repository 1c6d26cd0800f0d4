#!/usr/bin/python3
"""Checks a `candump -L` log against the repository's DBC (docs/mrd.dbc, docs/can_bus.md).

Every frame: a standard ID the DBC defines, the DBC's DLC, every signal decoded (Intel byte
order, signed or unsigned, factor and offset) within its DBC range; frames with a *Checksum
signal: CRC-8 SAE J1850 (poly 0x1D, init 0xFF, final xor 0xFF) over the ID's low byte, its
high byte and data bytes 0..DLC-2 equals the last byte; a *Counter signal (4 bit) advances by
exactly 1 per frame of its ID; FirmwareStatus's StatusSequence (8 bit) by 1; TimeGrant's
GrantTime never moves backwards (the harness repeats the first step's grant while the
firmware starts: counted as repeated_grants). Both directions must be present (frames sent by the Firmware
node and by the Sensors node, per the DBC's BO_ senders).

Usage: check_candump.py DBC CANDUMP_LOG [--json]
Exit 0: all frames valid; 1: a frame broke a rule (listed, at most 20); 2: bad input
("error: FILE:LINE: reason").
"""
import json
import re
import sys


def fail_input(path, line, reason):
    print(f"error: {path}:{line}: {reason}", file=sys.stderr)
    sys.exit(2)


def parse_dbc(path):
    messages = {}
    current = None
    bo = re.compile(r"^BO_ (\d+) (\w+): (\d+) (\w+)")
    sg = re.compile(r"^\s*SG_ (\w+) : (\d+)\|(\d+)@([01])([+-]) \(([^,]+),([^)]+)\) \[([^|]+)\|([^\]]+)\]")
    try:
        lines = open(path, encoding="utf-8").read().splitlines()
    except OSError as e:
        fail_input(path, 0, f"cannot read ({e.strerror})")
    for n, line in enumerate(lines, 1):
        m = bo.match(line)
        if m:
            current = {"id": int(m[1]), "name": m[2], "dlc": int(m[3]), "sender": m[4], "signals": []}
            messages[current["id"]] = current
            continue
        m = sg.match(line)
        if m:
            if current is None:
                fail_input(path, n, "SG_ before any BO_")
            if m[4] != "1":
                fail_input(path, n, f"signal {m[1]}: only Intel byte order (@1) is supported")
            current["signals"].append({
                "name": m[1], "start": int(m[2]), "length": int(m[3]), "signed": m[5] == "-",
                "factor": float(m[6]), "offset": float(m[7]), "min": float(m[8]), "max": float(m[9])})
    if not messages:
        fail_input(path, 1, "no BO_ message definitions")
    return messages


def crc8_j1850(data):
    crc = 0xFF
    for b in data:
        crc ^= b
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1D) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
    return crc ^ 0xFF


def raw_signal(data, sig):
    value = int.from_bytes(bytes(data), "little") >> sig["start"]
    value &= (1 << sig["length"]) - 1
    if sig["signed"] and value & (1 << (sig["length"] - 1)):
        value -= 1 << sig["length"]
    return value


def main():
    args = [a for a in sys.argv[1:] if a != "--json"]
    as_json = "--json" in sys.argv[1:]
    if len(args) != 2:
        print(__doc__.strip().splitlines()[-4], file=sys.stderr)
        sys.exit(2)
    dbc_path, log_path = args
    messages = parse_dbc(dbc_path)
    frame_re = re.compile(r"^\((\d+\.\d+)\) (\S+) ([0-9A-Fa-f]+)#([0-9A-Fa-f]*)$")
    try:
        lines = open(log_path, encoding="ascii", errors="replace").read().splitlines()
    except OSError as e:
        fail_input(log_path, 0, f"cannot read ({e.strerror})")
    counts = {}
    senders = {}
    last_counter = {}
    last_seq = None
    last_grant = None
    repeated_grants = 0
    errors = []

    def bad(n, why):
        errors.append(f"{log_path}:{n}: {why}")

    for n, line in enumerate(lines, 1):
        if not line.strip():
            continue
        m = frame_re.match(line.strip())
        if not m:
            fail_input(log_path, n, f"not a candump -L line: {line[:60]!r}")
        ident_text, data_text = m[3], m[4]
        if len(ident_text) != 3:
            bad(n, f"extended or malformed ID {ident_text}")
            continue
        ident = int(ident_text, 16)
        data = bytes.fromhex(data_text)
        msg = messages.get(ident)
        if msg is None:
            bad(n, f"ID 0x{ident:03X} not in the DBC")
            continue
        counts[msg["name"]] = counts.get(msg["name"], 0) + 1
        senders[msg["sender"]] = senders.get(msg["sender"], 0) + 1
        if len(data) != msg["dlc"]:
            bad(n, f"{msg['name']}: DLC {len(data)}, DBC says {msg['dlc']}")
            continue
        for sig in msg["signals"]:
            raw = raw_signal(data, sig)
            name = sig["name"]
            if name.endswith("Checksum"):
                want = crc8_j1850([ident & 0xFF, ident >> 8] + list(data[:-1]))
                if raw != want:
                    bad(n, f"{msg['name']}: checksum 0x{raw:02X}, CRC-8 gives 0x{want:02X}")
                continue
            if name.endswith("Counter") or name == "StatusSequence":
                prev = last_counter.get(name)
                modulo = 1 << sig["length"]
                if prev is not None and raw != (prev + 1) % modulo:
                    bad(n, f"{msg['name']}: {name} {raw} after {prev} (expected {(prev + 1) % modulo})")
                last_counter[name] = raw
                continue
            value = raw * sig["factor"] + sig["offset"]
            if value < sig["min"] - 1e-9 or value > sig["max"] + 1e-9:
                bad(n, f"{msg['name']}: {name} = {value} outside [{sig['min']}, {sig['max']}]")
            if name == "GrantTime":
                if last_grant is not None and raw < last_grant:
                    bad(n, f"TimeGrant: {raw} us before the previous grant's {last_grant} us")
                if last_grant is not None and raw == last_grant:
                    repeated_grants += 1
                last_grant = raw
    for node in ("Firmware", "Sensors"):
        if senders.get(node, 0) == 0:
            errors.append(f"{log_path}: no frame from the {node} node (one direction missing)")
    total = sum(counts.values())
    if total == 0:
        errors.append(f"{log_path}: no frames")
    summary = {"frames": total, "by_message": counts, "by_sender": senders,
               "repeated_grants": repeated_grants,
               "errors": len(errors), "first_errors": errors[:20], "ok": not errors}
    if as_json:
        print(json.dumps(summary, indent=1, sort_keys=True))
    else:
        print(f"check_candump: {total} frames, " +
              ", ".join(f"{k} {v}" for k, v in sorted(counts.items())) +
              f"; senders " + ", ".join(f"{k} {v}" for k, v in sorted(senders.items())) +
              f"; repeated grants {repeated_grants}; {len(errors)} errors")
        for e in errors[:20]:
            print(e, file=sys.stderr)
    sys.exit(0 if not errors else 1)


if __name__ == "__main__":
    main()
