#!/usr/bin/python3
"""CAN wire conformance from the documents alone (docs/mrd.dbc, docs/can_bus.md).

The decoder is the test's own: toolchain/vboard/check_candump.py's DBC parser, CRC-8 and
signal extraction (Python, written from the DBC; it shares nothing with the project's C++
codec), fed with frames a test node (mrd_can_node capture) recorded on the local frame bus.

  frames       mrd-firmware against `mrd-hil serve` (real time, on a stand-alone mrd-canbus
               relay, a driver fault injected with --fault-line) and against `mrd-hil run`
               (lockstep): every frame of the DBC seen and decoded (ID, DLC, CRC, counter
               sequence per ID, ranges), the periods, the scaling (decoded signals against the
               harness's trace), and the driver fault in DriverStatus turning into the safe
               state (FirmwareStatus cause fault_line, safe commands).
  stall-flood  mrd-firmware against `mrd-hil run --clock realtime` with the firmware stopped
               for --stall-ms twice (SIGSTOP/SIGCONT) and a babbling node at --babble-rate
               frames/ms (sensor IDs, bad checksums) meanwhile: no driving command (SafeState
               0) may leave on a SensorMotion sample older than max_age_ms (the command's
               EchoSeq names the sample; both stamps are the relay's bus stamps), and the
               firmware must enter the safe state instead.
Prints a JSON summary; exit 0 when every check holds, 1 when one fails (listed), 2 on bad use.
"""
import argparse
import csv
import importlib.util
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time

MAX_AGE_MS = 5.0


def load_decoder(source):
    path = os.path.join(source, "toolchain", "vboard", "check_candump.py")
    spec = importlib.util.spec_from_file_location("check_candump", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


class Decoder:
    """Decodes candump -L lines per the DBC; collects every rule a frame breaks."""

    def __init__(self, dbc_module, dbc_path):
        self.m = dbc_module
        self.messages = self.m.parse_dbc(dbc_path)
        self.by_name = {msg["name"]: ident for ident, msg in self.messages.items()}
        self.errors = []

    def decode_log(self, path, keep_invalid=False):
        """[(t_s, ident, name, {signal: value}, valid)] in log order."""
        frames = []
        with open(path, encoding="ascii") as f:
            for n, line in enumerate(f, 1):
                line = line.strip()
                if not line:
                    continue
                stamp, _, rest = line.partition(" ")
                _, _, frame = rest.partition(" ")
                ident_text, _, data_text = frame.partition("#")
                t = float(stamp.strip("()"))
                ident = int(ident_text, 16)
                data = bytes.fromhex(data_text)
                decoded, why = self.decode(ident, data)
                if why and not keep_invalid:
                    self.errors.append(f"{path}:{n}: {why}")
                    continue
                name = self.messages[ident]["name"] if ident in self.messages else None
                frames.append((t, ident, name, decoded, why is None))
        return frames

    def decode(self, ident, data):
        msg = self.messages.get(ident)
        if msg is None:
            return None, f"ID 0x{ident:03X} not in the DBC"
        if len(data) != msg["dlc"]:
            return None, f"{msg['name']}: DLC {len(data)}, DBC says {msg['dlc']}"
        values = {}
        for sig in msg["signals"]:
            raw = self.m.raw_signal(data, sig)
            if sig["name"].endswith("Checksum"):
                want = self.m.crc8_j1850([ident & 0xFF, ident >> 8] + list(data[:-1]))
                if raw != want:
                    return None, f"{msg['name']}: checksum 0x{raw:02X}, CRC-8 gives 0x{want:02X}"
                continue
            value = raw * sig["factor"] + sig["offset"]
            if value < sig["min"] - 1e-9 or value > sig["max"] + 1e-9:
                return None, f"{msg['name']}: {sig['name']} = {value} outside [{sig['min']}, {sig['max']}]"
            values[sig["name"]] = value
        return values, None


def check_counters(frames, errors, what):
    """Every *Counter advances by exactly 1 mod 16 per frame of its ID, StatusSequence by 1."""
    last = {}
    for t, ident, name, values, _ in frames:
        for sig, value in values.items():
            if not (sig.endswith("Counter") or sig == "StatusSequence"):
                continue
            modulo = 256 if sig == "StatusSequence" else 16
            prev = last.get(sig)
            if prev is not None and int(value) != (prev + 1) % modulo:
                errors.append(f"{what}: {name} {sig} {int(value)} after {prev} at {t:.6f}")
            last[sig] = int(value)


def median_period_ms(frames, name):
    times = [t for t, _, n, _, _ in frames if n == name]
    gaps = sorted(b - a for a, b in zip(times, times[1:]))
    return 1e3 * gaps[len(gaps) // 2] if gaps else None


class Procs:
    """Children killed at exit, whatever happens."""

    def __init__(self):
        self.all = []

    def start(self, argv, out, err=None):
        p = subprocess.Popen(argv, stdout=open(out, "w"), stderr=open(err or out + ".err", "w"),
                             stdin=subprocess.DEVNULL)
        self.all.append(p)
        return p

    def close(self):
        for p in self.all:
            if p.poll() is None:
                p.kill()
                p.wait()


def wait_path(path, timeout_s):
    until = time.monotonic() + timeout_s
    while not os.path.exists(path):
        if time.monotonic() > until:
            raise RuntimeError(f"{path} did not appear within {timeout_s} s")
        time.sleep(0.005)


def read_json(path):
    with open(path) as f:
        text = f.read()
    try:
        return json.loads(text)
    except ValueError:
        raise RuntimeError(f"{path}: not JSON: {text[:400]!r}")


def firmware_config(path, bus, extra=""):
    with open(path, "w") as f:
        f.write('[control]\nlaw = "force"\n\n[safety]\nrecover_periods = 5\n\n[can]\n'
                'inputs = ["velocity", "displacement", "demand", "body_velocity", "force"]\n'
                'outputs = ["command", "enable", "heartbeat", "status"]\n'
                f'local_bus = "{bus}"\n{extra}')


def frames_realtime(a, dec, procs, tmp, out, errors):
    """mrd-firmware + mrd-hil serve on a stand-alone relay; a driver fault from 1.5 to 1.8 s."""
    bus = os.path.join(tmp, "bus.sock")
    relay = procs.start([os.path.join(a.bin, "mrd-canbus"), "--socket", bus],
                        os.path.join(tmp, "relay.json"))
    wait_path(bus, 10)
    log = os.path.join(tmp, "realtime.log")
    capture = procs.start([a.node, "capture", "--socket", bus, "--out", log],
                          os.path.join(tmp, "capture.json"))
    time.sleep(0.2)
    hil = procs.start([os.path.join(a.bin, "mrd-hil"), "serve", "--port", "can=" + bus,
                       "--duration", "3.5", "--fault-line", "1.5:1.8", "--json"],
                      os.path.join(tmp, "serve.json"))
    config = os.path.join(tmp, "firmware.toml")
    firmware_config(config, bus)
    fw = procs.start([os.path.join(a.bin, "mrd-firmware"), "--config", config, "--duration", "3",
                      "--json"], os.path.join(tmp, "firmware.json"))
    for p in (fw, hil):
        p.wait(timeout=120)
    time.sleep(0.2)
    for p in (capture, relay):
        p.send_signal(signal.SIGTERM)
        p.wait(timeout=30)
    relay_stats = read_json(os.path.join(tmp, "relay.json"))
    fw_stats = read_json(os.path.join(tmp, "firmware.json"))
    frames = dec.decode_log(log)
    out["realtime"] = {"frames": len(frames), "relay": relay_stats}
    # Counters are checked only on a complete capture (the relay dropped nothing to anyone).
    if relay_stats["frames_dropped"] == 0:
        check_counters(frames, errors, "realtime")
    else:
        out["realtime"]["counters"] = "not checked: the relay dropped frames (overloaded machine)"
    names = {n for _, _, n, _, _ in frames}
    for name in ("DriverCommand", "Heartbeat", "SensorMotion", "SensorForce", "DriverStatus",
                 "FirmwareStatus"):
        if name not in names:
            errors.append(f"realtime: no {name} frame on the bus")
    # Periods as documented (medians: a loaded machine delays single frames).
    for name, period in (("DriverCommand", 1), ("SensorMotion", 1), ("SensorForce", 1),
                         ("Heartbeat", 10), ("DriverStatus", 100), ("FirmwareStatus", 100)):
        got = median_period_ms(frames, name)
        out["realtime"][name + "_period_ms"] = got
        if got is None or abs(got - period) > 0.2 * period + 0.3:
            errors.append(f"realtime: {name} period {got} ms, documented {period} ms")
    # The echo never runs ahead of the sensor frames on the bus.
    latest_seq = None
    for t, _, name, v, _ in frames:
        if name == "SensorMotion":
            latest_seq = int(v["SensorSeq"])
        elif name == "DriverCommand" and latest_seq is not None:
            ahead = (int(v["EchoSeq"]) - latest_seq) % 65536
            if 0 < ahead < 32768:
                errors.append(f"realtime: EchoSeq {int(v['EchoSeq'])} ahead of SensorSeq {latest_seq}")
    # The simulated driver's current follows the commands: within [0, E_max / 5 ohm].
    statuses = [(t, v) for t, _, n, v, _ in frames if n == "DriverStatus"]
    if any(v["MeasuredCurrent"] > 2.25 / 5.0 + 1e-3 for _, v in statuses):
        errors.append("realtime: DriverStatus current above E_max / 5 ohm")
    if not any(v["MeasuredCurrent"] > 0.0 for _, v in statuses):
        errors.append("realtime: DriverStatus never reported a current (coil never driven?)")
    # The driver fault: DriverStatus bit 0 during the window, then the firmware's fault_line
    # cause (bit 4) in FirmwareStatus and safe commands within a few periods of it.
    faulted = [t for t, v in statuses if int(v["DriverFaults"]) != 0]
    out["realtime"]["faulted_driver_statuses"] = len(faulted)
    if not faulted:
        errors.append("realtime: no DriverStatus with a fault bit during the fault window")
    else:
        t0 = faulted[0]
        reacted = [t for t, _, n, v, _ in frames
                   if n == "FirmwareStatus" and t >= t0 and int(v["ActiveCauses"]) & (1 << 4)]
        after = [(t, v) for t, _, n, v, _ in frames if n == "DriverCommand" and t >= t0]
        safe_after = [t for t, v in after if v["SafeState"] == 1]
        out["realtime"]["fault_line_in_status_after_ms"] = (reacted[0] - t0) * 1e3 if reacted else None
        out["realtime"]["first_safe_command_after_ms"] = (safe_after[0] - t0) * 1e3 if safe_after else None
        if not reacted:
            errors.append("realtime: the firmware never reported the fault_line cause after the "
                          "driver's fault")
        # The next tick reads the status: its command (the first or, when a tick was under way
        # as the status arrived, the second after it) is safe, and so is every one while the
        # fault lasts.
        if not any(v["SafeState"] == 1 for _, v in after[:2]):
            errors.append("realtime: neither of the two commands after the driver's fault was safe")
        t_safe = after[1][0] if len(after) > 1 else t0
        driving = [t for t, v in after if t_safe <= t <= faulted[-1] and v["SafeState"] == 0]
        if driving:
            errors.append(f"realtime: {len(driving)} driving commands while the driver reported a fault")
    fault_line = fw_stats.get("watchdog", {}).get("fault_line", {})
    out["realtime"]["firmware_fault_line_trips"] = fault_line.get("trips")
    if not fault_line.get("trips"):
        errors.append("realtime: the firmware's watchdog never tripped on fault_line")


def frames_lockstep(a, dec, procs, tmp, out, errors):
    """mrd-firmware + mrd-hil run (lockstep): TimeGrant frames and scaling against the trace."""
    run_dir = os.path.join(tmp, "run")
    scenario = os.path.join(a.source, "hil", "scenarios", "force-periodic.toml")
    hil = procs.start([os.path.join(a.bin, "mrd-hil"), "run", scenario, "--out", run_dir, "--json"],
                      os.path.join(tmp, "run.json"))
    bus = os.path.join(run_dir, "canbus.sock")
    wait_path(bus, 30)
    log = os.path.join(tmp, "lockstep.log")
    capture = procs.start([a.node, "capture", "--socket", bus, "--out", log],
                          os.path.join(tmp, "capture-lockstep.json"))
    hil.wait(timeout=240)
    capture.send_signal(signal.SIGTERM)
    capture.wait(timeout=30)
    frames = dec.decode_log(log)
    import csv
    with open(os.path.join(run_dir, "trace.csv")) as f:
        trace = [{k: float(v) for k, v in row.items()} for row in csv.DictReader(f)]
    out["lockstep"] = {"frames": len(frames), "trace_rows": len(trace)}
    # The capture is a node of the harness's relay: a drop to it (an overloaded machine) shows
    # as a gap in the sensor seq (one motion frame per step); the continuity checks (counters,
    # grant steps) need a gap-free capture.
    seqs = [int(v["SensorSeq"]) for _, _, n, v, _ in frames if n == "SensorMotion"]
    gaps = sum(1 for a_, b_ in zip(seqs, seqs[1:]) if (b_ - a_) % 65536 > 1)
    out["lockstep"]["capture_gaps"] = gaps
    grants = [v["GrantTime"] for _, _, n, v, _ in frames if n == "TimeGrant"]
    if not grants:
        errors.append("lockstep: no TimeGrant frame on the bus")
    steps = [b - a for a, b in zip(grants, grants[1:]) if b != a]
    if gaps == 0 and any(s != 1000 for s in steps):
        errors.append(f"lockstep: GrantTime steps other than 1000 us: {sorted(set(steps))[:5]}")
    if any(b < a for a, b in zip(grants, grants[1:])):
        errors.append("lockstep: GrantTime went backwards")
    # Scaling: the step-k frames (SensorSeq k + 1) carry the plant's sample the trace shows
    # (row k's v as published, row k-1's x, force and demand), the command of step k echoes
    # k + 1 and its set-point is row k's command (one of those echoing k + 1: a tick that
    # missed its grant repeats the echo). Tolerance: half a count and the trace's
    # 9 significant digits.
    motion = {}
    force_after = {}
    last_seq = None
    commands = {}
    for _, _, n, v, _ in frames:
        if n == "SensorMotion":
            last_seq = int(v["SensorSeq"])
            motion[last_seq] = v
        elif n == "SensorForce" and last_seq is not None:
            force_after[last_seq] = v
            # The next SensorForce belongs to a later SensorMotion: when the capture lost that
            # one (capture_gaps), the force frame is not taken for this step's.
            last_seq = None
        elif n == "DriverCommand":
            # Several ticks may echo one sample (e.g. one without a grant in between).
            commands.setdefault(int(v["EchoSeq"]), []).append(v["VoltageSetpoint"])
    checked = {"velocity": 0, "displacement": 0, "force": 0, "demand": 0, "command": 0}
    bad = []

    def near(what, got, want, half_count, k):
        checked[what] += 1
        if abs(got - want) > half_count * 1.0001 + 1e-6 * max(1.0, abs(want)):
            bad.append(f"step {k}: {what} decoded {got}, trace {want}")

    for k in range(1, len(trace)):
        s = (k + 1) % 65536
        if s in motion:
            near("velocity", motion[s]["Velocity"], trace[k]["v"], 0.005, k)
            near("displacement", motion[s]["Displacement"], trace[k - 1]["x"], 0.0005, k)
        if s in force_after:
            near("force", force_after[s]["Force"], trace[k - 1]["force"], 0.25, k)
            near("demand", force_after[s]["Demand"], trace[k - 1]["demand"], 0.25, k)
        if s in commands:
            want = trace[k]["command"]
            got = min(commands[s], key=lambda c: abs(c - want))  # the tick the harness applied
            near("command", got, want, 0.0005, k)
    out["lockstep"]["scaling_checked"] = checked
    out["lockstep"]["scaling_mismatches"] = len(bad)
    errors.extend("lockstep: " + b for b in bad[:10])
    if min(checked.values()) < len(trace) // 2:
        errors.append(f"lockstep: too few frames matched to the trace: {checked}")
    if gaps == 0:
        check_counters(frames, errors, "lockstep")
    else:
        out["lockstep"]["counters"] = "not checked: the capture lost frames (overloaded machine)"


def cmd_frames(a):
    dec = Decoder(load_decoder(a.source), os.path.join(a.source, "docs", "mrd.dbc"))
    procs = Procs()
    tmp = tempfile.mkdtemp(prefix="mrd-can-conformance-")
    out, errors = {}, []
    try:
        frames_realtime(a, dec, procs, tmp, out, errors)
        frames_lockstep(a, dec, procs, tmp, out, errors)
    finally:
        procs.close()
    errors[:0] = dec.errors[:20]
    out["errors"] = errors
    print(json.dumps(out, indent=2))
    if not errors:
        shutil.rmtree(tmp, ignore_errors=True)
    else:
        print(f"files kept in {tmp}", file=sys.stderr)
    return 0 if not errors else 1


def cmd_stall_flood(a):
    dec = Decoder(load_decoder(a.source), os.path.join(a.source, "docs", "mrd.dbc"))
    procs = Procs()
    tmp = tempfile.mkdtemp(prefix="mrd-can-stall-flood-")
    out, errors = {"seconds": a.seconds, "babble_rate_per_ms": a.babble_rate,
                   "stall_ms": a.stall_ms, "max_age_ms": MAX_AGE_MS}, []
    T = a.seconds
    scenario = os.path.join(tmp, "scenario.toml")
    with open(scenario, "w") as f:
        f.write(f'name = "stall-flood"\ndescription = "stall and flood"\nduration_s = {T}\n\n'
                '[excitation]\nkind = "periodic"\n\n[control]\nlaw = "force"\n\n'
                f'[firmware]\nmax_age_ms = {MAX_AGE_MS}\n')
    run_dir = os.path.join(tmp, "run")
    try:
        hil = procs.start([os.path.join(a.bin, "mrd-hil"), "run", scenario, "--clock", "realtime",
                           "--attach", "--out", run_dir, "--json"], os.path.join(tmp, "run.json"))
        bus = os.path.join(run_dir, "canbus.sock")
        wait_path(os.path.join(run_dir, "firmware.toml"), 30)
        wait_path(bus, 30)
        log = os.path.join(tmp, "capture.log")
        capture = procs.start([a.node, "capture", "--socket", bus, "--out", log, "--valid-only"],
                              os.path.join(tmp, "capture.json"))
        time.sleep(0.2)
        fw = procs.start([os.path.join(a.bin, "mrd-firmware"), "--config",
                          os.path.join(run_dir, "firmware.toml"), "--duration", str(T + 5),
                          "--json"], os.path.join(tmp, "firmware.json"))
        # Wait for the loop to run, then the schedule (seconds after the first driving command
        # would be ideal; the harness starts within a second of the firmware).
        time.sleep(1.0)
        t_start = time.monotonic()
        events = []

        def at(fraction):
            delay = t_start + fraction * T - time.monotonic()
            if delay > 0:
                time.sleep(delay)

        def stall():
            t0 = time.monotonic()
            fw.send_signal(signal.SIGSTOP)
            time.sleep(a.stall_ms / 1e3)
            fw.send_signal(signal.SIGCONT)
            events.append(["stall", t0, time.monotonic()])

        at(0.2)
        stall()
        at(0.4)
        babbler = procs.start([a.node, "babble", "--socket", bus, "--rate", str(a.babble_rate),
                               "--nodes", str(a.babble_nodes)], os.path.join(tmp, "babble.json"))
        b0 = time.monotonic()
        at(0.55)
        stall()
        at(0.7)
        babbler.send_signal(signal.SIGTERM)
        babbler.wait(timeout=30)
        events.append(["babble", b0, time.monotonic()])
        hil.wait(timeout=T + 120)
        fw.send_signal(signal.SIGTERM)
        fw.wait(timeout=30)
        capture.send_signal(signal.SIGTERM)
        capture.wait(timeout=30)
    finally:
        procs.close()
    out["events"] = events
    out["babbler"] = read_json(os.path.join(tmp, "babble.json"))
    out["babbler"]["frames_per_ms"] = out["babbler"]["sent"] / out["babbler"]["seconds"] / 1e3
    fw_stats = read_json(os.path.join(tmp, "firmware.json"))
    hil = read_json(os.path.join(run_dir, "summary.json"))
    out["harness"] = {k: hil.get(k) for k in ("steps", "commands", "safe_commands",
                                              "driven_steps", "invariant_violations")}
    out["harness"]["late_steps"] = hil.get("timing", {}).get("late_steps")
    out["harness"]["heard_from_firmware"] = hil.get("ports", {}).get("can", {}).get("received")
    out["capture"] = read_json(os.path.join(tmp, "capture.json"))
    frames = dec.decode_log(log, keep_invalid=True)
    # The sensor frames the harness sent (valid checksums: not the babbler's).
    published = {}
    commands = []
    for t, _, n, v, ok in frames:
        if not ok:
            continue
        if n == "SensorMotion":
            published.setdefault(int(v["SensorSeq"]), t)
        elif n == "DriverCommand":
            commands.append((t, v))
    # Commands the capture missed (a node of the flooded bus too): gaps in CommandCounter.
    lost = sum((int(b["CommandCounter"]) - int(a_["CommandCounter"]) - 1) % 16
               for (_, a_), (_, b) in zip(commands, commands[1:]))
    tol_ms = 0.2  # the firmware checks before its send; the relay stamps the send
    driving = [(t, v) for t, v in commands if v["SafeState"] == 0]
    ages, unknown, violations = [], 0, []
    for t, v in driving:
        p = published.get(int(v["EchoSeq"]))
        if p is None or p > t:
            unknown += 1
            continue
        age = (t - p) * 1e3
        ages.append(age)
        if age > MAX_AGE_MS + tol_ms:
            violations.append(round(age, 3))
    # The flood as the bus saw it: from the babbler's first frame to its last (its frames are
    # left out of the log, their span counted); the firmware gets a period to notice.
    c = out["capture"]
    flood = (c["left_out_first_s"] + 0.01, c["left_out_last_s"]) if c["left_out_bad_checksum"] else None
    # A babbler descheduled for longer than the firmware's flood hold (100 ms) leaves a healthy
    # bus meanwhile: driving then is allowed (counted apart).
    hold_s = 0.1
    paused = lambda t: any(p0 + hold_s <= t <= p1 + 0.01 for p0, p1 in out["babbler"]["pauses"])
    in_flood = [t for t, _ in driving if flood and flood[0] <= t <= flood[1]]
    driving_in_flood = [t for t in in_flood if not paused(t)]
    out["figures"] = {
        "commands_captured": len(commands),
        "commands_missed_by_the_capture": lost,
        "driving_commands": len(driving),
        "safe_commands": len(commands) - len(driving),
        "driving_commands_older_than_max_age": len(violations),
        "worst_violations_ms": sorted(violations)[-10:],
        "max_sample_age_of_a_driving_command_ms": round(max(ages), 3) if ages else None,
        "driving_commands_without_their_sample_on_the_bus": unknown,
        "driving_commands_during_the_flood": len(driving_in_flood),
        "driving_commands_during_babbler_pauses": len(in_flood) - len(driving_in_flood),
        "babbler_pauses_over_20ms": len(out["babbler"]["pauses"]),
        "firmware_tx_frames": fw_stats.get("devices", {}).get("can", {}).get("tx_ok"),
    }
    # The same from the harness's own trace: each step's command with the age of the sample it
    # was computed from when it left the firmware (command_age_ms; -1 without a command).
    with open(os.path.join(run_dir, "trace.csv")) as f:
        rows = [r for r in csv.DictReader(f) if float(r["command_age_ms"]) >= 0.0]
    trace_driving = [float(r["command_age_ms"]) for r in rows if int(r["safe"]) == 0]
    trace_violations = [a for a in trace_driving if a > MAX_AGE_MS + tol_ms]
    out["figures"]["trace_commands_with_age"] = len(rows)
    out["figures"]["trace_driving_commands"] = len(trace_driving)
    out["figures"]["trace_driving_commands_older_than_max_age"] = len(trace_violations)
    out["figures"]["trace_max_sample_age_of_a_driving_command_ms"] = (
        round(max(trace_driving), 3) if trace_driving else None)
    if trace_violations:
        errors.append(f"harness trace: {len(trace_violations)} driving commands on samples older "
                      f"than {MAX_AGE_MS} ms (worst {max(trace_violations):.3f} ms)")
    if len(trace_driving) < 100 * T:
        errors.append(f"harness trace: only {len(trace_driving)} driving commands with their age")
    wd = fw_stats.get("watchdog", {})
    out["firmware"] = {k: fw_stats.get(k) for k in ("ticks", "overruns", "safe_periods",
                                                    "missed_periods")}
    out["firmware"]["safe_entries"] = fw_stats.get("safe_entries")
    out["firmware"]["can_bus_trips"] = wd.get("can_bus", {}).get("trips")
    out["firmware"]["stale_sensor_trips"] = wd.get("stale_sensor", {}).get("trips")
    out["firmware"]["can_errors"] = fw_stats.get("devices", {}).get("can", {}).get("errors")
    if violations:
        errors.append(f"{len(violations)} driving commands on samples older than {MAX_AGE_MS} ms "
                      f"(worst {max(violations)} ms)")
    if len(driving) < 100 * T:
        errors.append(f"only {len(driving)} driving commands: the loop hardly ran")
    if driving_in_flood:
        errors.append(f"{len(driving_in_flood)} driving commands while the bus was flooded")
    if flood is None:
        errors.append("the babbler's frames never reached the bus")
    if not wd.get("can_bus", {}).get("trips"):
        errors.append("the flood never tripped the can_bus cause")
    if lost > len(commands) // 10:
        errors.append(f"the capture missed {lost} of {len(commands) + lost} commands: not checked")
    if unknown > len(driving) // 100:
        errors.append(f"{unknown} driving commands whose sample is missing from the capture")
    errors[:0] = dec.errors[:20]
    out["errors"] = errors
    print(json.dumps(out, indent=2))
    if not errors and not a.keep:
        shutil.rmtree(tmp, ignore_errors=True)
    else:
        print(f"files kept in {tmp}", file=sys.stderr)
    return 0 if not errors else 1


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--bin", required=True, help="build/bin (mrd-firmware, mrd-hil, mrd-canbus)")
    p.add_argument("--node", required=True, help="the mrd_can_node test tool")
    p.add_argument("--source", required=True, help="the source tree (docs/, hil/, toolchain/)")
    sub = p.add_subparsers(dest="command", required=True)
    sub.add_parser("frames")
    sf = sub.add_parser("stall-flood")
    sf.add_argument("--seconds", type=float, default=5.0)
    sf.add_argument("--babble-rate", type=float, default=200.0, help="frames per ms")
    sf.add_argument("--babble-nodes", type=int, default=4, help="connections it spreads over")
    sf.add_argument("--stall-ms", type=float, default=200.0)
    sf.add_argument("--keep", action="store_true", help="keep the files")
    a = p.parse_args()
    try:
        return cmd_frames(a) if a.command == "frames" else cmd_stall_flood(a)
    except (RuntimeError, subprocess.TimeoutExpired, OSError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
