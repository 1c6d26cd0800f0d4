#!/usr/bin/env python3
"""Live telemetry over CAN (labels observe, fieldbus, profile): a lockstep `mrd-hil run` of the
quarter car (3 s, compiled-in table, mrd-native profile, status every period as the harness
configures it) with --can-log; every FirmwareTelemetry frame is decoded with docs/mrd.dbc
(parsed here, independently of the firmware's codec) and checked against the firmware's own
figures:
  - one frame per period, the sequence +1 mod 256;
  - CommandVoltage equals the same tick's DriverCommand VoltageSetpoint (mrd-native: volts);
  - the last frame's ModelForce, ForceDemand and CommandVoltage equal the firmware summary's
    last model force, force demand and command (within half a count);
  - the model force moves (a live signal, not a constant).

Usage: telemetry_can_test.py BIN_DIR SOURCE_DIR WORK_DIR
"""
import json
import os
import re
import shutil
import subprocess
import sys

BIN, SRC, WORK = sys.argv[1:4]
failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


def load_dbc(path):
    """{name: (id, {signal: (start, length, signed, scale, offset)})}, little-endian only."""
    msgs, cur = {}, None
    for line in open(path):
        m = re.match(r"BO_ (\d+) (\w+): (\d+)", line)
        if m:
            cur = msgs.setdefault(m.group(2), (int(m.group(1)), {}))
            continue
        m = re.match(r"\s+SG_ (\w+) : (\d+)\|(\d+)@1([+-]) \(([^,]+),([^)]+)\)", line)
        if m and cur is not None:
            cur[1][m.group(1)] = (int(m.group(2)), int(m.group(3)), m.group(4) == "-",
                                  float(m.group(5)), float(m.group(6)))
        elif not line.strip():
            cur = None
    return msgs


def decode(data, sig):
    start, length, signed, scale, offset = sig
    raw = (int.from_bytes(data, "little") >> start) & ((1 << length) - 1)
    if signed and raw >> (length - 1):
        raw -= 1 << length
    return raw * scale + offset


dbc = load_dbc(os.path.join(SRC, "docs/mrd.dbc"))
tel_id, tel = dbc["FirmwareTelemetry"]
cmd_id, cmd = dbc["DriverCommand"]
shutil.rmtree(WORK, ignore_errors=True)
os.makedirs(WORK)
log = os.path.join(WORK, "bus.log")
p = subprocess.run([os.path.join(BIN, "mrd-hil"), "run",
                    os.path.join(SRC, "hil/scenarios/quarter-car-skyhook.toml"),
                    "--set", "duration_s=3", "--set", "quarter_car.settle_s=1",
                    "--can-log", log, "--json"], capture_output=True, text=True, timeout=300)
# Exit 1 is a scored run that missed a criterion (3 s is short for the ride criterion).
check(p.returncode in (0, 1) and p.stdout.startswith("{"),
      f"the run ran (exit {p.returncode}) {p.stderr[-400:]}")
summary = json.loads(p.stdout)
fw = summary["firmware"]["summary"]

frames = []  # (t, id, data)
for line in open(log):
    m = re.match(r"\((\d+\.\d+)\) \S+ ([0-9A-Fa-f]+)#([0-9A-Fa-f]*)", line)
    if m:
        frames.append((float(m.group(1)), int(m.group(2), 16), bytes.fromhex(m.group(3))))
tele = [(t, d) for t, i, d in frames if i == tel_id]
# One per period, and one with the safe-state status the firmware sends when it stops (which
# the log has when it reached the bus before the harness closed it).
# Periods are the firmware's ticks (the harness's steps, or one more when the firmware ticked on
# the grant the harness sent as it ended).
ticks = fw["ticks"]
check(len(tele) in (ticks, ticks + 1) and ticks in (summary["steps"], summary["steps"] + 1),
      f"one FirmwareTelemetry frame per period ({len(tele)} for {ticks} ticks, "
      f"{summary['steps']} steps)")
stopped = len(tele) == ticks + 1
seq = [decode(d, tel["TelemetrySequence"]) for _, d in tele]
check(all((b - a) % 256 == 1 for a, b in zip(seq, seq[1:])), "the sequence counts +1 mod 256")

# Each telemetry frame's command is the DriverCommand the firmware sent just before it.
last_cmd, mismatches, pairs = None, 0, 0
for t, i, d in frames:
    if i == cmd_id:
        last_cmd = decode(d, cmd["VoltageSetpoint"])
    elif i == tel_id and last_cmd is not None:
        pairs += 1
        if abs(decode(d, tel["CommandVoltage"]) - last_cmd) > 0.0015:
            mismatches += 1
check(pairs >= len(tele) - 1 and mismatches == 0,
      f"CommandVoltage = the tick's DriverCommand set-point ({pairs} pairs, {mismatches} differ)")

# The summary's model force and demand are the last period's (the stop does not change them);
# its command is the safe command of the stop when that frame is in the log.
d_last = tele[-1][1]
checks = [("ModelForce", "model_force_n", 0.25), ("ForceDemand", "force_demand_n", 0.25)]
if stopped:
    checks.append(("CommandVoltage", "last_command_v", 0.0005))
for sig, key, half in checks:
    got, want = decode(d_last, tel[sig]), fw[key]
    check(abs(got - want) <= half + 1e-9, f"last {sig} {got} = the firmware's {key} {want}")
forces = [decode(d, tel["ModelForce"]) for _, d in tele]
check(max(forces) - min(forces) > 10.0, f"the model force moves ({min(forces)} .. {max(forces)} N)")
volts = [decode(d, tel["CommandVoltage"]) for _, d in tele]
check(max(volts) > 0.0, f"the command moves (max {max(volts)} V)")
print(f"{len(failures)} failure(s)")
sys.exit(1 if failures else 0)
