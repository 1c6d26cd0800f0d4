"""HIL runs from Python: the summary of `mrd-hil run --json` as a dict (lockstep: everything but
the wall-clock figures identical), its files, Ctrl-C, and bad scenarios with the CLI's text."""
import json
import os
import signal
import threading

import pytest

import mrd
from conftest import SRC, cli_error, run

SCENARIOS = os.path.join(SRC, "hil", "scenarios")


def deterministic(summary):
    """A lockstep summary without what depends on the wall clock: `timing` (docs/hil_summary.md),
    the firmware's loop timing, the frames and grants counted up to the shutdown (`ports`, the
    firmware's `devices` and `clock.grants`: one more or less as the stop races the last
    frame) and how its log writer cut blocks (flush_ms), all of which differ between two
    `mrd-hil run`s alike."""
    s = json.loads(json.dumps(summary))
    s.pop("timing", None)
    s.pop("ports", None)
    fw = (s.get("firmware") or {}).get("summary") or {}
    fw.pop("devices", None)
    (fw.get("clock") or {}).pop("grants", None)
    for key in ("path", "blocks", "bytes"):  # path: each run's own folder
        (fw.get("log") or {}).pop(key, None)
    for key in list(fw):
        if any(w in key for w in ("latency", "exec", "jitter", "wall", "overrun", "late")):
            fw.pop(key)
    return s


@pytest.mark.parametrize("scenario,extra,kw", [
    ("force-periodic.toml", [], {}),
    ("quarter-car-skyhook.toml", ["--passive-step", "0.5", "--set", "duration_s=4"],
     {"passive_step": 0.5, "sets": ["duration_s=4"]}),
])
def test_run_scenario_is_mrd_hil_run(scenario, extra, kw, tmp_path):
    path = os.path.join(SCENARIOS, scenario)
    p = run(["mrd-hil", "run", path, "--json", "--out", tmp_path / "cli"] + extra, check=False)
    assert p.returncode in (0, 1), p.stderr
    cli = json.loads(p.stdout)
    summary = mrd.run_scenario(path, out=tmp_path / "out", **kw)
    assert deterministic(summary) == deterministic(cli)
    assert summary["pass"] == (p.returncode == 0)
    with open(tmp_path / "out" / "summary.json") as f:
        assert deterministic(json.load(f)) == deterministic(summary)
    log = mrd.read_log(tmp_path / "out" / "firmware.mrdlog", frame=False)
    assert len(log["command"]) >= summary["steps"] - 1


def children():
    """Process ids of this process's children."""
    out = []
    for task in os.listdir("/proc/self/task"):
        with open(f"/proc/self/task/{task}/children") as f:
            out += [int(p) for p in f.read().split()]
    return out


def test_ctrl_c_stops_the_run_and_its_firmware(tmp_path):
    before = set(children())
    timer = threading.Timer(1.0, os.kill, (os.getpid(), signal.SIGINT))
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            mrd.run_scenario(os.path.join(SCENARIOS, "force-periodic.toml"),
                             sets=["duration_s=600"])
    finally:
        timer.cancel()
    assert set(children()) <= before  # the firmware child was stopped and reaped


def test_bad_scenarios_raise_the_cli_text(tmp_path):
    good = os.path.join(SCENARIOS, "force-periodic.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "x"\nduration_s = -1\n')
    unknown = tmp_path / "unknown.toml"
    unknown.write_text('[nope]\nx = 1\n')
    cases = [
        ([str(bad)], {}, ValueError),
        ([str(unknown)], {}, ValueError),
        ([str(tmp_path / "missing.toml")], {}, FileNotFoundError),
        ([good, "--set", "duration_s=abc"], {"sets": ["duration_s=abc"]}, ValueError),
        ([good, "--set", "control.law=nope"], {"sets": ["control.law=nope"]}, ValueError),
    ]
    for argv, kw, kind in cases:
        expected = cli_error(["mrd-hil", "run"] + argv)
        with pytest.raises(kind) as e:
            mrd.run_scenario(argv[0], **kw)
        assert str(e.value) == expected, argv
    with pytest.raises(FileNotFoundError, match="not an executable"):
        mrd.run_scenario(good, firmware=tmp_path / "no-firmware")
