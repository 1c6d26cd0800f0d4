"""Shared fixtures of the Python module's tests (label python): the build's programs, the
source tree, data sets made once per session, and the CLI run for comparison.

Environment (set by tests/python/CMakeLists.txt): MRD_BIN_DIR (build/bin), MRD_SOURCE_DIR,
PYTHONPATH with build/python.
"""
import json
import os
import re
import subprocess

import pytest

BIN = os.environ.get("MRD_BIN_DIR", "build/bin")
SRC = os.environ.get("MRD_SOURCE_DIR", ".")
PAPER_MODEL = os.path.join(SRC, "firmware", "tables", "paper_model.json")


def run(argv, check=True, cwd=None):
    """Runs a program of the build (argv[0] a name in build/bin); returns the CompletedProcess
    with text stdout and stderr."""
    p = subprocess.run([os.path.join(BIN, argv[0])] + [str(a) for a in argv[1:]],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=cwd)
    if check and p.returncode != 0:
        raise AssertionError(f"{argv} exit {p.returncode}: {p.stderr}")
    return p


def cli_error(argv):
    """The CLI's error text for a bad input: what it prints after 'error: ' (exit status 2)."""
    p = run(argv, check=False)
    assert p.returncode == 2, f"{argv}: exit {p.returncode}, stderr {p.stderr!r}"
    lines = [l for l in p.stderr.splitlines() if l.startswith("error: ")]
    assert lines, p.stderr
    return lines[-1][len("error: "):]


def cli_json(argv):
    return json.loads(run(argv).stdout)


@pytest.fixture(scope="session")
def data_dir(tmp_path_factory):
    """Reference data sets of `mrd generate` (seed 1): v1, v2, wide (20 s) and identification
    (40 s)."""
    d = tmp_path_factory.mktemp("data")
    for profile in ("v1", "v2", "wide", "identification"):
        run(["mrd", "generate", "--profile", profile, "--seed", "1", "--out", d / f"{profile}.csv"])
    return d


@pytest.fixture(scope="session")
def nees_held(tmp_path_factory):
    """The NEES bench run shipped in tests/data/, imported at 1 kHz as the demo imports it, and
    its held-out part (14-19.5 s)."""
    d = tmp_path_factory.mktemp("nees")
    run(["mrd", "import", "--in", os.path.join(SRC, "tests", "data", "nees-2012-1158",
                                               "ransim_u.csv"),
         "--map", "t=t,x=D,v=V,E=Y,f=F", "--rate", "1000", "--out", d / "nees.csv"])
    run(["mrd", "slice", "--in", d / "nees.csv", "--from", "14", "--to", "19.5",
         "--out", d / "held.csv"])
    return d / "held.csv"


def without_source(x):
    """x (JSON-like) with the data source of "(<source> row N)" state names dropped: a file's
    name and "data" (arrays) then compare equal."""
    if isinstance(x, dict):
        return {k: without_source(v) for k, v in x.items()}
    if isinstance(x, list):
        return [without_source(v) for v in x]
    if isinstance(x, str):
        return re.sub(r"\([^()]* row (\d+)\)", r"(row \1)", x)
    return x
