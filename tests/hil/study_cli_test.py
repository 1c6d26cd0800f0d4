#!/usr/bin/env python3
"""The best passive baseline in `mrd-hil run` and `mrd-hil study` end to end (labels hil,
control), on the quarter car shortened to a few seconds:
  - run: the summary JSON carries the passive grid, the best setting per metric and the
    comfort at equal road holding; --out writes comfort.png and psd.png; --passive-step 0
    drops the grid;
  - study: the table has every cell (each class x speed x law), the CSV and JSON agree, the
    files and plots exist; the same study twice gives the same CSV and JSON byte for byte;
  - --motion-ratios: one case per ratio x class x speed, the ratio in every output and in the
    plot names; on the full 25 s class C road at 20 m/s, SH-ADD is >= 15 % more comfortable
    than the best passive setting at no worse road holding when the damper sits at motion
    ratio 0.5, and at the shipped 0.7 the 0 V damper is the most comfortable passive setting
    (the floor that limits every law there: docs/study.md);
  - bad flags: exit 2 with a message naming the flag, nothing written.

Usage: study_cli_test.py BIN_DIR SOURCE_DIR WORK_DIR
"""
import csv
import json
import os
import shutil
import signal
import subprocess
import sys

BIN, SRC, WORK = sys.argv[1:4]
HIL = os.path.join(BIN, "mrd-hil")
SCENARIO = os.path.join(SRC, "hil/scenarios/quarter-car-skyhook.toml")
failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


def hil(*args):
    return subprocess.run([HIL, *args], capture_output=True, text=True, timeout=600)


shutil.rmtree(WORK, ignore_errors=True)
os.makedirs(WORK)

# --- run: the baseline in the summary -----------------------------------------------------
out = os.path.join(WORK, "run")
p = hil("run", SCENARIO, "--set", "duration_s=4", "--set", "quarter_car.settle_s=1",
        "--passive-step", "0.25", "--out", out, "--json")
check(p.returncode in (0, 1), f"run ran (exit {p.returncode}) {p.stderr[-400:]}")
j = json.loads(p.stdout)
pas = j.get("passive")
check(pas is not None, "summary JSON has 'passive'")
if pas:
    check(len(pas["grid"]) == 10, f"grid 0..2.25 V step 0.25: 10 points ({len(pas['grid'])})")
    check(pas["step_v"] == 0.25 and pas["e_max"] == 2.25, "step and range in the JSON")
    for key in ("body_accel_rms", "body_accel_wk_rms", "tyre_load_rms_n", "travel_rms_cm"):
        b = pas["best"][key]
        low = min(g[key] for g in pas["grid"])
        check(b["value"] == low, f"best {key} is the grid's minimum")
        c = pas["controlled"][key]
        check(abs(b["improvement_percent"] - 100 * (b["value"] - c) / b["value"]) < 1e-9,
              f"{key} improvement = (best - controlled) / best")
    check(pas["controlled"]["body_accel_rms"] == j["ride"]["controlled"]["body_accel_rms"],
          "controlled figures are the run's")
    check(pas["grid"][0]["body_accel_rms"] == j["ride"]["passive_off"]["body_accel_rms"],
          "the grid's 0 V point is the run's passive-off twin")
    eq = pas["comfort_at_equal_road_holding"]
    tyre = pas["controlled"]["tyre_load_rms_n"]
    ok = [g for g in pas["grid"] if g["tyre_load_rms_n"] <= tyre]
    if ok:
        best = min(ok, key=lambda g: g["body_accel_rms"])
        check(eq is not None and eq["volts"] == best["volts"],
              "comfort at equal road holding: the best body acc among no-worse tyre loads")
        wk = pas["wk_comfort_at_equal_road_holding"]
        best_wk = min(ok, key=lambda g: g["body_accel_wk_rms"])
        check(wk is not None and wk["volts"] == best_wk["volts"],
              "Wk comfort at equal road holding: the best Wk among no-worse tyre loads")
    else:
        check(eq is None, "no passive point with a tyre load this low: null")
for f in ("comfort.png", "psd.png", "passive.dat", "psd.dat"):
    check(os.path.getsize(os.path.join(out, f)) > 0 if os.path.exists(os.path.join(out, f))
          else False, f"run --out wrote {f}")
p = hil("run", SCENARIO, "--set", "duration_s=3", "--set", "quarter_car.settle_s=1",
        "--passive-step", "0", "--json")
check(p.returncode in (0, 1) and "passive" not in json.loads(p.stdout),
      "--passive-step 0: no grid in the summary")
p = hil("run", SCENARIO, "--set", "duration_s=3", "--set", "quarter_car.settle_s=1",
        "--passive-step", "0.5")
check("comfort at equal road holding" in p.stdout and "best passive" in p.stdout,
      "text summary names the best passive and the comfort at equal road holding")

# SIGTERM during the grid (after the run): the grid stops, exit 128 + 15, no summary.
proc = subprocess.Popen([HIL, "run", SCENARIO, "--set", "duration_s=4", "--set",
                         "quarter_car.settle_s=1", "--passive-step", "0.01", "--json"],
                        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
seen = False
for line in proc.stderr:
    if line.startswith("passive grid: 10/226"):
        seen = True
        proc.send_signal(signal.SIGTERM)
        break
out_text, err_text = proc.communicate(timeout=120)
check(seen and proc.returncode == 128 + signal.SIGTERM and out_text == ""
      and "interrupted" in err_text,
      f"SIGTERM during the passive grid: exit 143, no summary ({proc.returncode})")

# --- study ------------------------------------------------------------------------------
SHORT_FLAGS = {"--scenario": SCENARIO, "--classes": "B,C", "--speeds": "10,20", "--duration": "3",
               "--passive-step": "0.25"}


def short(**override):
    flags = dict(SHORT_FLAGS)
    flags.update(override)
    return [x for kv in flags.items() for x in kv]


SHORT = short()
outs = []
for n in (1, 2):
    d = os.path.join(WORK, f"study{n}")
    p = hil("study", *SHORT, "--out", d)
    check(p.returncode == 0, f"study {n} exit 0 ({p.returncode}) {p.stderr[-400:]}")
    outs.append(d)
check("[4/4]" in p.stderr and "passive grid" in p.stderr, "progress lines on stderr")
rows = list(csv.DictReader(open(os.path.join(outs[0], "study.csv"))))
check(len(rows) == 8, f"CSV: 2 classes x 2 speeds x 2 laws = 8 rows ({len(rows)})")
for r in rows:
    check(all(v not in ("", None) for v in r.values()), f"every CSV cell filled: {r['class']} "
          f"{r['speed_m_s']} {r['law']}")
cells = {(r["class"], float(r["speed_m_s"]), r["law"]) for r in rows}
check(cells == {(c, s, l) for c in "BC" for s in (10.0, 20.0)
                for l in ("skyhook", "skyhook-on-off")}, "CSV: every class x speed x law")
sj = json.load(open(os.path.join(outs[0], "study.json")))
check(len(sj["cases"]) == 4 and all(len(c["laws"]) == 2 for c in sj["cases"]),
      "JSON: 4 cases with 2 laws each")
for c in sj["cases"]:
    check(len(c["grid"]) == 10, "JSON: each case has the 10-point grid")
    for l in c["laws"]:
        e = l["comfort_at_equal_road_holding"]
        row = [r for r in rows if r["class"] == c["class"] and float(r["speed_m_s"]) ==
               c["speed_m_s"] and r["law"] == l["law"]][0]
        if e is None:
            check(row["comfort_improvement_percent"] == "none", "CSV none where JSON null")
        else:
            check(abs(float(row["comfort_improvement_percent"]) - e["improvement_percent"]) < 1e-6,
                  f"CSV and JSON agree ({c['class']} {c['speed_m_s']} {l['law']})")
        check(l["violations"] == 0, "no command outside [0, E_max]")
table = open(os.path.join(outs[0], "study.txt")).read()
check(table.startswith("table compiled-in (CRC-32 0x") and ", plant quarter car" in table,
      "study.txt names the table and the plant first")
check(table.count("\n") == 2 + 2 + 4, "text table: what it ran on, a blank line, header, rule and "
      "4 rows")
for name in ("study.png", "comfort-B-10.png", "comfort-C-20.png"):
    check(os.path.exists(os.path.join(outs[0], name)), f"study wrote {name}")
for name in ("study.csv", "study.json", "study.txt"):
    a = open(os.path.join(outs[0], name), "rb").read()
    b = open(os.path.join(outs[1], name), "rb").read()
    check(a == b, f"same study twice: identical {name}")

# --- motion ratios ----------------------------------------------------------------------
d = os.path.join(WORK, "ratios")
p = hil("study", *short(**{"--classes": "C", "--speeds": "20"}), "--motion-ratios", "0.5,0.7",
        "--out", d)
check(p.returncode == 0, f"study --motion-ratios exit 0 ({p.returncode}) {p.stderr[-400:]}")
rows = list(csv.DictReader(open(os.path.join(d, "study.csv"))))
check(sorted((float(r["motion_ratio"]), r["law"]) for r in rows) ==
      [(0.5, "skyhook"), (0.5, "skyhook-on-off"), (0.7, "skyhook"), (0.7, "skyhook-on-off")],
      "CSV: one row per motion ratio x law")
rj = json.load(open(os.path.join(d, "study.json")))
check([c["motion_ratio"] for c in rj["cases"]] == [0.5, 0.7], "JSON: each case's motion ratio")
check(len(rj["cases"]) == 2 and rj["cases"][0]["grid"] != rj["cases"][1]["grid"],
      "the ratio reaches the plant: the two passive grids differ")
for name in ("comfort-C-20-r0.5.png", "comfort-C-20-r0.7.png"):
    check(os.path.exists(os.path.join(d, name)), f"study wrote {name}")
check("motion ratio 0.5" in p.stderr, "progress names the motion ratio")
table = open(os.path.join(d, "study.txt")).read()
check("| motion ratio |" in table and "| 0.5 |" in table, "text table has the motion ratio")

# The comfort goal on the full road: SH-ADD against the best passive at no worse tyre load.
d = os.path.join(WORK, "goal")
p = hil("study", "--scenario", SCENARIO, "--classes", "C", "--speeds", "20", "--laws", "sh-add",
        "--motion-ratios", "0.5,0.7", "--out", d)
check(p.returncode == 0, f"goal study exit 0 ({p.returncode}) {p.stderr[-400:]}")
gj = json.load(open(os.path.join(d, "study.json")))
by_ratio = {c["motion_ratio"]: c for c in gj["cases"]}
eq = by_ratio[0.5]["laws"][0]["comfort_at_equal_road_holding"]
check(eq is not None and eq["improvement_percent"] >= 15.0,
      f"motion ratio 0.5: SH-ADD >= 15 % over the best passive at no worse tyre load "
      f"({eq and eq['improvement_percent']})")
check(by_ratio[0.7]["best_passive"]["body_accel_rms"]["volts"] == 0.0,
      "motion ratio 0.7: 0 V is the most comfortable passive setting")
check(by_ratio[0.5]["best_passive"]["body_accel_rms"]["volts"] > 0.0,
      "motion ratio 0.5: a harder setting than 0 V is the most comfortable passive one")

# --- refusals ---------------------------------------------------------------------------
bad_dir = os.path.join(WORK, "bad")
for args, words in [
        (["--classes", "B,Z"], ["--classes", "'Z'"]),
        (["--classes", "B,B"], ["--classes", "twice"]),
        (["--speeds", "0"], ["--speeds", "(0, 100]"]),
        (["--speeds", "ten"], ["--speeds", "'ten'"]),
        (["--laws", "nosuch"], ["--laws 'nosuch'", "must be one of", "skyhook"]),
        (["--laws", "force"], ["--laws 'force'", "force demand"]),
        (["--laws", "skyhook:skyhook_gain"], ["--laws", "KEY=VALUE"]),
        (["--laws", "skyhook:skyhook_gain=-3"], ["--laws", "skyhook_gain"]),
        (["--laws", "skyhook:no_such_key=1"], ["--laws", "no_such_key"]),
        (["--passive-step", "0"], ["--passive-step", "step > 0"]),
        (["--duration", "1"], ["--duration", "settle"]),
        (["--duration", "-5"], ["--duration"]),
        (["--classes", ""], ["--classes"]),
        (["--speeds", ""], ["--speeds"]),
        (["--laws", ""], ["--laws"]),
        (["--motion-ratios", "0"], ["--motion-ratios", "[0.01, 1]"]),
        (["--motion-ratios", "0.5,1.5"], ["--motion-ratios", "'1.5'"]),
        (["--motion-ratios", "half"], ["--motion-ratios", "'half'"]),
        (["--motion-ratios", "0.5,0.5"], ["--motion-ratios", "twice"])]:
    p = hil("study", *short(**{args[0]: args[1]}), "--out", bad_dir)
    check(p.returncode == 2 and all(w in p.stderr for w in words),
          f"study {' '.join(args)}: exit 2 naming it ({p.returncode}: {p.stderr.strip()[:200]})")
check(not os.path.exists(bad_dir), "refused studies wrote nothing")
p = hil("study", "--scenario", os.path.join(SRC, "hil/scenarios/force-v1.toml"), "--out", bad_dir)
check(p.returncode == 2 and "not a quarter car" in p.stderr, "study of a damper scenario: exit 2")
p = hil("study", "--classes", "C")
check(p.returncode == 2 and "--scenario" in p.stderr, "study without --scenario: exit 2")
p = hil("study", "--scenario", os.path.join(WORK, "missing.toml"))
check(p.returncode == 2 and "missing.toml" in p.stderr, "missing scenario file: exit 2")
p = hil("run", os.path.join(SRC, "hil/scenarios/force-v1.toml"), "--passive-step", "0.1")
check(p.returncode == 2 and "--passive-step" in p.stderr and "not a quarter car" in p.stderr,
      "run --passive-step on a damper scenario: exit 2")
p = hil("run", SCENARIO, "--passive-step", "-1")
check(p.returncode == 2 and "--passive-step" in p.stderr, "run --passive-step -1: exit 2")
p = hil("run", SCENARIO, "--set", "quarter_car.passive_step_v=0.00001")
check(p.returncode == 2 and "passive_step_v" in p.stderr, "scenario passive_step_v too fine: exit 2")
p = hil("study", "--help")
check(p.returncode == 0 and "--classes" in p.stdout and "--laws" in p.stdout and
      "--motion-ratios" in p.stdout, "study --help")

print(f"{len(failures)} failure(s)")
sys.exit(1 if failures else 0)
