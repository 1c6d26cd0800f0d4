#!/usr/bin/env python3
"""Lockstep does not depend on wall time: a scenario run undisturbed, with the firmware child
stopped (SIGSTOP ... SIGCONT) for 150 ms at three moments, and with the harness stopped
likewise, gives the same summary and trace, byte for byte (sha256).

The summary is compared without the figures that measure wall time by definition (wall_s,
speed_x, the sensor->command latency, the wake-up jitter, the firmware's worst latency and
execution time, the per-period log's path, block count and size); everything else, every trace column and every counter, must be identical.

Usage: lockstep_stall_test.py BIN_DIR SOURCE_DIR PAPER_DIR WORK_DIR
         [SCENARIO[@TRANSPORT][+PROFILE] ...]
  SCENARIO: force-v1 (with PAPER_DIR/v1.csv) or quarter-car-skyhook (default: both, on CAN);
  TRANSPORT: can (default), modbus-tcp or modbus-rtu; PROFILE: a shipped device profile
  (firmware/profiles/PROFILE.toml, e.g. canopen-drive) the harness and the firmware run on.
Prints one line per run with its hashes; exit 0 when every disturbed run matches, else 1.
"""
import hashlib
import json
import os
import signal
import subprocess
import sys
import time

STALL_S = 0.150
# Fractions of the undisturbed run's wall time (early: a disturbed run may go faster on a
# machine whose load changed); halved and retried when a stop falls after the run's end.
MOMENTS = (0.1, 0.25, 0.4)
WALL_KEYS = {"wall_s", "speed_x", "latency_us", "wake_jitter_us"}  # under "timing"
FIRMWARE_WALL_KEYS = {"worst_latency_us", "worst_exec_us"}
# The firmware's per-period log: its path names the run's folder; its block count and size
# depend on when the writer flushed a partial block (flush_ms of wall time). The records
# written and dropped are compared.
LOG_WALL_KEYS = {"path", "blocks", "bytes"}
NO_PROGRAMS = "/nonexistent-mrd-no-programs"  # a PATH where nothing is found


def children(pid):
    """Direct children of pid (from /proc)."""
    out = []
    for task in os.listdir(f"/proc/{pid}/task"):
        try:
            with open(f"/proc/{pid}/task/{task}/children") as f:
                out += [int(c) for c in f.read().split()]
        except OSError:
            pass
    return out


def strip_wall(summary):
    s = dict(summary)
    if isinstance(s.get("timing"), dict):
        s["timing"] = {k: v for k, v in s["timing"].items() if k not in WALL_KEYS}
    fw = s.get("firmware", {}).get("summary")
    if isinstance(fw, dict):
        s["firmware"] = dict(s["firmware"])
        s["firmware"]["summary"] = {k: v for k, v in fw.items() if k not in FIRMWARE_WALL_KEYS}
        if isinstance(fw.get("log"), dict):
            s["firmware"]["summary"]["log"] = {
                k: v for k, v in fw["log"].items() if k not in LOG_WALL_KEYS}
    return s


def run(bin_dir, args, out_dir, stop_target=None, wall_s=None, scale=1.0):
    """One mrd-hil run; stop_target 'firmware' or 'harness' stops it at MOMENTS x scale of
    wall_s."""
    cmd = [os.path.join(bin_dir, "mrd-hil"), "run", *args, "--out", out_dir, "--json"]
    # No program on PATH: mrd-hil skips its plots (gnuplot), which cost about two seconds a run
    # and are not compared; it starts the firmware by its own path.
    env = dict(os.environ, PATH=NO_PROGRAMS)
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    start = time.monotonic()
    stops = 0
    if stop_target:
        for m in MOMENTS:
            while time.monotonic() - start < m * scale * wall_s and p.poll() is None:
                time.sleep(0.002)
            if p.poll() is not None:
                break
            if stop_target == "harness":
                target = p.pid
            else:
                kids = children(p.pid)
                while not kids and p.poll() is None:  # not started yet
                    time.sleep(0.002)
                    kids = children(p.pid)
                if not kids:
                    break
                target = kids[0]
            os.kill(target, signal.SIGSTOP)
            time.sleep(STALL_S)
            os.kill(target, signal.SIGCONT)
            stops += 1
    out, err = p.communicate(timeout=600)
    wall = time.monotonic() - start
    if p.returncode not in (0, 1) or not os.path.exists(os.path.join(out_dir, "summary.json")):
        raise RuntimeError(f"{' '.join(cmd)}: exit {p.returncode}\n{err.decode()}")
    with open(os.path.join(out_dir, "summary.json")) as f:
        summary = json.load(f)
    with open(os.path.join(out_dir, "trace.csv"), "rb") as f:
        trace = f.read()
    s = json.dumps(strip_wall(summary), sort_keys=True).encode()
    return {
        "summary": hashlib.sha256(s).hexdigest()[:16],
        "trace": hashlib.sha256(trace).hexdigest()[:16],
        "pass": summary.get("pass"),
        "wall": wall,
        "stops": stops,
        "raw": strip_wall(summary),
    }


def diff(a, b, path=""):
    """First differing keys of two JSON values (for the failure message)."""
    if isinstance(a, dict) and isinstance(b, dict):
        out = []
        for k in sorted(set(a) | set(b)):
            out += diff(a.get(k), b.get(k), f"{path}.{k}")
        return out
    return [] if a == b else [f"{path}: {json.dumps(a)[:120]} != {json.dumps(b)[:120]}"]


def main():
    bin_dir, src, paper, work = sys.argv[1:5]
    names = sys.argv[5:] or ["force-v1", "quarter-car-skyhook"]
    scenarios = {
        "force-v1": [os.path.join(src, "hil/scenarios/force-v1.toml"), "--table",
                     os.path.join(paper, "table.bin"), "--excitation",
                     os.path.join(paper, "v1.csv")],
        "quarter-car-skyhook": [os.path.join(src, "hil/scenarios/quarter-car-skyhook.toml"),
                                "--table", os.path.join(paper, "table.bin")],
    }
    ok = True
    for spec in names:
        spec_run, _, profile = spec.partition("+")
        name, _, transport = spec_run.partition("@")
        args = scenarios[name] + ["--transport", transport or "can"]
        if profile:
            args += ["--profile", os.path.join(src, "firmware/profiles", profile + ".toml")]
        name = spec.replace("@", "-").replace("+", "-")
        base = run(bin_dir, args, os.path.join(work, name, "undisturbed"))
        print(f"{name} undisturbed: summary {base['summary']} trace {base['trace']} "
              f"pass {base['pass']} wall {base['wall']:.2f} s", flush=True)
        for target in ("firmware", "harness"):
            for attempt in range(4):
                r = run(bin_dir, args, os.path.join(work, name, f"{target}-stopped"), target,
                        base["wall"], 0.5 ** attempt)
                if r["stops"] == len(MOMENTS):
                    break
            same = r["summary"] == base["summary"] and r["trace"] == base["trace"]
            print(f"{name} {target} stopped {r['stops']}x {int(STALL_S * 1000)} ms: summary "
                  f"{r['summary']} trace {r['trace']} pass {r['pass']} wall {r['wall']:.2f} s "
                  f"-> {'identical' if same else 'DIFFERENT'}", flush=True)
            if r["stops"] != len(MOMENTS):
                print(f"  only {r['stops']} of {len(MOMENTS)} stops landed inside the run")
                ok = False
            if not same:
                ok = False
                for line in diff(base["raw"], r["raw"])[:12]:
                    print("  " + line)
    print("lockstep_stall_test: " + ("every disturbed run identical" if ok else "FAILED"))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
