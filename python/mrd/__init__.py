"""The MRD toolkit from Python: model files, simulation, identification, coefficient tables and
the firmware's inversion, per-period logs and HIL runs, with numpy arrays (docs/python.md).

Everything here calls the toolkit's C++ libraries (the extension mrd._mrd); this file only adds
defaults, Python's logging and pandas frames. Errors are ValueError (bad input) or OSError (a
file that cannot be read or written) with the text the command-line tools print after
"error: ".
"""
import logging
import os
import shutil

from ._mrd import (  # noqa: F401  (the module's interface)
    EnvelopeWarning,
    InvertibilityWarning,
    LogWarning,
    Model,
    Table,
    __version__,
    check_table,
    load_model,
    log_info,
    simulate,
    spec_toml,
    read_table,
    table_from_bytes,
)
from . import _mrd

__all__ = [
    "EnvelopeWarning", "InvertibilityWarning", "LogWarning", "Model", "Table", "check_table", "identify",
    "load_model", "log_info", "read_data", "read_log", "read_table", "run_scenario",
    "simulate", "spec_toml", "table_from_bytes",
]

logger = logging.getLogger("mrd")


def _frame(columns, frame):
    """columns (a dict of arrays) as a pandas DataFrame when frame is True, or None and pandas
    is installed; else the dict."""
    if frame is False:
        return columns
    try:
        import pandas
    except ImportError:
        if frame:
            raise
        return columns
    return pandas.DataFrame(columns, copy=False)


def read_data(path, frame=None):
    """A data file (CSV t,x,v,E,f...) read and checked as every mrd command reads it: a dict of
    float64 arrays by column, or a pandas DataFrame (frame=None: when pandas is installed)."""
    return _frame(_mrd._read_data(path), frame)


def read_log(path, fields=None, frame=None):
    """The firmware's per-period log (.mrdlog) as `mrd log export --csv` reads it: every field
    (or those named) as a numpy array of its own type (float64, int64, uint8, ...), in a dict
    or a pandas DataFrame (frame=None: when pandas is installed). A file cut inside its last
    block is read up to its last whole block with a LogWarning; a corrupt block is an error."""
    return _frame(_mrd._read_log(path, fields), frame)


def identify(data, spec=None, *, validate=None, threads=0, max_iterations=None,
             threshold=None, target_j=None, strategy=None, initial=None,
             max_candidates=None, log=None):
    """SEM identification as `mrd identify` runs it; returns the Model.

    data, validate: a data file path, a dict or DataFrame of arrays (t and the spec's signals),
    or a list of them. spec: a spec file (host/specs/*.toml), the same as a dict, or None for
    the built-in default. The other arguments are mrd identify's options. Progress lines go to
    the logger `log` (default: logging.getLogger("mrd"), level INFO); Ctrl-C stops at the end
    of the iteration under way and raises KeyboardInterrupt.
    """
    if isinstance(initial, str):
        initial = [t for t in initial.split(",") if t.strip()]
    out = log if log is not None else logger
    return _mrd._identify(data, spec, validate, threads, max_iterations, threshold, target_j,
                          strategy, initial, max_candidates, out.info)


def _firmware():
    """mrd-firmware of this build, else the first on PATH."""
    built = os.path.join(_mrd.bin_dir, "mrd-firmware")
    if os.access(built, os.X_OK):
        return built
    return shutil.which("mrd-firmware") or built


def run_scenario(scenario, *, sets=(), firmware=None, table=None, out=None, transport="can",
                 clock="lockstep", profile=None, passive_step=None, startup_timeout=10.0,
                 command_timeout=10.0, log=None):
    """A HIL scenario against an mrd-firmware child, as `mrd-hil run` runs it; returns the
    summary of `mrd-hil run --json` as a dict (keys: docs/hil_summary.md; "pass" says whether
    the scenario's criteria hold). sets: overrides "KEY=VALUE" (mrd-hil run --set). out: a
    folder for summary.json, trace.csv, firmware.mrdlog and the plots. Ctrl-C stops the run
    (KeyboardInterrupt)."""
    if isinstance(sets, str):
        sets = [sets]
    out_log = log if log is not None else logger
    return _mrd._run_scenario(scenario, list(sets), os.fspath(firmware or _firmware()), table,
                              out, transport, clock, profile, passive_step,
                              float(startup_timeout), float(command_timeout), out_log.info)
