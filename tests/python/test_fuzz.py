"""Fuzzing the bindings' inputs: wrong dtypes, NaN and infinities, empty, huge, misshapen and
mismatched arrays, odd paths, random table images and spec values. Each call either works or
raises ValueError, TypeError or OSError; nothing crashes the interpreter (a crash fails the
test run) and no other exception escapes."""
import os
import random

import numpy as np
import pytest

import mrd
from conftest import PAPER_MODEL, run

ALLOWED = (ValueError, TypeError, OSError)
pytestmark = pytest.mark.filterwarnings("ignore::mrd.EnvelopeWarning")


def bad_columns(n, rng):
    """Array-likes that are wrong in one way or another, and a few valid odd ones."""
    base = np.linspace(0.0, 1.0, n)
    return [
        base.astype(str), base.astype(object), base.astype(np.complex128), base > 0.5,
        base.astype("datetime64[s]") if n else np.array([], dtype="datetime64[s]"),
        np.full(n, np.nan), np.full(n, np.inf), np.full(n, -np.inf), np.full(n, 1e300),
        np.full(n, 1e101), np.full(n, -1e101), np.full(n, 5e-324),
        np.zeros(0), np.zeros((n, 2)), np.zeros((2, 3, 4)), np.float64(1.5), None, "abc",
        [1, "x", 3], [[1, 2], [3]], {"a": 1},
        np.broadcast_to(np.float64(0.0), (10 ** 12,)),      # huge, no memory behind it
        np.broadcast_to(np.float64(0.0), (2 ** 28 + 1,)),  # one beyond the limit
        base[::-1], base[::2], base.astype(">f8"), base.astype(np.float32),
        base.astype(np.int8), base.astype(np.uint64), (base * 1e3).astype(np.int64),
        np.arange(n, dtype=np.float16), list(base), tuple(base),
        rng.standard_normal(n), rng.standard_normal(n + 1), rng.standard_normal(max(n - 1, 0)),
    ]


def attempt(f, *a, **kw):
    try:
        return f(*a, **kw)
    except ALLOWED:
        return None


@pytest.fixture(scope="module")
def table(tmp_path_factory):
    path = tmp_path_factory.mktemp("fuzz") / "t.bin"
    run(["mrd", "export", "--model", PAPER_MODEL, "--table", path])
    return mrd.read_table(path)


def test_simulate_survives_bad_columns():
    model = mrd.load_model(PAPER_MODEL)
    rng = np.random.default_rng(1)
    n = 300
    good = {"t": np.arange(n) * 1e-3, "x": rng.standard_normal(n), "v": rng.standard_normal(n),
            "E": rng.uniform(0, 2.25, n), "f": rng.standard_normal(n) * 100}
    assert model.simulate(good)["samples"] > 0
    for name in good:
        for bad in bad_columns(n, rng):
            d = dict(good)
            d[name] = bad
            attempt(model.simulate, d)
    for data in (None, 42, [1, 2], {1: np.zeros(3)}, {}, {"t": []}, b"\x00", "", "a\x00b"):
        attempt(model.simulate, data)


def test_invert_and_simulate_survive_bad_arrays(table):
    rng = np.random.default_rng(2)
    n = 200
    v, x, d = rng.standard_normal(n), rng.standard_normal(n) * 0.1, rng.standard_normal(n) * 300
    assert len(table.invert(v, x, d)["E"]) == n
    for bad in bad_columns(n, rng):
        attempt(table.invert, bad, x, d)
        attempt(table.invert, v, bad, d)
        attempt(table.invert, v, x, bad)
        attempt(table.invert, v, x, d, command=bad)
        attempt(table.simulate, v, x, bad)
    for kw in ({"e_max": np.nan}, {"e_max": -1.0}, {"envelope_margin": np.nan},
               {"envelope_margin": 1e308}, {"config": "/nonexistent.toml"}, {"config": "\x00"}):
        attempt(table.invert, v, x, d, **kw)
    # Empty inputs are valid (nothing to do); extreme demands saturate, never fail.
    assert len(table.invert([], [], [])["E"]) == 0
    r = table.invert(v, x, np.full(n, 1e300))
    assert np.isfinite(r["E"]).all() and not r["reachable"].any()


def test_identify_survives_bad_data_and_specs():
    rng = np.random.default_rng(3)
    n = 120
    good = {"t": np.arange(n) * 1e-3, "x": rng.standard_normal(n), "v": rng.standard_normal(n),
            "E": rng.uniform(0, 2.25, n), "f": rng.standard_normal(n) * 100}
    spec = {"output": "f", "regressor": [
        {"name": "y", "signal": "f", "transform": "identity", "powers": [1], "delays": [1]},
        {"name": "u", "signal": "v", "transform": "identity", "powers": [1], "delays": [0]}],
        "algorithm": {"max_iterations": 2}}
    assert mrd.identify(good, spec, threads=1).selected >= 0
    for name in good:
        for bad in bad_columns(n, rng)[:22]:  # the wrong ones
            d = dict(good)
            d[name] = bad
            attempt(mrd.identify, d, spec, threads=1)
    junk = [None, 1, -1, 2 ** 70, 1.5, np.nan, "x", [], [1, "a"], {}, {"a": {"b": None}},
            object(), b"x", [[1], [2]], True]
    r = random.Random(4)
    for _ in range(200):
        s = {"output": "f", "regressor": [dict(spec["regressor"][0])]}
        target = r.choice([s, s["regressor"][0]])
        target[r.choice(["output", "name", "signal", "transform", "powers", "delays",
                         "exponent", "tau", "limits", "cost", "algorithm", "stress", "x"])] = \
            r.choice(junk)
        attempt(mrd.identify, good, s, threads=1)
    for s in (42, [], "", "\x00"):
        attempt(mrd.identify, good, s)


def test_paths_and_table_images_survive(tmp_path, table):
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    odd = ["", "\x00", "a\x00b", str(tmp_path), str(fifo), "/dev/zero", "/dev/null",
           str(tmp_path / "missing"), "x" * 5000, b"\xff\xfe", 3.5, None]
    for p in odd:
        for f in (mrd.load_model, mrd.read_table, mrd.read_log, mrd.log_info, mrd.read_data,
                  mrd.check_table):
            attempt(f, p)
    image = bytearray(table.to_bytes())
    r = random.Random(5)
    for _ in range(500):
        b = bytearray(image)
        for _ in range(r.randint(1, 4)):
            b[r.randrange(len(b))] = r.randrange(256)
        attempt(mrd.table_from_bytes, bytes(b[: r.choice([len(b), r.randrange(len(b) + 1)])]))
    for b in (b"", b"MRDT", bytes(4096), os.urandom(2216)):
        attempt(mrd.table_from_bytes, b)
    log = tmp_path / "x.mrdlog"
    for _ in range(200):
        log.write_bytes(bytes(r.randrange(256) for _ in range(r.randrange(200))))
        attempt(mrd.read_log, log)
        attempt(mrd.log_info, log)
