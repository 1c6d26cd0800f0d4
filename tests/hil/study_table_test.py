#!/usr/bin/env python3
"""`mrd-hil study` runs the scenario's own table and plant (labels hil, control):
  - on a quarter-car scenario whose [firmware] table is not the compiled-in one, the study's
    skyhook figures equal `mrd-hil run` of the same scenario (same table, law and plant: body
    acceleration and tyre-load RMS to 4 significant digits), and differ from the same study on
    the compiled-in table (the table is used, not ignored);
  - stdout, study.txt, study.json, study.csv and the plot script name the table by path and
    CRC-32 (the one in the file's last 4 bytes) and the plant (its params file);
  - what the study cannot use is refused, exit 2, naming it: [[fault]]s, a table the firmware
    refuses; nothing written.

Usage: study_table_test.py BIN_DIR SOURCE_DIR WORK_DIR
"""
import json
import os
import shutil
import struct
import subprocess
import sys

BIN, SRC, WORK = (os.path.abspath(a) for a in sys.argv[1:4])
HIL = os.path.join(BIN, "mrd-hil")
TABLE = os.path.join(SRC, "tests/data/profiles/mrd-native-frames.table.bin")
PLANT = os.path.join(SRC, "hil/scenarios/nees-damper/plant.toml")
failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


def hil(*args):
    return subprocess.run([HIL, *args], capture_output=True, text=True, timeout=600)


def sig4(v):
    return float(f"{v:.4g}")


shutil.rmtree(WORK, ignore_errors=True)
os.makedirs(WORK)
crc = "0x%08X" % struct.unpack("<I", open(TABLE, "rb").read()[-4:])[0]

# The shipped quarter car, shortened, with its own table and a fitted plant file.
base = open(os.path.join(SRC, "hil/scenarios/quarter-car-skyhook.toml")).read()
base = base.replace('duration_s = 25.0', 'duration_s = 5.0')
base = base.replace('settle_s = 2.0', 'settle_s = 1.0')
base = base.replace('preset = "paper"', f'params = "{PLANT}"')
scenario = os.path.join(WORK, "own-table.toml")
open(scenario, "w").write(base + f'\n[firmware]\ntable = "{TABLE}"\n')
builtin = os.path.join(WORK, "builtin.toml")
open(builtin, "w").write(base)

p = hil("run", scenario, "--passive-step", "0", "--json")
check(p.returncode in (0, 1), f"run ran (exit {p.returncode}) {p.stderr[-400:]}")
run = json.loads(p.stdout)
check(run.get("table") == f"{TABLE} (CRC-32 {crc})", f"run summary names the table: {run.get('table')}")
check(PLANT in run.get("plant", ""), f"run summary names the plant: {run.get('plant')}")
ride = run["ride"]["controlled"]

out = os.path.join(WORK, "study")
p = hil("study", "--scenario", scenario, "--classes", "C", "--speeds", "20", "--laws", "skyhook",
        "--passive-step", "0.25", "--out", out)
check(p.returncode == 0, f"study exit 0 ({p.returncode}) {p.stderr[-400:]}")
check(crc in p.stdout and TABLE in p.stdout, "study stdout names the table path and CRC")
check(PLANT in p.stdout, "study stdout names the plant")
sj = json.load(open(os.path.join(out, "study.json")))
check(sj["table"] == f"{TABLE} (CRC-32 {crc})", f"study.json table: {sj['table']}")
check(PLANT in sj["plant"], f"study.json plant: {sj['plant']}")
law = sj["cases"][0]["laws"][0]["ride"]
print(f"[ figures ] run body acc {ride['body_accel_rms']:.6g}, tyre {ride['tyre_load_rms_n']:.6g}; "
      f"study body acc {law['body_accel_rms']:.6g}, tyre {law['tyre_load_rms_n']:.6g}")
check(sig4(law["body_accel_rms"]) == sig4(ride["body_accel_rms"]),
      f"study = run: body acceleration RMS to 4 digits ({law['body_accel_rms']:.6g} vs "
      f"{ride['body_accel_rms']:.6g})")
check(sig4(law["tyre_load_rms_n"]) == sig4(ride["tyre_load_rms_n"]),
      f"study = run: tyre-load RMS to 4 digits ({law['tyre_load_rms_n']:.6g} vs "
      f"{ride['tyre_load_rms_n']:.6g})")
txt = open(os.path.join(out, "study.txt")).read()
check(txt.startswith(f"table {TABLE} (CRC-32 {crc}), plant "), "study.txt's first line: table, plant")
csv_text = open(os.path.join(out, "study.csv")).read()
check(crc in csv_text and PLANT in csv_text, "study.csv rows name table and plant")
check(crc in open(os.path.join(out, "study.gp")).read(), "plot titles name the table")

# The same study on the compiled-in table gives other figures: the table is the scenario's.
out2 = os.path.join(WORK, "study-builtin")
p = hil("study", "--scenario", builtin, "--classes", "C", "--speeds", "20", "--laws", "skyhook",
        "--passive-step", "0.25", "--out", out2)
check(p.returncode == 0, f"builtin study exit 0 ({p.returncode})")
bj = json.load(open(os.path.join(out2, "study.json")))
check(bj["table"].startswith("compiled-in (CRC-32 0x"), f"compiled-in table named: {bj['table']}")
check(bj["cases"][0]["laws"][0]["ride"]["body_accel_rms"] != law["body_accel_rms"],
      "another table, other figures")

# Refusals: exit 2, the reason, nothing written.
faulty = os.path.join(WORK, "faulty.toml")
open(faulty, "w").write(base + '\n[[fault]]\nkind = "drop"\nat_s = 1.0\nduration_s = 0.1\n')
bad_table = os.path.join(WORK, "bad.bin")
data = bytearray(open(TABLE, "rb").read())
data[100] ^= 0x5A
open(bad_table, "wb").write(bytes(data))
bad = os.path.join(WORK, "bad-table.toml")
open(bad, "w").write(base + f'\n[firmware]\ntable = "{bad_table}"\n')
for path, words in [(faulty, ["[[fault]]", "no faults"]), (bad, [bad_table, "CRC"])]:
    d = os.path.join(WORK, "refused")
    p = hil("study", "--scenario", path, "--classes", "C", "--speeds", "20", "--out", d)
    check(p.returncode == 2 and all(w in p.stderr for w in words) and not os.path.exists(d),
          f"refused {os.path.basename(path)}: exit {p.returncode}, {p.stderr.strip()[:200]}")

if failures:
    print(f"{len(failures)} check(s) failed")
    sys.exit(1)
print("all checks passed")
