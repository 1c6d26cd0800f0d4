#!/usr/bin/env python3
"""Doc tests: the commands of the user docs run as written, and name only flags that exist.

  doc_blocks.py run   --source DIR --bin DIR [--python EXE --pythonpath DIR] PAGE.md...
                                                          run every runnable block
  doc_blocks.py flags --source DIR --bin DIR PAGE.md...   check every --flag against --help

A runnable block is a fenced block whose info string is `sh run` or `python run`:

    ```sh run
    mrd generate --profile v1 --seed 1 --out v1.csv
    ```

It is shown as a plain shell (Python) block and run by `run`: a `python run` block with
--python (default: this interpreter), --pythonpath first on PYTHONPATH (the build's Python
module, build/python). The blocks of one page run in order, each
in its own `bash -euo pipefail`, in one scratch directory per page that holds a symlink to
every top-level entry of the source tree but .git, out/ and build folders, and build/bin of the
build under test (so `host/specs/paper.toml` and `build/bin/mrd` resolve as in a clone); files the blocks write stay in the scratch directory, which is
removed afterwards (kept with --keep). build/bin is first on PATH. A block that exits non-zero
or runs past --timeout seconds (default 120) fails the page (processes a block leaves in the
background are killed when it ends); the message names the page, the
line of the block and the output's last lines. Shell variables do not carry from one block to
the next: each block sets what it uses.

`flags`: every command line (fenced block or inline code) that starts with mrd, mrd-firmware,
mrd-hil or mrd-canbus (a build/bin/ prefix allowed) or a toolchain/ script has each of its
--flags in the --help of that program and subcommand (`mrd identify --help`, `mrd log export --help`); a bare inline
`--flag` must be in the --help of a program or subcommand the page uses.
Exit 0 when everything holds, 1 otherwise (each failure printed), 2 on bad arguments.
"""
import argparse
import os
import re
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile

PROGRAMS = ("mrd", "mrd-firmware", "mrd-hil", "mrd-canbus")
FENCE = re.compile(r"^(\s*)(```+|~~~+)\s*(.*)$")


def blocks(path):
    """Yields (line number of the opening fence, info string, text) for each fenced block."""
    with open(path, encoding="utf-8") as f:
        lines = f.read().split("\n")
    i = 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        fence, info, start = m.group(2), m.group(3).strip(), i + 1
        body = []
        i += 1
        while i < len(lines) and not lines[i].strip().startswith(fence):
            body.append(lines[i])
            i += 1
        if i >= len(lines):
            raise SystemExit(f"{path}:{start}: unclosed fenced block")
        i += 1
        yield start, info, "\n".join(body) + "\n"


def prose(path):
    """The page's text outside fenced blocks."""
    out, inside = [], None
    with open(path, encoding="utf-8") as f:
        for line in f:
            m = FENCE.match(line)
            if m and inside is None:
                inside = m.group(2)
            elif inside is not None and line.strip().startswith(inside):
                inside = None
            elif inside is None:
                out.append(line)
    return "".join(out)


def run_page(page, source, bindir, timeout, keep, python=sys.executable, pythonpath=None):
    runnable = [(n, info.split()[0], text) for n, info, text in blocks(page)
                if info.split() in (["sh", "run"], ["python", "run"])]
    if not runnable:
        return [f"{page}: no runnable block (```sh run)"]
    scratch = tempfile.mkdtemp(prefix="mrd-doc-")
    for entry in os.listdir(source):  # not .git, the demo's out/ nor any build folder
        if entry not in (".git", "out") and not entry.startswith("build"):
            os.symlink(os.path.join(source, entry), os.path.join(scratch, entry))
    os.makedirs(os.path.join(scratch, "build"))  # build/bin: the build under test
    os.symlink(bindir, os.path.join(scratch, "build", "bin"))
    env = dict(os.environ, PATH=bindir + os.pathsep + os.environ.get("PATH", ""))
    if pythonpath:
        env["PYTHONPATH"] = os.pathsep.join(p for p in (pythonpath, env.get("PYTHONPATH")) if p)
    env["PYTHONDONTWRITEBYTECODE"] = "1"  # no __pycache__ in the source tree
    failures = []
    try:
        for n, kind, text in runnable:
            print(f"{page}:{n}: running\n" + "".join("    " + l + "\n" for l in text.splitlines()),
                  flush=True)
            if kind == "python":  # from a file, so a traceback names the block's lines
                script = os.path.join(scratch, f".doc-block-{n}.py")
                with open(script, "w", encoding="utf-8") as f:
                    f.write(text)
                argv = [python, script]
            else:
                argv = ["bash", "-euo", "pipefail", "-c", text]
            p = subprocess.Popen(argv, cwd=scratch, env=env,
                                 stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                 start_new_session=True)
            try:
                out, status = p.communicate(timeout=timeout)[0], p.returncode
            except subprocess.TimeoutExpired:
                status = f"timeout after {timeout} s"
                os.killpg(p.pid, signal.SIGKILL)
                out = p.communicate()[0]
            finally:
                try:  # whatever the block left running in the background goes with it
                    os.killpg(p.pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
            out = out.decode(errors="replace")
            if status != 0:
                tail = "\n".join("    | " + l for l in out.splitlines()[-25:])
                failures.append(f"{page}:{n}: block failed (exit {status}):\n{tail}")
                break  # later blocks build on this one
            print(f"{page}:{n}: ok", flush=True)
    finally:
        if keep:
            print(f"{page}: scratch directory kept: {scratch}")
        else:
            shutil.rmtree(scratch, ignore_errors=True)
    return failures


_help_cache = {}


def help_text(bindir, argv, source=None):
    key = tuple(argv)
    if key not in _help_cache:
        exe = [os.path.join(bindir, argv[0])]
        if argv[0].startswith("toolchain/"):  # a script of the tree: its own --help
            exe = ["bash", os.path.join(source or ".", argv[0])]
        try:
            p = subprocess.run(exe + argv[1:] + ["--help"],
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=30)
            _help_cache[key] = p.stdout.decode(errors="replace") if p.returncode == 0 else None
        except (OSError, subprocess.TimeoutExpired):
            _help_cache[key] = None
    return _help_cache[key]


def command_lines(page):
    """(line, text) of every command line: fenced lines (continuations joined) and inline code."""
    for n, _info, text in blocks(page):
        joined, first = "", None
        for k, line in enumerate(text.splitlines()):
            first = n + 1 + k if first is None else first
            if line.rstrip().endswith("\\"):
                joined += line.rstrip()[:-1] + " "
                continue
            yield first, joined + line
            joined, first = "", None
    for k, line in enumerate(prose(page).splitlines()):
        for code in re.findall(r"`([^`]+)`", line):
            yield None, code


def split_commands(text):
    """The simple commands of one shell line (split at ; && || | and a leading `$ `)."""
    text = re.sub(r"#.*$", "", text) if not text.lstrip().startswith("--") else text
    for part in re.split(r"&&|\|\||;|\||\$\(|\)|&", text):
        try:
            words = shlex.split(part)
        except ValueError:
            words = part.split()
        while words and re.match(r"^[A-Z_][A-Z0-9_]*=", words[0]):  # VAR=value prefixes
            words = words[1:]
        if words and words[0] in ("time", "exec", "sudo"):
            words = words[1:]
        if words:
            yield words


def check_flags(page, bindir, source):
    failures, used = [], set()
    bare = []
    for n, text in command_lines(page):
        where = f"{page}:{n}" if n else f"{page} (inline `{text.strip()}`)"
        if text.strip().startswith("--"):
            for flag in re.findall(r"(?<![\w-])(--[a-z][a-z0-9-]*)", text.split()[0]):
                bare.append((where, flag))
            continue
        for words in split_commands(text):
            prog = os.path.basename(words[0])
            if re.fullmatch(r"(\./)?toolchain/[\w.-]+", words[0]) and \
                    os.path.isfile(os.path.join(source, words[0])):
                prog = os.path.normpath(words[0])  # toolchain/deploy: checked against its --help
            elif prog not in PROGRAMS:
                continue
            argv = [prog]
            for w in ([] if prog.startswith("toolchain/") else words[1:3]):
                if re.fullmatch(r"[a-z][a-z-]*", w) and help_text(bindir, argv + [w]) is not None \
                        and help_text(bindir, argv + [w]) != help_text(bindir, argv):
                    argv.append(w)
                else:
                    break
            h = help_text(bindir, argv, source)
            if h is None:
                failures.append(f"{where}: `{' '.join(argv)} --help` fails")
                continue
            used.add(tuple(argv))
            for w in words[len(argv):]:
                m = re.fullmatch(r"(--[a-z][a-z0-9-]*)(=.*)?", w)
                if m and not re.search(r"(?<![\w-])" + re.escape(m.group(1)) + r"(?![\w-])", h):
                    failures.append(f"{where}: {m.group(1)} is not in `{' '.join(argv)} --help`")
    helps = [help_text(bindir, list(a), source) or "" for a in used]
    for where, flag in bare:
        if not any(re.search(r"(?<![\w-])" + re.escape(flag) + r"(?![\w-])", h) for h in helps):
            failures.append(f"{where}: {flag} is in the --help of no command the page uses")
    return failures


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("mode", choices=("run", "flags"))
    ap.add_argument("--source", required=True, help="the source tree (repository root)")
    ap.add_argument("--bin", required=True, help="the build's bin folder (mrd, mrd-hil, ...)")
    ap.add_argument("--timeout", type=float, default=120, help="seconds per block")
    ap.add_argument("--keep", action="store_true", help="keep the scratch directories")
    ap.add_argument("--python", default=sys.executable, help="interpreter of `python run` blocks")
    ap.add_argument("--pythonpath", help="put first on PYTHONPATH (the build's Python module)")
    ap.add_argument("pages", nargs="+")
    a = ap.parse_args()
    source, bindir = os.path.realpath(a.source), os.path.realpath(a.bin)
    failures = []
    for page in a.pages:
        if not os.path.isfile(page):
            print(f"error: {page}: no such page", file=sys.stderr)
            return 2
        if a.mode == "run":
            failures += run_page(page, source, bindir, a.timeout, a.keep, a.python,
                                 a.pythonpath and os.path.realpath(a.pythonpath))
        else:
            failures += check_flags(page, bindir, source)
    for f in failures:
        print("FAIL: " + f)
    print(f"doc_blocks {a.mode}: {len(a.pages)} page(s), {len(failures)} failure(s)")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
