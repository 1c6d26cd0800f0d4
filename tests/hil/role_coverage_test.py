#!/usr/bin/env python3
"""Every input role a shipped device profile maps (the signals the firmware reads) is exercised
by a harness run, and the run shows that the firmware took it.

For each profile in firmware/profiles/*.toml the test lists the roles of its [inputs] (CAN) or
[modbus.inputs] (Modbus), finds the runs COVERAGE names for each, runs them (`mrd-hil run`,
lockstep, 3 s, the harness playing the profile's driver and sensors) and checks the evidence:

  routed     the generated firmware configuration routes the input, and the run took frames
             with no refusal (a law that reads it: force tracking, skyhook, hybrid, the
             clipped-optimal structure)
  grant      the lockstep clock ran on the profile's grant without a missed grant
  seq_echo   the echoed sample number gave latency samples (CAN: the echo carries it back)
  seq_stale  a sensor stall (the same sample number again) went stale (Modbus: no new data)
  accepted   the firmware accepted the frames carrying it (telemetry roles the loop does not
             use: driver_current; a sample number with no echo to carry it back)
  fault      a scenario fault of that kind made the firmware's fault_line cause trip

A mapped role with no run in COVERAGE fails the test (a new role needs a run). Prints a table:
profile, role, run, evidence. Usage: role_coverage_test.py BIN_DIR SOURCE_DIR PAPER_DIR WORK_DIR
"""
import json
import os
import subprocess
import sys
import tomllib

# role -> [(run, evidence)] in order of preference; the first run the profile can play covers it.
COVERAGE = {
    "velocity": [("force", "routed")],
    "displacement": [("force", "routed")],
    "demand": [("force", "routed")],
    "force": [("force", "routed")],
    "body_velocity": [("skyhook", "routed")],
    "body_acceleration": [("hybrid", "routed")],
    "wheel_velocity": [("hybrid", "routed")],
    "floor_acceleration_1": [("structure", "routed")],
    "floor_acceleration_2": [("structure", "routed")],
    "floor_acceleration_3": [("structure", "routed")],
    "grant": [("force", "grant")],
    "sensor_seq": [("stall", "seq_stale"), ("force", "seq_echo"), ("force", "accepted")],
    "fault_line": [("fault_line", "fault")],
    "driver_faults": [("driver_fault", "fault")],
    "driver_current": [("force", "accepted")],
}

SCENARIOS = {  # run -> scenario (cut to 3 s of plant time) and its fault
    "force": ["hil/scenarios/force-v1.toml"],
    "skyhook": ["hil/scenarios/quarter-car-skyhook.toml"],
    "hybrid": ["hil/scenarios/quarter-car-hybrid.toml"],
    "structure": ["hil/scenarios/structure-clipped-optimal.toml"],
    "stall": ["hil/scenarios/force-v1.toml", "stall"],
    "fault_line": ["hil/scenarios/force-v1.toml", "fault_line"],
    "driver_fault": ["hil/scenarios/force-v1.toml", "driver_fault"],
}


def inputs_of(path):
    with open(path, "rb") as f:
        p = tomllib.load(f)
    if "modbus" in p:
        return "modbus", sorted(p["modbus"].get("inputs", {})), p
    return "can", sorted(p.get("inputs", {})), p


def scenario_file(work, src, paper, run):
    """The run's scenario: the shipped one cut to 3 s (relative files made absolute), with the
    run's fault at 1 s."""
    base, *fault = SCENARIOS[run]
    with open(os.path.join(src, base), "rb") as f:
        text = f.read().decode()
    path = os.path.join(work, f"{run}.toml")
    here = os.path.dirname(os.path.join(src, base))
    out = ["duration_s = 3.0"]
    for ln in text.splitlines():
        key, eq, value = ln.partition("=")
        key, value = key.strip(), value.strip()
        if key == "duration_s":
            continue
        if key == "settle_s":  # the quarter car's ride figures: after 1 s of the 3
            ln = "settle_s = 1.0"
        elif (eq and value.startswith('"') and value[-5:] in ('.csv"', 'toml"') and
              value[1] != "/"):
            ln = f'{key} = "{os.path.normpath(os.path.join(here, value[1:-1]))}"'
        out.append(ln)
    if fault:
        out += ["", "[[fault]]", f"kind = \"{fault[0]}\"", "at_s = 1.0", "duration_s = 0.2"]
    with open(path, "w") as f:
        f.write("\n".join(out) + "\n")
    return path


class Runs:
    def __init__(self, bin_dir, src, paper, work):
        self.bin, self.src, self.paper, self.work = bin_dir, src, paper, work
        self.cache = {}

    def get(self, profile, run):
        key = (profile, run)
        if key in self.cache:
            return self.cache[key]
        name = os.path.basename(profile)[:-5]
        out = os.path.join(self.work, name, run)
        os.makedirs(out, exist_ok=True)
        transport, _, _ = inputs_of(profile)
        cmd = [os.path.join(self.bin, "mrd-hil"), "run",
               scenario_file(os.path.dirname(out), self.src, self.paper, run),
               "--table", os.path.join(self.paper, "table.bin"), "--profile", profile,
               "--transport", "can" if transport == "can" else "modbus-tcp",
               "--out", out, "--json"]
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
        r = {"status": p.returncode, "err": p.stderr}
        try:
            r["j"] = json.loads(p.stdout)
        except json.JSONDecodeError:
            r["j"] = {}
        cfg = os.path.join(out, "firmware.toml")
        r["config"] = open(cfg).read() if os.path.exists(cfg) else ""
        self.cache[key] = r
        return r


def routed_inputs(config):
    """The inputs lists of the generated configuration's bus sections."""
    routed = set()
    for section in tomllib.loads(config).values():
        if isinstance(section, dict) and isinstance(section.get("inputs"), list):
            routed.update(section["inputs"])
    return routed


def evidence(kind, role, r, transport):
    """'' when the run shows the firmware took the role, else why not."""
    j = r["j"]
    if r["status"] not in (0, 1) or not j:
        return f"the run failed (exit {r['status']}): {r['err'][-300:]}"
    fw = j.get("firmware", {}).get("summary", {})
    dev = fw.get("devices", {}).get(transport, {})
    if kind in ("routed", "accepted", "grant", "seq_echo"):
        if dev.get("rx_ok", 0) == 0 or dev.get("rx_rejected", 1) != 0:
            return f"frames not taken cleanly: {dev}"
    if kind == "routed" and role not in routed_inputs(r["config"]):
        return "the generated configuration does not route it"
    if kind == "grant" and (j.get("clock") != "lockstep" or
                            fw.get("clock", {}).get("missed_grants", 1) != 0):
        return "no clean lockstep run"
    if kind == "seq_echo" and j.get("timing", {}).get("latency_us", {}).get("count", 0) == 0:
        return "no latency sample (no echo)"
    if kind == "seq_stale" and fw.get("watchdog", {}).get("stale_sensor", {}).get("trips", 0) < 1:
        return "the stall was not seen as stale data"
    if kind == "fault":
        f = (j.get("faults") or [{}])[0]
        trips = fw.get("watchdog", {}).get("fault_line", {}).get("trips", 0)
        if trips < 1 or not f.get("ok"):
            return f"fault_line trips {trips}, fault {f}"
    return ""


def main():
    bin_dir, src, paper, work = sys.argv[1:5]
    os.makedirs(work, exist_ok=True)
    runs = Runs(bin_dir, src, paper, work)
    profiles = sorted(os.path.join(src, "firmware/profiles", f)
                      for f in os.listdir(os.path.join(src, "firmware/profiles"))
                      if f.endswith(".toml"))
    ok = True
    print(f"{'profile':16} {'role':22} {'run':13} evidence")
    for profile in profiles:
        transport, roles, _ = inputs_of(profile)
        name = os.path.basename(profile)[:-5]
        for role in roles:
            if role not in COVERAGE:
                print(f"{name:16} {role:22} {'-':13} NOT COVERED: no run in COVERAGE")
                ok = False
                continue
            why_not = []
            for run, kind in COVERAGE[role]:
                # Only runs the profile can play: a seq stall is Modbus's evidence, the echo
                # CAN's; a law needs its inputs mapped (else the run is refused: skip it).
                if kind == "seq_stale" and transport != "modbus":
                    continue
                r = runs.get(profile, run)
                if r["status"] == 2:
                    why_not.append(f"{run}: refused ({r['err'].strip()[-160:]})")
                    continue
                why = evidence(kind, role, r, transport)
                if not why:
                    print(f"{name:16} {role:22} {run:13} {kind}")
                    break
                why_not.append(f"{run}/{kind}: {why}")
            else:
                print(f"{name:16} {role:22} {'-':13} NOT COVERED: " + "; ".join(why_not))
                ok = False
    print("role_coverage_test: " + ("every mapped input role exercised" if ok else "FAILED"))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
