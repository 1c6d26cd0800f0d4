"""Model files from Python: simulate gives the numbers of `mrd simulate` bit for bit, on a file
and on arrays; the envelope check and table export are the CLI's; bad input raises ValueError or
OSError with the CLI's text."""
import csv
import json
import os
import warnings

import numpy as np
import pytest

import mrd
from conftest import PAPER_MODEL, without_source, cli_error, cli_json, run


def csv_columns(path):
    """A CSV as {name: list of the field texts}."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return {name: [r[i] for r in rows[1:]] for i, name in enumerate(rows[0])}


def arrays(path):
    """A data file as a dict of float64 arrays, parsed by numpy (not by the toolkit)."""
    names = open(path).readline().strip().split(",")
    table = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return {n: table[:, i].copy() for i, n in enumerate(names)}


def same_bits(a, b):
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    return a.shape == b.shape and a.tobytes() == b.tobytes()


@pytest.mark.parametrize("profile", ["v1", "v2", "wide", "nees"])
def test_simulate_is_the_cli(profile, data_dir, nees_held, tmp_path):
    data = nees_held if profile == "nees" else data_dir / f"{profile}.csv"
    out = tmp_path / "sim.csv"
    cli = cli_json(["mrd", "simulate", "--model", PAPER_MODEL, "--data", data, "--json"])
    model = mrd.load_model(PAPER_MODEL)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mrd.EnvelopeWarning)
        warnings.simplefilter("ignore", mrd.InvertibilityWarning)
        from_file = model.simulate(str(data))
        from_arrays = model.simulate(arrays(data))
    for key, value in cli.items():  # every number of --json, exactly (JSON round-trips doubles)
        assert from_file[key] == value, key
        # Arrays have no file name: a state the invertibility check names is "data row N".
        assert without_source(from_arrays[key]) == without_source(value), key
    # The simulated force: the same doubles from the file and from arrays (NaN where the free
    # run diverged: the paper model on data far outside its envelope).
    assert same_bits(from_file["f_sim"], from_arrays["f_sim"])
    if cli["diverged"]:
        assert profile in ("wide", "nees")  # the identification's own validation sets never
        return                              # diverge; --out refuses non-finite values
    # The CLI's --out text (10 significant digits) for every row.
    run(["mrd", "simulate", "--model", PAPER_MODEL, "--data", data, "--out", out])
    sim = csv_columns(out)
    assert [format(v, ".10g") for v in from_file["f_sim"]] == sim["f_sim"]
    assert [format(v, ".10g") for v in from_file["t"]] == sim["t"]
    assert [format(v, ".10g") for v in from_file["f"]] == sim["f"]


def test_simulate_other_iteration_and_the_envelope_warning(data_dir):
    model = mrd.load_model(PAPER_MODEL)
    data = str(data_dir / "wide.csv")
    cli = run(["mrd", "simulate", "--model", PAPER_MODEL, "--data", data, "--iteration", "3",
               "--json"])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        r = model.simulate(data, iteration=3)
    assert {k: v for k, v in r.items() if k not in ("t", "f", "f_sim")} == json.loads(cli.stdout)
    # The CLI's stderr lines, as warnings.
    expected = [l[len("warning: "):] for l in cli.stderr.splitlines() if l.startswith("warning: ")]
    assert expected and [str(w.message) for w in caught] == expected
    assert all(w.category is (mrd.InvertibilityWarning if ": invertibility in " in str(w.message)
                              else mrd.EnvelopeWarning) for w in caught)
    assert model.check_envelope(data) == r["envelope"]


def test_model_attributes_and_round_trip(tmp_path, data_dir):
    model = mrd.load_model(PAPER_MODEL)
    on_disk = json.load(open(PAPER_MODEL))
    assert model.selected == on_disk["selected"]
    assert model.output == on_disk["spec"]["output"] == "f"
    assert model.inputs == [c["name"] for c in on_disk["channels"][1:]]
    assert len(model.iterations) == len(on_disk["iterations"])
    sel = [it for it in model.iterations if it["iteration"] == model.selected][0]
    assert list(model.coefficients()) == [t["coefficient"] for t in sel["terms"]]
    assert len(model.terms()) == len(sel["terms"])
    assert [c["name"] for c in model.channels] == [c["name"] for c in on_disk["channels"]]
    saved = tmp_path / "copy.json"
    model.save(saved)
    assert mrd.load_model(saved).to_json() == model.to_json()
    data = data_dir / "v1.csv"
    assert cli_json(["mrd", "simulate", "--model", saved, "--data", data, "--json"]) == \
        cli_json(["mrd", "simulate", "--model", PAPER_MODEL, "--data", data, "--json"])


def test_table_is_mrd_export(tmp_path):
    model = mrd.load_model(PAPER_MODEL)
    for args, kw in (([], {}), (["--iteration", "5", "--e-max", "2.0"],
                                {"iteration": 5, "e_max": 2.0})):
        out = tmp_path / "t.bin"
        run(["mrd", "export", "--model", PAPER_MODEL, "--table", out] + args)
        table = model.table(**kw)
        assert table.to_bytes() == out.read_bytes()
        assert table.inversion()["invertible"]
    with pytest.raises(ValueError) as e:
        model.table(input="x")
    assert str(e.value) == cli_error(["mrd", "export", "--model", PAPER_MODEL, "--table",
                                      tmp_path / "x.bin", "--input", "x"])
    with pytest.raises(ValueError) as e:
        model.table(e_min=2.0, e_max=1.0)
    assert str(e.value) == cli_error(["mrd", "export", "--model", PAPER_MODEL, "--table",
                                      tmp_path / "x.bin", "--e-min", "2", "--e-max", "1"])


def write(path, text):
    path.write_text(text)
    return path


def bad_inputs(tmp_path, data_dir):
    """(description, model path, data path, exception type): each a bad input the CLI refuses."""
    good = str(data_dir / "v1.csv")
    rows = open(good).read().splitlines()
    nan_row = rows[:5] + [rows[5].rsplit(",", 1)[0] + ",nan"] + rows[6:20]
    jump = rows[:8] + ["0.5," + rows[8].split(",", 1)[1]] + rows[9:20]
    return [
        ("missing model", str(tmp_path / "nope.json"), good, FileNotFoundError),
        ("model is a directory", str(tmp_path), good, IsADirectoryError),
        ("model not JSON", str(write(tmp_path / "m.json", "{ not json")), good, ValueError),
        ("model without iterations",
         str(write(tmp_path / "m2.json", '{"format": "mrd-sem-model", "version": 1}')), good,
         ValueError),
        ("missing data", PAPER_MODEL, str(tmp_path / "nope.csv"), FileNotFoundError),
        ("data NaN", PAPER_MODEL, str(write(tmp_path / "nan.csv", "\n".join(nan_row) + "\n")),
         ValueError),
        ("data time jumps", PAPER_MODEL, str(write(tmp_path / "j.csv", "\n".join(jump) + "\n")),
         ValueError),
        ("data without v", PAPER_MODEL, str(write(tmp_path / "nov.csv", "t,x,E,f\n0,0,0,0\n0.001,0,0,0\n")),
         ValueError),
        ("one row", PAPER_MODEL, str(write(tmp_path / "one.csv", rows[0] + "\n" + rows[1] + "\n")),
         ValueError),
        ("empty data", PAPER_MODEL, str(write(tmp_path / "empty.csv", "")), ValueError),
    ]


def test_bad_input_raises_the_cli_text(tmp_path, data_dir):
    for what, model_path, data_path, kind in bad_inputs(tmp_path, data_dir):
        expected = cli_error(["mrd", "simulate", "--model", model_path, "--data", data_path])
        with pytest.raises(kind) as e:
            mrd.simulate(mrd.load_model(model_path), data_path)
        assert str(e.value) == expected, what
        assert isinstance(e.value, ValueError if kind is ValueError else OSError), what


def test_bad_iteration_is_the_cli_text(data_dir):
    data = str(data_dir / "v1.csv")
    expected = cli_error(["mrd", "simulate", "--model", PAPER_MODEL, "--data", data,
                          "--iteration", "999"])
    with pytest.raises(ValueError) as e:
        mrd.load_model(PAPER_MODEL).simulate(data, iteration=999)
    assert str(e.value) == expected


def test_arrays_are_checked_by_the_data_file_rules(data_dir):
    model = mrd.load_model(PAPER_MODEL)
    d = arrays(data_dir / "v1.csv")
    d["v"] = d["v"].copy()
    d["v"][7] = np.nan
    with pytest.raises(ValueError, match=r"^data: row 7: column 'v': non-finite value 'nan'$"):
        model.simulate(d)
    d = arrays(data_dir / "v1.csv")
    del d["E"]
    with pytest.raises(ValueError, match=r"^data: missing column 'E'"):
        model.simulate(d)
    d = arrays(data_dir / "v1.csv")
    d["t"] = d["t"][::-1].copy()
    with pytest.raises(ValueError, match=r"^data: row 1: time 't' is not increasing"):
        model.simulate(d)
    with pytest.raises(TypeError):
        model.simulate(42)


def test_read_data_is_the_csv_reader(data_dir, tmp_path):
    d = mrd.read_data(str(data_dir / "v2.csv"), frame=False)
    ref = arrays(data_dir / "v2.csv")
    assert list(d) == list(ref) and all(same_bits(d[k], ref[k]) for k in d)
    frame = mrd.read_data(str(data_dir / "v2.csv"), frame=True)
    assert list(frame.columns) == list(ref) and same_bits(frame["f"].to_numpy(), ref["f"])
    bad = write(tmp_path / "bad.csv", "t,x\n0,1\n0.001,abc\n")
    with pytest.raises(ValueError) as e:
        mrd.read_data(str(bad))
    assert str(e.value) == cli_error(["mrd", "slice", "--in", bad, "--from", "0", "--to", "1",
                                      "--out", tmp_path / "o.csv"])
