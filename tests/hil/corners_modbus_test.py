#!/usr/bin/env python3
"""Four damper channels of one mrd-firmware closed in lockstep over one Modbus TCP link with the
full car (hil/scenarios/full-car-modbus-corners.toml: the four-corner maps, one sensor module and
one driver with four set-points served by the harness, the firmware the link's one master;
modal skyhook, fault policy "all", the rear-left corner's sensor block frozen for 100 ms). Runs
of 2 s of plant time (the fault at 1.5 s) to keep the wall time small:

  repeat      the same run twice: the summary (wall-time figures aside) and corners.csv are
              identical, byte for byte (sha256), and so is the commands' hash
  stall       the firmware stopped (SIGSTOP ... SIGCONT) for 150 ms at three moments: the same
  all         every corner commands its safe value within 2 periods of the detection on the
              rear-left corner, and recovers after the fault
  channel     per-corner skyhook, policy "channel": the rear-left corner goes safe, the other
              three command through the fault (no safe command), counted per corner
  devices     the firmware's summary names a device per channel (modbus, modbus1 .. modbus3),
              each with a read per period
  rtu         the same run over Modbus RTU (a pseudo-terminal): the same commands and corners.csv
  transport   --transport can on the Modbus maps is refused (exit 2), naming the lists

Usage: corners_modbus_test.py BIN_DIR SOURCE_DIR WORK_DIR
"""
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import corners_run_test as base  # noqa: E402

check = base.check
SETS = ("duration_s=2.0",)
STEPS = 2000


def main():
    bin_dir, src, work = sys.argv[1:4]
    scenario = os.path.join(src, "hil/scenarios/full-car-modbus-corners.toml")

    # repeat, all, devices
    a = base.run(bin_dir, scenario, os.path.join(work, "a"), sets=SETS)
    s = a["summary"]
    print(f"run a: exit {a['exit']} summary {a['hash']} corners.csv {a['rows']} commands "
          f"{s.get('corners', {}).get('commands_fnv1a')} wall {a['wall']:.2f} s", flush=True)
    check(a["exit"] == 0 and s["pass"], f"the corners run passes ({s.get('failures')})")
    check(s["transport"] == "modbus-tcp", f"over Modbus TCP by default ({s['transport']})")
    c = s["corners"]
    steps = s["steps"]
    check(steps == STEPS, f"{STEPS} periods ran ({steps})")
    for corner in c["per_corner"]:
        check(corner["commands"] == steps and corner["command_timeouts"] == 0,
              f"{corner['name']}: a command every period ({corner['commands']})")
        check(corner["rejected"] == 0, f"{corner['name']}: no request rejected")
    ride = c["ride"]
    check(ride["samples"] > 0 and 0.0 < ride["body_accel_rms"] < 10.0 and
          all(0.0 < t < 5000.0 for t in ride["tyre_load_rms_n"]),
          f"ride figures in range: body {ride['body_accel_rms']:.4g} m/s^2")
    with open(os.path.join(work, "a", "firmware.json")) as f:
        fw = json.load(f)
    names = sorted(fw["devices"])
    check(names == ["modbus", "modbus1", "modbus2", "modbus3"], f"a device per channel ({names})")
    for n in names:
        d = fw["devices"][n]
        check(d["rx_ok"] >= steps - 100 and d["tx_failed"] == 0,
              f"{n}: a read per period ({d['rx_ok']}), no failed write")
    with open(os.path.join(work, "a", "firmware.toml")) as f:
        cfg = f.read()
    check("modbus_profiles = [" in cfg and "\n[modbus]\nmode = \"tcp\"" in cfg and
          "[can]" not in cfg, "the firmware runs on [modbus] and [channels] modbus_profiles")
    base.check_policy_all(s)
    base.check_repeat_and_stall(bin_dir, scenario, work, a, sets=SETS)
    base.check_policy_channel(bin_dir, scenario, work, sets=SETS)

    # rtu
    r = base.run(bin_dir, scenario, os.path.join(work, "rtu"), sets=SETS,
                 extra=("--transport", "modbus-rtu"))
    rc = r["summary"]["corners"]
    print(f"run rtu: exit {r['exit']} corners.csv {r['rows']} commands "
          f"{rc.get('commands_fnv1a')} wall {r['wall']:.2f} s", flush=True)
    check(r["exit"] == 0 and r["summary"]["pass"] and r["summary"]["transport"] == "modbus-rtu",
          f"over Modbus RTU the run passes ({r['summary'].get('failures')})")
    check(rc["commands_fnv1a"] == c["commands_fnv1a"] and r["rows"] == a["rows"],
          "over RTU the same commands and corners.csv as over TCP")

    # transport
    p = subprocess.run([os.path.join(bin_dir, "mrd-hil"), "run", scenario, "--transport", "can",
                        "--out", os.path.join(work, "can")], capture_output=True, text=True)
    check(p.returncode == 2 and "on modbus_profiles run over --transport modbus-tcp or "
          "modbus-rtu" in p.stderr, f"--transport can on Modbus maps refused: {p.stderr.strip()}")

    print("corners_modbus_test: " + ("every check holds" if not base.failures else
                                     f"{len(base.failures)} FAILED"))
    return 0 if not base.failures else 1


if __name__ == "__main__":
    sys.exit(main())
