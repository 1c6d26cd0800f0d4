"""The documented installation works: `pip install --no-build-isolation` of the build's python
folder into a virtual environment (with the system's numpy) gives a module that runs outside
the build tree; no network is used (--no-index)."""
import os
import shutil
import subprocess
import sys

from conftest import PAPER_MODEL


def test_pip_install_of_the_build_folder(tmp_path):
    build_python = os.path.dirname(os.path.dirname(__import__("mrd").__file__))
    src = tmp_path / "src"  # a copy: pip leaves build files beside setup.py
    shutil.copytree(build_python, src, ignore=shutil.ignore_patterns("__pycache__"))
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--system-site-packages", venv], check=True)
    py = venv / "bin" / "python"
    p = subprocess.run([py, "-m", "pip", "install", "--no-build-isolation", "--no-index",
                        "--no-deps", "-q", src], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                       text=True)
    assert p.returncode == 0, p.stdout
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    code = ("import mrd, sys; m = mrd.load_model(sys.argv[1]); "
            "print(mrd.__file__); print(m.selected, len(m.terms()))")
    p = subprocess.run([py, "-c", code, PAPER_MODEL], cwd=tmp_path, env=env,
                       stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    assert p.returncode == 0, p.stdout
    where, selected = p.stdout.splitlines()[:2]
    assert where.startswith(str(venv)), where  # the installed copy, not the build's
    assert int(selected.split()[0]) >= 0
