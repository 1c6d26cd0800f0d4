#!/usr/bin/env python3
"""The mrd-native profile on the wire: a lockstep run's frames equal, frame for frame and tick
for tick, the frames captured from the firmware and harness built before device profiles
existed (tests/data/profiles/mrd-native-frames.log.gz, candump -L, from `mrd-hil run
tests/data/profiles/mrd-native-frames.toml --can-log` of that build).

Three differences are expected and checked, nothing else is allowed:
- the firmware now sends its live telemetry, FirmwareTelemetry (0x301), right after each
  FirmwareStatus (0x300): exactly one per FirmwareStatus, taken out before comparing;
- the harness now plays the driver's DriverStatus (0x180, every 100 ms), which the old harness
  did not send: those frames are taken out before comparing;
- after the last captured frame, at the run's final time, the firmware's last tick's command and
  its safe-state shutdown frames (0x080, 0x300), which the old harness stopped listening for.

Usage: native_frames_test.py MRD_HIL SOURCE_DIR [PROFILE]
  PROFILE: run with --profile PROFILE (default: the built-in mrd-native).
"""
import gzip
import os
import subprocess
import sys
import tempfile

DRIVER_STATUS = "180"
FIRMWARE_STATUS = "300"
TELEMETRY = "301"
FIRMWARE_IDS = {"080", "081", FIRMWARE_STATUS, TELEMETRY}  # what mrd-firmware sends
SHUTDOWN_IDS = {"080", "300"}


def frame_id(line):
    return line.split()[2].split("#")[0]


def frames(lines):
    return [l for l in lines if frame_id(l) not in (DRIVER_STATUS, TELEMETRY)]


def telemetry_follows_status(lines):
    """Each FirmwareStatus is followed by one FirmwareTelemetry: the firmware's next frame (the
    harness's frames of the next tick may come between them on the bus)."""
    fw = [l for l in lines if frame_id(l) in FIRMWARE_IDS]
    for i, line in enumerate(fw):
        if frame_id(line) == FIRMWARE_STATUS:
            if i + 1 >= len(fw) or frame_id(fw[i + 1]) != TELEMETRY:
                return f"no FirmwareTelemetry right after {line}"
        if frame_id(line) == TELEMETRY and (i == 0 or frame_id(fw[i - 1]) != FIRMWARE_STATUS):
            return f"FirmwareTelemetry without its FirmwareStatus: {line}"
    return None


def main():
    hil, source = sys.argv[1], sys.argv[2]
    profile = sys.argv[3] if len(sys.argv) > 3 else None
    data = os.path.join(source, "tests", "data", "profiles")
    with gzip.open(os.path.join(data, "mrd-native-frames.log.gz"), "rt") as f:
        golden = f.read().splitlines()
    with tempfile.TemporaryDirectory() as tmp:
        log = os.path.join(tmp, "frames.log")
        # The table the capture ran on (the compiled-in table of that build, written by its
        # `mrd-firmware --write-table`): the compiled-in table is now the paper run's model.
        cmd = [hil, "run", os.path.join(data, "mrd-native-frames.toml"), "--can-log", log,
               "--table", os.path.join(data, "mrd-native-frames.table.bin"),
               "--out", os.path.join(tmp, "run")]
        if profile:
            cmd += ["--profile", profile]
        run = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
        if run.returncode != 0:
            print("mrd-hil failed:", run.returncode, run.stdout[-2000:], run.stderr[-2000:])
            return 1
        with open(log) as f:
            got = f.read().splitlines()
    ours = frames(got)
    why = telemetry_follows_status(got)
    if why:
        print(why)
        return 1
    for i, (want, have) in enumerate(zip(golden, ours)):
        if want != have:
            print(f"frame {i + 1} differs:\n  before profiles: {want}\n  now:             {have}")
            return 1
    if len(ours) < len(golden):
        print(f"run ended after {len(ours)} of the {len(golden)} captured frames")
        return 1
    if not [l for l in got if frame_id(l) == DRIVER_STATUS]:
        print("no DriverStatus frames from the harness: the capture is not what this test expects")
        return 1
    last_t = golden[-1].split()[0]
    extra = ours[len(golden):]
    for line in extra:
        t, _, frame = line.split()
        if t != last_t or frame.split("#")[0] not in SHUTDOWN_IDS:
            print(f"unexpected frame after the captured ones: {line}")
            return 1
    n_status = len([l for l in got if frame_id(l) == DRIVER_STATUS])
    n_tel = len([l for l in got if frame_id(l) == TELEMETRY])
    print(f"{len(golden)} frames identical to the capture ({n_status} DriverStatus frames from "
          f"the harness and {n_tel} FirmwareTelemetry frames, one after each FirmwareStatus, "
          f"left out; {len(extra)} final shutdown frames after it)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
