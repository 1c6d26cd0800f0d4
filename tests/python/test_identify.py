"""Identification from Python: the model of `mrd identify` from files, arrays and a spec dict;
progress through logging; Ctrl-C stops it; bad specs and data raise the CLI's text."""
import json
import logging
import os
import signal
import tomllib

import numpy as np
import pytest

import mrd
from conftest import without_source, SRC, cli_error, run

PAPER_SPEC = os.path.join(SRC, "host", "specs", "paper.toml")


def comparable(model_json):
    """A model file without its wall-clock figures (elapsed_s)."""
    m = json.loads(model_json)
    for it in m["iterations"]:
        it.pop("elapsed_s", None)
    return m


@pytest.fixture(scope="module")
def cli_model(data_dir, tmp_path_factory):
    """`mrd identify` on v1 with the paper's spec, 4 iterations."""
    out = tmp_path_factory.mktemp("identify") / "cli.json"
    run(["mrd", "identify", "--data", data_dir / "v1.csv", "--spec", PAPER_SPEC,
         "--max-iterations", "4", "--threads", "2", "--out", out])
    return out.read_text()


def test_identify_is_the_cli(cli_model, data_dir, caplog):
    with caplog.at_level(logging.INFO, logger="mrd"):
        model = mrd.identify(str(data_dir / "v1.csv"), PAPER_SPEC, max_iterations=4, threads=1)
    assert comparable(model.to_json()) == comparable(cli_model)
    lines = [r.getMessage() for r in caplog.records if r.name == "mrd"]
    iterations = [l for l in lines if l.startswith("iteration ")]
    assert len(iterations) == len(model.iterations)
    assert "selected iteration" in lines[-1]


def test_identify_without_a_spec_chooses_as_the_cli(data_dir, tmp_path, caplog):
    """spec=None: both built-in specs run and the same one is kept as by mrd identify."""
    out = tmp_path / "cli.json"
    run(["mrd", "identify", "--data", data_dir / "v1.csv", "--max-iterations", "2",
         "--threads", "2", "--out", out])
    with caplog.at_level(logging.INFO, logger="mrd"):
        model = mrd.identify(str(data_dir / "v1.csv"), max_iterations=2, threads=1)
    got, want = comparable(model.to_json()), comparable(out.read_text())
    assert got["spec_choice"] == want["spec_choice"]
    assert got["iterations"] == want["iterations"]
    lines = [r.getMessage() for r in caplog.records if r.name == "mrd"]
    assert any(l.startswith("built-in spec 2/2: nees.toml (built in)") for l in lines)


def test_identify_from_arrays_and_a_spec_dict(cli_model, data_dir):
    names = open(data_dir / "v1.csv").readline().strip().split(",")
    table = np.loadtxt(data_dir / "v1.csv", delimiter=",", skiprows=1)
    arrays = {n: table[:, i].copy() for i, n in enumerate(names)}
    with open(PAPER_SPEC, "rb") as f:
        spec = tomllib.load(f)
    model = mrd.identify(arrays, spec, max_iterations=4, threads=2)
    got, want = comparable(model.to_json()), comparable(cli_model)
    # The same search and numbers; only the provenance differs (arrays, a spec made in memory;
    # a state the invertibility check names is "data row N" instead of "<file> row N").
    got, want = without_source(got), without_source(want)
    for key in ("iterations", "selected", "selection_rule", "channels", "warmup_samples"):
        assert got[key] == want[key], key
    assert got["identification_data"] == ["data"]
    assert tomllib.loads(mrd.spec_toml(spec)) == spec


def test_ctrl_c_stops_at_the_next_iteration(data_dir):
    class InterruptAtFirst(logging.Handler):
        def __init__(self):
            super().__init__()
            self.lines = []

        def emit(self, record):
            self.lines.append(record.getMessage())
            if record.getMessage().startswith("iteration   1:"):
                os.kill(os.getpid(), signal.SIGINT)  # as Ctrl-C

    log = logging.getLogger("mrd.test-interrupt")
    handler = InterruptAtFirst()
    log.addHandler(handler)
    log.setLevel(logging.INFO)
    try:
        with pytest.raises(KeyboardInterrupt):
            mrd.identify(str(data_dir / "identification.csv"), PAPER_SPEC, max_iterations=20,
                         threads=1, log=log)
    finally:
        log.removeHandler(handler)
    # Iterations 0 and 1 were reported; the search stopped at the next one.
    assert [l[:14] for l in handler.lines] == ["iteration   0:", "iteration   1:"]


def test_bad_specs_raise_the_cli_text(data_dir, tmp_path):
    data = str(data_dir / "v1.csv")
    cases = {
        "unknown key": 'output = "f"\nfoo = 1\n',
        "no regressors": 'output = "f"\n',
        "bad power": 'output = "f"\n[[regressor]]\nname = "y"\nsignal = "f"\n'
                     'transform = "identity"\npowers = [0]\ndelays = [1]\n',
        "not TOML": "output = \n",
    }
    for what, text in cases.items():
        spec = tmp_path / "spec.toml"
        spec.write_text(text)
        expected = cli_error(["mrd", "identify", "--data", data, "--spec", spec, "--out",
                              tmp_path / "m.json"])
        with pytest.raises(ValueError) as e:
            mrd.identify(data, str(spec))
        assert str(e.value) == expected, what
    with pytest.raises(FileNotFoundError) as e:
        mrd.identify(data, str(tmp_path / "none.toml"))
    assert str(e.value) == cli_error(["mrd", "identify", "--data", data, "--spec",
                                      tmp_path / "none.toml", "--out", tmp_path / "m.json"])
    # A dict: the reason names the line of the TOML made from it, and shows it.
    with pytest.raises(ValueError, match=r"^spec \(dict\):\d+: .*\(line \d+ of the dict as TOML: "):
        mrd.identify(data, {"output": "f", "regressor": [{"name": "y", "signal": "f",
                                                           "transform": "identity",
                                                           "powers": [0], "delays": [1]}]})
    with pytest.raises(ValueError, match="is not a TOML value"):
        mrd.identify(data, {"output": object()})


def test_bad_options_and_data(data_dir, tmp_path):
    data = str(data_dir / "v1.csv")
    for kw in ({"threshold": 120.0}, {"max_iterations": -1}, {"threads": 1000},
               {"strategy": "worst"}, {"target_j": float("nan")}, {"max_candidates": 0}):
        with pytest.raises(ValueError):
            mrd.identify(data, PAPER_SPEC, **kw)
    with pytest.raises(ValueError) as e:
        mrd.identify(data, PAPER_SPEC, initial=["q(k-1)"])
    assert str(e.value) == cli_error(["mrd", "identify", "--data", data, "--spec", PAPER_SPEC,
                                      "--initial", "q(k-1)", "--out", tmp_path / "m.json"])
    flat = tmp_path / "flat.csv"
    flat.write_text("t,x,v,E,f\n" + "".join(f"{k / 1000},0,1,0,5\n" for k in range(200)))
    with pytest.raises(ValueError) as e:
        mrd.identify(str(flat), PAPER_SPEC)
    assert str(e.value) == cli_error(["mrd", "identify", "--data", flat, "--spec", PAPER_SPEC,
                                      "--out", tmp_path / "m.json"])
    with pytest.raises(ValueError, match="no identification data"):
        mrd.identify([], PAPER_SPEC)
