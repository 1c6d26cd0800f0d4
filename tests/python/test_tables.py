"""Coefficient tables from Python: the firmware's inversion and model runtime on arrays give
the firmware's own commands and forces bit for bit (its per-period log of a dry run); reading and
checking a table refuses what the firmware refuses, with its words."""
import numpy as np
import pytest

import mrd
from conftest import PAPER_MODEL, SRC, cli_error, run


def same_bits(a, b):
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    return a.shape == b.shape and a.tobytes() == b.tobytes()


def dry_run(tmp_path, table=None, config=None, seconds=3):
    """The firmware's lockstep dry run (force tracking on its simulated damper) with its log."""
    log = tmp_path / "run.mrdlog"
    argv = ["mrd-firmware", "--dry-run", seconds, "--lockstep", "--log", log]
    argv += ["--table", table] if table else []
    argv += ["--config", config] if config else []
    run(argv)
    return mrd.read_log(log, frame=False)


def builtin_table(tmp_path):
    path = tmp_path / "builtin.bin"
    run(["mrd-firmware", "--write-table", path])
    return path


def check_replay(table, log, **kw):
    """Table.invert and Table.simulate on the log's inputs give the log's outputs exactly."""
    safe = log["safe"] == 1
    assert log["force_law"][~safe].all(), "the dry run's law is force tracking"
    # Periods in the safe state sent the safe voltage: replayed as fixed commands.
    fixed = np.where(safe, log["command"], np.nan)
    r = table.invert(log["v_used"], log["x_used"], log["force_demand"], command=fixed, **kw)
    assert same_bits(r["E"], log["command"])
    assert same_bits(r["E"][~safe], log["e_law"][~safe])
    assert same_bits(r["force"], log["model_force"])
    assert (r["reachable"][~safe] == (log["reachable"][~safe] == 1)).all()
    assert same_bits(table.simulate(log["v_used"], log["x_used"], log["command"], **kw),
                     log["model_force"])
    return safe


def test_invert_is_the_firmware_builtin_table(tmp_path):
    table = mrd.read_table(builtin_table(tmp_path))
    log = dry_run(tmp_path)
    safe = check_replay(table, log)
    assert (~safe).sum() > 2000  # nearly all of the 3 s were inverted


def test_invert_is_the_firmware_exported_paper_model(tmp_path):
    path = tmp_path / "paper.bin"
    run(["mrd", "export", "--model", PAPER_MODEL, "--table", path])
    table = mrd.read_table(path)
    assert table.to_bytes() == path.read_bytes()
    assert table.has_envelope and table.input == "E" and table.output == "f"
    # A config narrowing E_max and widening the envelope margin: both sides use it.
    config = tmp_path / "fw.toml"
    config.write_text("[control]\ne_max = 2.0\n\n[envelope]\nmargin = 0.2\n")
    log = dry_run(tmp_path, table=path, config=config)
    check_replay(table, log, config=str(config))
    assert log["command"].max() <= 2.0
    # The same without the config's settings gives other commands: the settings matter.
    other = table.invert(log["v_used"], log["x_used"], log["force_demand"])
    assert not same_bits(other["E"], log["command"])


def test_invert_without_the_model_history_is_not_the_firmware(tmp_path):
    """The replay check can fail: feeding the demand one period late changes the commands."""
    table = mrd.read_table(builtin_table(tmp_path))
    log = dry_run(tmp_path)
    late = np.roll(log["force_demand"], 1)
    r = table.invert(log["v_used"], log["x_used"], late)
    assert not same_bits(r["E"], log["command"])


def test_check_table_is_the_firmware_check(tmp_path):
    good = builtin_table(tmp_path)
    assert mrd.check_table(good) is None
    image = bytearray(good.read_bytes())
    image[1700] ^= 0x40  # a coefficient: the CRC no longer matches
    bad = tmp_path / "bad.bin"
    bad.write_bytes(bytes(image))
    with pytest.raises(ValueError) as e:
        mrd.check_table(bad)
    assert str(e.value) == cli_error(["mrd-firmware", "--check-table", bad])
    with pytest.raises(FileNotFoundError) as e:
        mrd.check_table(tmp_path / "none.bin")
    assert str(e.value) == cli_error(["mrd-firmware", "--check-table", tmp_path / "none.bin"])
    config = tmp_path / "fw.toml"
    config.write_text("[control]\ne_max = 9.0\n")  # beyond the table's 2.25 V
    with pytest.raises(ValueError) as e:
        mrd.check_table(good, config=config)
    assert str(e.value) == cli_error(["mrd-firmware", "--check-table", good, "--config", config])
    # read_table refuses with the words mrd-hil uses for a table it will not run.
    with pytest.raises(ValueError) as e:
        mrd.read_table(bad)
    scenario = "hil/scenarios/force-periodic.toml"
    assert str(e.value) == cli_error(["mrd-hil", "run", f"{SRC}/{scenario}", "--table", bad])
    with pytest.raises(ValueError, match="^table image: "):
        mrd.table_from_bytes(bytes(image))
    assert mrd.table_from_bytes(good.read_bytes()).to_bytes() == good.read_bytes()


def test_inversion_check_and_settings_refusals(tmp_path):
    table = mrd.read_table(builtin_table(tmp_path))
    check = table.inversion()
    assert check["invertible"] and check["problem"] == "none" and 1 <= check["degree"] <= 4
    v = np.zeros(10)
    with pytest.raises(ValueError, match="e_max 3 V is outside the table's range"):
        table.invert(v, v, v, e_max=3.0)
    with pytest.raises(ValueError, match="envelope_margin"):
        table.invert(v, v, v, envelope_margin=-0.5)
    with pytest.raises(ValueError, match="^command: row 2: 5 V is outside"):
        table.invert(v, v, v, command=[np.nan, np.nan, 5.0] + [np.nan] * 7)
