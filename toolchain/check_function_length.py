#!/usr/bin/env python3
"""Lists C++ function bodies longer than a limit (default 150 lines) in the source folders.

A function is a brace block opened at namespace or class level by a line whose text before the
'{' ends in ')' plus qualifiers (const, override, noexcept, -> type, a constructor's
initialiser list). Data tables are exempt by name in ALLOWED (a table of keys or help text is
long by nature). Exit 1 and one line per function over the limit: FILE:LINE NAME LENGTH.

Usage: check_function_length.py [--limit N] [ROOT]
"""
import os
import re
import sys

FOLDERS = ["common", "host", "firmware", "hil", "python/src"]
# Data tables: one entry per key / help section; long by nature, not by doing many things.
ALLOWED = {
    ("firmware/platform/src/config_keys.cpp", "KeyTable"),
}
HEAD = re.compile(r"([A-Za-z_~][\w:~<>]*)\s*\([^;]*\)\s*(const)?\s*(noexcept)?\s*(override|final)?"
                  r"\s*(->\s*[\w:<>,\s\*&]+)?\s*(:.*)?\{\s*(//.*)?$")
CONTROL = {"if", "for", "while", "switch", "catch", "return", "else", "do", "sizeof", "decltype"}


def strip(line):
    line = re.sub(r'"(\\.|[^"\\])*"', '""', line)
    line = re.sub(r"'(\\.|[^'\\])*'", "''", line)
    return line.split("//")[0]


def functions(path):
    with open(path, encoding="utf-8", errors="replace") as f:
        lines = f.readlines()
    depth, stack, out, in_comment, head_buf = 0, [], [], False, ""
    for i, raw in enumerate(lines, 1):
        line = raw
        if in_comment:
            if "*/" not in line:
                continue
            line = line.split("*/", 1)[1]
            in_comment = False
        if "/*" in line and "*/" not in line.split("/*", 1)[1]:
            line, in_comment = line.split("/*", 1)[0], True
        code = strip(line)
        if not code.strip() or code.lstrip().startswith("#"):
            continue
        head_buf = (head_buf + " " + code.strip())[-400:]
        for ch in code:
            if ch == "{":
                m = HEAD.search(head_buf.split(";")[-1].split("}")[-1])
                name = m.group(1).split("::")[-1] if m else None
                is_fn = (name is not None and name not in CONTROL and
                         all(s[2] is None for s in stack))  # not inside another function
                stack.append((i, name if is_fn else None, name if is_fn else None))
                head_buf = ""
            elif ch == "}":
                if stack:
                    start, name, fn = stack.pop()
                    if fn is not None:
                        out.append((start, name, i - start + 1))
                head_buf = ""
            elif ch == ";":
                head_buf = ""
    return out


def main(argv):
    limit, root = 150, "."
    args = argv[1:]
    if args[:1] == ["--limit"]:
        limit, args = int(args[1]), args[2:]
    if args:
        root = args[0]
    bad = []
    for folder in FOLDERS:
        for dirpath, _, files in os.walk(os.path.join(root, folder)):
            for fname in sorted(files):
                if not fname.endswith((".cpp", ".hpp", ".inc", ".cpp.in")):
                    continue
                path = os.path.join(dirpath, fname)
                rel = os.path.relpath(path, root)
                for start, name, length in functions(path):
                    if length > limit and (rel, name) not in ALLOWED:
                        bad.append(f"{rel}:{start} {name} {length} lines")
    for b in bad:
        print(b)
    if bad:
        print(f"{len(bad)} function(s) over {limit} lines (split them, or list a data table in "
              f"ALLOWED with the reason)", file=sys.stderr)
        return 1
    print(f"no function over {limit} lines outside the data tables")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
