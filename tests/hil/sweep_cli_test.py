#!/usr/bin/env python3
"""`mrd-hil run --set` and `mrd-hil sweep` end to end (labels hil, observe), on the quarter car
shortened to 3 s (compiled-in table, lockstep over the local CAN bus):
  - --set changes the run (duration and steps in the summary; the gain changes the ride);
  - a bad --set or range is refused with exit 2, naming it, and writes nothing;
  - a sweep prints its table, writes sweep.csv and sweep.png; its rows are the single runs'
    figures; the same sweep twice gives the same CSV byte for byte (lockstep: deterministic).

Usage: sweep_cli_test.py BIN_DIR SOURCE_DIR WORK_DIR
"""
import csv
import json
import os
import shutil
import subprocess
import sys

BIN, SRC, WORK = sys.argv[1:4]
HIL = os.path.join(BIN, "mrd-hil")
SCENARIO = os.path.join(SRC, "hil/scenarios/quarter-car-skyhook.toml")
SHORT = ["--set", "duration_s=3", "--set", "quarter_car.settle_s=1"]
failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


def hil(*args):
    return subprocess.run([HIL, *args], capture_output=True, text=True, timeout=600)


def run_json(*sets):
    p = hil("run", SCENARIO, *SHORT, *sets, "--json")
    check(p.returncode in (0, 1), f"run {' '.join(sets)} ran (exit {p.returncode}) {p.stderr[-300:]}")
    return json.loads(p.stdout)


shutil.rmtree(WORK, ignore_errors=True)
os.makedirs(WORK)

# --set changes the run.
a = run_json("--set", "control.skyhook_gain=40")
b = run_json("--set", "control.skyhook_gain=100")
check(a["duration_s"] == 3 and a["steps"] == 3000, f"duration_s=3 gives 3000 steps ({a['steps']})")
ra, rb = a["ride"]["controlled"], b["ride"]["controlled"]
check(ra["body_accel_rms"] != rb["body_accel_rms"], "the gain changes the body acceleration")
check(a["ride"]["passive_off"] == b["ride"]["passive_off"], "the passive twins do not depend on it")

# Bad --set: exit 2, the error names it, no --out directory made.
for sets, why in ((["control.skyhook_gain=abc"], "--set control.skyhook_gain=abc: 'skyhook_gain' must be a number"),
                  (["control.nosuch=1"], "--set control.nosuch=1: unknown key 'nosuch' in [control]"),
                  (["duration_s"], "--set duration_s: expected KEY=VALUE")):
    out = os.path.join(WORK, "bad-run")
    p = hil("run", SCENARIO, *[x for s in sets for x in ("--set", s)], "--out", out)
    check(p.returncode == 2 and why in p.stderr and not os.path.exists(out),
          f"run --set {sets[0]} refused: exit {p.returncode}, {p.stderr.strip()}")
for rng, why in (("10:120:0", "STEP must not be 0"), ("120:10:10", "STEP must be negative"),
                 ("x:1:1", "finite numbers"), ("0:1e9:1", "more than 1000 points")):
    out = os.path.join(WORK, "bad-sweep")
    p = hil("sweep", SCENARIO, "--set", "control.skyhook_gain=" + rng, "--out", out)
    check(p.returncode == 2 and why in p.stderr and not os.path.exists(out),
          f"sweep {rng} refused: exit {p.returncode}, {p.stderr.strip()}")
# A bad value inside an otherwise good range is refused before any run.
out = os.path.join(WORK, "bad-value")
p = hil("sweep", SCENARIO, *SHORT, "--set", "road.seed=1:2:0.5", "--out", out)
check(p.returncode == 2 and "--set road.seed=1.5: 'seed' must be an integer" in p.stderr
      and "[1/" not in p.stderr and not os.path.exists(out), f"sweep road.seed=1:2:0.5 refused: {p.stderr.strip()}")

# The sweep, twice.
csvs = []
for k in (1, 2):
    out = os.path.join(WORK, f"sweep{k}")
    p = hil("sweep", SCENARIO, *SHORT, "--set", "control.skyhook_gain=40:100:30", "--out", out)
    check(p.returncode == 0, f"sweep {k} exit {p.returncode} {p.stderr[-300:]}")
    print(p.stdout, end="")
    check(p.stderr.count("/3] control.skyhook_gain=") == 3, "a progress line per point")
    check(p.stdout.splitlines()[0].split()[:3] == ["control.skyhook_gain", "pass", "body_accel_rms"],
          "the table's header")
    check("<- best" in p.stdout and "best: control.skyhook_gain=" in p.stdout, "the best point named")
    with open(os.path.join(out, "sweep.csv"), "rb") as f:
        csvs.append(f.read())
    if shutil.which("gnuplot"):
        png = os.path.join(out, "sweep.png")
        check(os.path.getsize(png) > 1000, "sweep.png written")
    check(not [n for n in os.listdir(out) if "XXXXXX" in n or n.endswith(".tmp")], "no temporaries left")
check(csvs[0] == csvs[1], "the same sweep twice gives the same sweep.csv")
rows = list(csv.DictReader(csvs[0].decode().splitlines()))
check([r["control.skyhook_gain"] for r in rows] == ["40", "70", "100"], "one row per point")
for row, single in ((rows[0], a), (rows[2], b)):
    got = float(row["body_accel_rms"])
    want = single["ride"]["controlled"]["body_accel_rms"]
    check(abs(got - want) <= 1e-8 * abs(want), f"row {row['control.skyhook_gain']}: {got} = the run's {want}")
    check(row["pass"] == ("1" if single["pass"] else "0"), "pass as the run's")

print(f"{len(failures)} failure(s)")
sys.exit(1 if failures else 0)
