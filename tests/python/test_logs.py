"""Per-period logs from Python: every field with the values of `mrd log export --csv`, in its own
type; damaged files as `mrd log` treats them, with its words."""
import csv
import struct
import warnings

import numpy as np
import pytest

import mrd
from conftest import cli_error, run

DTYPES = {"u8": np.uint8, "u32": np.uint32, "u64": np.uint64, "i64": np.int64, "f64": np.float64}


@pytest.fixture(scope="module")
def log_path(tmp_path_factory):
    """A 2 s lockstep dry run's log (2000 records, several blocks)."""
    d = tmp_path_factory.mktemp("log")
    path = d / "run.mrdlog"
    run(["mrd-firmware", "--dry-run", "2", "--lockstep", "--log", path])
    return path


def exported(path, tmp_path, fields=None):
    out = tmp_path / "export.csv"
    run(["mrd", "log", "export", path, "--csv", out] + (["--fields", ",".join(fields)] if fields else []))
    with open(out, newline="") as f:
        rows = list(csv.reader(f))
    return {name: [r[i] for r in rows[1:]] for i, name in enumerate(rows[0])}


def assert_same_values(arrays, texts, types):
    assert list(arrays) == list(texts)
    for name, column in texts.items():
        a = arrays[name]
        assert a.dtype == DTYPES[types[name]], name
        assert len(a) == len(column), name
        if a.dtype == np.float64:  # shortest round-trip text: float() gives the same double
            expected = np.array([float(s) for s in column])
            nan = np.isnan(expected)
            assert (np.isnan(a) == nan).all(), name
            assert a[~nan].tobytes() == expected[~nan].tobytes(), name
        else:
            assert [int(v) for v in a] == [int(s) for s in column], name


def test_read_log_is_mrd_log_export(log_path, tmp_path):
    info = mrd.log_info(log_path)
    types = {f["name"]: f["type"] for f in info["fields"]}
    d = mrd.read_log(log_path, frame=False)
    assert info["records"] == 2000 and len(d["period"]) == 2000
    assert_same_values(d, exported(log_path, tmp_path), types)
    some = ["t_ns", "model_force", "force_demand", "command", "safe"]
    assert_same_values(mrd.read_log(log_path, fields=some, frame=False),
                       exported(log_path, tmp_path, some), types)
    assert info["text"] == run(["mrd", "log", "info", log_path]).stdout


def test_read_log_as_a_data_frame(log_path):
    frame = mrd.read_log(log_path, frame=True)
    d = mrd.read_log(log_path, frame=False)
    assert list(frame.columns) == list(d)
    for name in d:
        assert frame[name].dtype == d[name].dtype
        assert frame[name].to_numpy().tobytes() == d[name].tobytes()
    # frame=None: a DataFrame, pandas being installed here.
    assert type(mrd.read_log(log_path)).__name__ == "DataFrame"


def test_truncated_log_reads_to_its_last_whole_block_with_the_cli_note(log_path, tmp_path):
    cut = tmp_path / "cut.mrdlog"
    data = log_path.read_bytes()
    cut.write_bytes(data[:-100])
    p = run(["mrd", "log", "export", cut, "--csv", tmp_path / "cut.csv"])
    note = [l[len("note: "):] for l in p.stderr.splitlines() if l.startswith("note: ")]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        d = mrd.read_log(cut, frame=False)
    assert [str(w.message) for w in caught] == note and caught[0].category is mrd.LogWarning
    full = mrd.read_log(log_path, frame=False)
    n = len(d["period"])
    assert 0 < n < len(full["period"])
    assert all(d[k].tobytes() == full[k][:n].tobytes() for k in d)


def header_bytes(data):
    return struct.unpack_from("<I", data, 12)[0]


def test_damaged_logs_raise_the_cli_text(log_path, tmp_path):
    data = log_path.read_bytes()
    h = header_bytes(data)
    cases = []
    corrupt = bytearray(data)
    corrupt[h + 24 + 10] ^= 0xFF  # a record byte of the first block: its CRC fails
    cases.append(("corrupt.mrdlog", bytes(corrupt)))
    cases.append(("notlog.mrdlog", b"t,x\n0,1\n"))
    version = bytearray(data)
    version[8] = 9
    cases.append(("version.mrdlog", bytes(version)))
    cases.append(("short.mrdlog", data[: h - 3]))
    for name, content in cases:
        path = tmp_path / name
        path.write_bytes(content)
        expected = cli_error(["mrd", "log", "export", path, "--csv", tmp_path / "x.csv"])
        with pytest.raises(ValueError) as e:
            mrd.read_log(path)
        assert str(e.value) == expected, name
    with pytest.raises(ValueError) as e:
        mrd.read_log(log_path, fields=["command", "nope"])
    assert str(e.value) == cli_error(["mrd", "log", "export", log_path, "--csv",
                                      tmp_path / "x.csv", "--fields", "command,nope"])
    missing = tmp_path / "missing.mrdlog"
    with pytest.raises(FileNotFoundError) as e:
        mrd.read_log(missing)
    assert str(e.value) == cli_error(["mrd", "log", "export", missing, "--csv", tmp_path / "x.csv"])
    with pytest.raises(IsADirectoryError) as e:
        mrd.read_log(tmp_path)
    assert str(e.value) == cli_error(["mrd", "log", "export", tmp_path, "--csv", tmp_path / "x.csv"])
    # info reports a corrupt block instead of raising.
    info = mrd.log_info(tmp_path / "corrupt.mrdlog")
    assert info["damage"] == "corrupt" and info["records"] == 0
