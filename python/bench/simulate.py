#!/usr/bin/env python3
"""Overhead of the Python module (a benchmark, not a test): a 40 000-sample run (`mrd generate
--profile identification --seed 1`: 40 s at 1 kHz) simulated with the paper model from Python,
against the same computation in C++ (build/tests/bench_python_simulate: what `mrd simulate
--json` computes) and the `mrd simulate` process itself.

  PYTHONPATH=build/python /usr/bin/python3 python/bench/simulate.py [--build build] [--repeat 40]

Rows (median and fastest of the repeats, CPU time in milliseconds; the process: wall time):
  file    Model.simulate(path)          vs  BM_SimulateCommand (read model and CSV, run, JSON)
  arrays  Model.simulate(dict of numpy) vs  BM_SimulateInMemory (check, run, envelope, metrics)
  process `mrd simulate --json` wall time (start-up, reading, output included), for context.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
import warnings


def timed(f, repeat, clock=time.thread_time):
    """Median and fastest of repeat calls [ms], by this thread's CPU time (the machine's load
    moves it less than the wall clock; the calls run on this thread)."""
    times = []
    for _ in range(repeat):
        t0 = clock()
        f()
        times.append((clock() - t0) * 1e3)
    return statistics.median(times), min(times)


def cpp(bench, model, data, name, repeat):
    out = subprocess.run([bench, model, data, f"--benchmark_filter=^{name}$",
                          f"--benchmark_repetitions={repeat}", "--benchmark_min_time=0.2",
                          "--benchmark_format=json"], check=True, stdout=subprocess.PIPE,
                         stderr=subprocess.DEVNULL, text=True).stdout
    runs = [b["cpu_time"] for b in json.loads(out)["benchmarks"]
            if b.get("run_type") == "iteration"]
    return statistics.median(runs), min(runs)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--source", default=os.path.dirname(os.path.dirname(os.path.dirname(
        os.path.abspath(__file__)))))
    ap.add_argument("--repeat", type=int, default=40)
    a = ap.parse_args()
    import mrd
    import numpy as np

    model_path = os.path.join(a.source, "firmware", "tables", "paper_model.json")
    bench = os.path.join(a.build, "tests", "bench_python_simulate")
    mrd_exe = os.path.join(a.build, "bin", "mrd")
    with tempfile.TemporaryDirectory() as tmp:
        data = os.path.join(tmp, "identification.csv")
        subprocess.run([mrd_exe, "generate", "--profile", "identification", "--seed", "1",
                        "--out", data], check=True, stdout=subprocess.DEVNULL)
        model = mrd.load_model(model_path)
        arrays = {k: np.asarray(v) for k, v in mrd.read_data(data, frame=False).items()}
        samples = len(arrays["t"])
        warnings.simplefilter("ignore", mrd.EnvelopeWarning)
        py_file = timed(lambda: mrd.simulate(mrd.load_model(model_path), data), a.repeat)
        py_arrays = timed(lambda: model.simulate(arrays), a.repeat)
        c_file = cpp(bench, model_path, data, "BM_SimulateCommand", a.repeat)
        c_arrays = cpp(bench, model_path, data, "BM_SimulateInMemory", a.repeat)
        process = timed(lambda: subprocess.run(
            [mrd_exe, "simulate", "--model", model_path, "--data", data, "--json"],
            check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL), a.repeat,
            time.perf_counter)
    print(f"{samples} samples, paper model, {a.repeat} repeats; median / fastest CPU time [ms]")
    print("| case | Python | C++ (the CLI's computation) | Python / C++ (median) |")
    print("|---|---|---|---|")
    for name, p, c in (("file: load model, read CSV, simulate", py_file, c_file),
                       ("arrays: check, simulate, metrics", py_arrays, c_arrays)):
        print(f"| {name} | {p[0]:.2f} / {p[1]:.2f} | {c[0]:.2f} / {c[1]:.2f} | "
              f"{p[0] / c[0]:.3f} |")
    print(f"| `mrd simulate --json` process | | {process[0]:.2f} / {process[1]:.2f} | |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
