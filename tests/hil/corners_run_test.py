#!/usr/bin/env python3
"""Four damper channels of one mrd-firmware closed in lockstep over one CAN bus with the full
car (hil/scenarios/full-car-can-corners.toml: modal skyhook, fault policy "all", the rear-left
corner's sensor node silent for 100 ms):

  repeat      the same run twice: the summary (wall-time figures aside) and corners.csv are
              identical, byte for byte (sha256), and so is the commands' hash
  stall       the firmware stopped (SIGSTOP ... SIGCONT) for 150 ms at three moments: the same
  grants      the bus log (--can-log): after start-up, exactly one TimeGrant per period, each
              after the four corners' sensor frames of its period
  all         every corner commands its safe value within 2 periods of the detection on the
              rear-left corner, and recovers after the fault
  channel     per-corner skyhook, policy "channel": the rear-left corner goes safe, the other
              three command through the fault (no safe command), counted per corner

Usage: corners_run_test.py BIN_DIR SOURCE_DIR WORK_DIR
"""
import hashlib
import json
import os
import signal
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from lockstep_stall_test import children, strip_wall  # noqa: E402

STALL_S = 0.150
MOMENTS = (0.15, 0.35, 0.55)
NO_PROGRAMS = "/nonexistent-mrd-no-programs"  # no gnuplot: no plots (not compared)
CORNERS = ("front-left", "front-right", "rear-left", "rear-right")
SENSOR_IDS = {0x190, 0x191, 0x192, 0x193, 0x290, 0x291, 0x292, 0x293}
failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what, flush=True)
    if not ok:
        failures.append(what)


def run(bin_dir, scenario, out_dir, sets=(), extra=(), stall_wall=None):
    """One mrd-hil run; stall_wall: the firmware child stopped at MOMENTS of that wall time."""
    cmd = [os.path.join(bin_dir, "mrd-hil"), "run", scenario, "--out", out_dir, "--json",
           *[a for s in sets for a in ("--set", s)], *extra]
    env = dict(os.environ, PATH=NO_PROGRAMS)
    start = time.monotonic()
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    stops = 0
    if stall_wall:
        for m in MOMENTS:
            while time.monotonic() - start < m * stall_wall and p.poll() is None:
                time.sleep(0.002)
            kids = children(p.pid) if p.poll() is None else []
            if not kids:
                break
            os.kill(kids[0], signal.SIGSTOP)
            time.sleep(STALL_S)
            os.kill(kids[0], signal.SIGCONT)
            stops += 1
    out, err = p.communicate(timeout=300)
    wall = time.monotonic() - start
    summary_path = os.path.join(out_dir, "summary.json")
    if p.returncode not in (0, 1) or not os.path.exists(summary_path):
        raise RuntimeError(f"{' '.join(cmd)}: exit {p.returncode}\n{err.decode()}")
    with open(summary_path) as f:
        summary = json.load(f)
    with open(os.path.join(out_dir, "corners.csv"), "rb") as f:
        rows = f.read()
    stripped = strip_wall(summary)
    return {
        "summary": summary,
        "hash": hashlib.sha256(json.dumps(stripped, sort_keys=True).encode()).hexdigest()[:16],
        "rows": hashlib.sha256(rows).hexdigest()[:16],
        "raw": stripped,
        "wall": wall,
        "stops": stops,
        "exit": p.returncode,
        "stderr": err.decode(),
    }


def grants_in_log(path):
    """(grant times [us] in order, sensor frames before each grant) from a candump -L log."""
    grants, sensors, since = [], [], 0
    with open(path) as f:
        for line in f:
            parts = line.split()
            if len(parts) < 3 or "#" not in parts[2]:
                continue
            ident, data = parts[2].split("#", 1)
            ident = int(ident, 16)
            if ident == 0x7F0:
                raw = bytes.fromhex(data)
                grants.append(int.from_bytes(raw[:6], "little"))
                sensors.append(since)
                since = 0
            elif ident in SENSOR_IDS:
                since += 1
    return grants, sensors


def fault_of(summary):
    faults = summary["corners"]["faults"]
    return faults[0] if faults else None


def check_policy_all(summary):
    """The fault on the rear-left corner under policy "all": every corner safe within 2 periods
    of the detection, and recovering after it."""
    f = fault_of(summary)
    check(f is not None and f["ok"], f"fault on the rear-left corner, policy all: {f and f['why']}")
    if f is not None and f["periods_to_detection"] is not None:
        for name, pc in zip(CORNERS, f["per_corner"]):
            d2s = pc["detection_to_safe_periods"]
            check(d2s is not None and 0 <= d2s <= 2,
                  f"policy all: {name} safe {d2s} periods after the detection")
            check(pc["periods_to_recovery"] is not None, f"policy all: {name} recovers")


def check_repeat_and_stall(bin_dir, scenario, work, a, sets=()):
    """Runs a's scenario again (work/b) and with the firmware stopped 150 ms at MOMENTS
    (work/stall): both bit-identical to a. The stall's wall moments halve until all land inside
    the run."""
    b = run(bin_dir, scenario, os.path.join(work, "b"), sets=sets)
    print(f"run b: summary {b['hash']} corners.csv {b['rows']}", flush=True)
    check(b["hash"] == a["hash"] and b["rows"] == a["rows"], "bit-identical on repeat")
    for attempt in range(4):
        st = run(bin_dir, scenario, os.path.join(work, "stall"), sets=sets,
                 stall_wall=a["wall"] * 0.5 ** attempt)
        if st["stops"] == len(MOMENTS):
            break
    print(f"run stall ({st['stops']} stops of {int(STALL_S * 1000)} ms): summary {st['hash']} "
          f"corners.csv {st['rows']} wall {st['wall']:.2f} s", flush=True)
    check(st["stops"] == len(MOMENTS), f"{len(MOMENTS)} stops landed inside the run")
    check(st["hash"] == a["hash"] and st["rows"] == a["rows"],
          "bit-identical with the firmware stopped 150 ms mid-run")


def check_policy_channel(bin_dir, scenario, work, sets=()):
    """Per-corner skyhook under policy "channel" (work/channel): the rear-left corner goes safe,
    the other three command through the fault window with no safe command."""
    ch = run(bin_dir, scenario, os.path.join(work, "channel"),
             sets=tuple(sets) + ("channels.fault_policy=channel", "channels.body_law=none",
                                 "control.law=skyhook"))
    f = fault_of(ch["summary"])
    print(f"run channel: exit {ch['exit']} fault {json.dumps(f)}", flush=True)
    check(ch["exit"] == 0 and ch["summary"]["pass"],
          f"policy channel passes ({ch['summary'].get('failures')})")
    window = f["clear_step"] - f["onset_step"]
    for i, (name, pc) in enumerate(zip(CORNERS, f["per_corner"])):
        if i == 2:
            check(pc["safe_steps"] > 0 and pc["detection_to_safe_periods"] is not None and
                  pc["detection_to_safe_periods"] <= 2,
                  f"policy channel: the rear-left corner goes safe ({pc['safe_steps']} periods)")
        else:
            check(pc["safe_steps"] == 0 and pc["commanding_steps"] == window,
                  f"policy channel: {name} keeps commanding ({pc['commanding_steps']} of "
                  f"{window}, {pc['safe_steps']} safe)")


def main():
    bin_dir, src, work = sys.argv[1:4]
    scenario = os.path.join(src, "hil/scenarios/full-car-can-corners.toml")

    # repeat, grants, all
    log = os.path.join(work, "a-can.log")
    a = run(bin_dir, scenario, os.path.join(work, "a"), extra=("--can-log", log))
    s = a["summary"]
    print(f"run a: exit {a['exit']} summary {a['hash']} corners.csv {a['rows']} commands "
          f"{s.get('corners', {}).get('commands_fnv1a')} wall {a['wall']:.2f} s", flush=True)
    check(a["exit"] == 0 and s["pass"], f"the corners run passes ({s.get('failures')})")
    c = s["corners"]
    steps = s["steps"]
    check(steps == 3000, f"3000 periods ran ({steps})")
    for corner in c["per_corner"]:
        check(corner["commands"] == steps and corner["command_timeouts"] == 0,
              f"{corner['name']}: a command every period ({corner['commands']})")
        check(corner["rejected"] == 0, f"{corner['name']}: no frame rejected")
    ride = c["ride"]
    check(ride["samples"] > 0 and 0.0 < ride["body_accel_rms"] < 10.0 and
          all(0.0 < t < 5000.0 for t in ride["tyre_load_rms_n"]),
          f"ride figures in range: body {ride['body_accel_rms']:.4g} m/s^2, pitch "
          f"{ride['pitch_rate_rms']:.4g} rad/s, roll {ride['roll_rate_rms']:.4g} rad/s")
    grants, sensors = grants_in_log(log)
    after_start = [(g, n) for g, n in zip(grants, sensors) if g > 1000]
    times = [g for g, _ in after_start]
    check(times == [1000 * (k + 2) for k in range(steps)],
          f"one grant per period after the first ({len(times)} for {steps} periods + the final)")
    # The rear-left sensor node is silent in periods 1500 .. 1599 (its two frames dropped).
    expected = [6 if 1500 <= g // 1000 - 1 < 1600 else 8 for g, _ in after_start]
    check([n for g, n in after_start if g <= 1000 * steps] ==
          [e for (g, _), e in zip(after_start, expected) if g <= 1000 * steps],
          "every period's grant follows the four corners' sensor frames (8; 6 while the "
          "rear-left node is silent)")
    check(c["grants"] == steps and len(grants) == steps + 1,
          f"one offer of the first period: {len(grants)} grants on the bus, {c['grants']} counted")
    check_policy_all(s)
    check_repeat_and_stall(bin_dir, scenario, work, a)
    check_policy_channel(bin_dir, scenario, work)

    print("corners_run_test: " + ("every check holds" if not failures else
                                  f"{len(failures)} FAILED"))
    return 0 if not failures else 1


if __name__ == "__main__":
    sys.exit(main())
