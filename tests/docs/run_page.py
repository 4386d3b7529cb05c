#!/usr/bin/env python3
"""Runs the commands of a page of the manual and checks the outputs the page quotes.

Usage: run_page.py PAGE --source-dir DIR [--path DIR ...] [--examples DIR] [--skip NAME ...]

The page's fenced blocks are taken in order:
- a ```sh block is run by bash (-e -o pipefail), all of them in one fresh folder that holds a link
  `data` to the source tree's data/, with every --path folder first on PATH;
- a ```cpp block preceded by the comment <!-- example: NAME (LIBRARY) --> is run as the program NAME of
  the --examples folder (compiled from the block by tests/docs/CMakeLists.txt), in the same folder,
  unless --skip names it (its library is not built here: it is neither run nor its output checked);
- a ```text block right after one of those (only blank lines between) quotes its output (stdout
  and stderr together): every quoted line must equal a line of the output, in the same order,
  lines between them skipped; a `…` in a quoted line stands for any text, a line of `…` alone for
  nothing (a visible elision).
A command that fails, or a quoted line not found, fails the page with the block's line number.
"""
import argparse
import os
import re
import subprocess
import sys
import tempfile

FENCE = re.compile(r"^```(\S*)\s*$")
EXAMPLE = re.compile(r"^<!--\s*example:\s*([A-Za-z0-9_]+)\s*\([^)]*\)\s*-->\s*$")


def blocks(lines):
    """Yields (kind, first line number, body lines, example name, preceded only by blank lines)."""
    i, last_end, pending_example = 0, None, None
    while i < len(lines):
        line = lines[i]
        m = EXAMPLE.match(line)
        if m:
            pending_example = m.group(1)
            i += 1
            continue
        m = FENCE.match(line)
        if not m:
            if line.strip():
                last_end = None
                pending_example = None if not line.strip().startswith("<!--") else pending_example
            i += 1
            continue
        kind, start, body = m.group(1), i + 1, []
        i += 1
        while i < len(lines) and not FENCE.match(lines[i]):
            body.append(lines[i])
            i += 1
        if i == len(lines):
            raise SystemExit(f"line {start}: code block not closed")
        adjacent = last_end is not None
        yield kind, start, body, pending_example, adjacent
        pending_example = None
        i += 1
        last_end = i


def quoted_pattern(line):
    parts = [re.escape(p) for p in line.rstrip().split("…")]
    return re.compile("^" + ".*".join(parts) + "$")


def check_quote(page, start, quote, output):
    out_lines = [l.rstrip() for l in output.splitlines()]
    pos = 0
    for q in quote:
        if q.strip() in ("…", ""):
            continue
        pattern = quoted_pattern(q)
        while pos < len(out_lines) and not pattern.match(out_lines[pos]):
            pos += 1
        if pos == len(out_lines):
            sys.stderr.write(f"{page}:{start}: quoted line not in the output (in this order):\n  {q}\n"
                             f"--- output ---\n{output}--- end ---\n")
            return False
        pos += 1
    return True


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("page")
    ap.add_argument("--source-dir", required=True)
    ap.add_argument("--path", action="append", default=[])
    ap.add_argument("--examples")
    ap.add_argument("--skip", action="append", default=[])
    args = ap.parse_args()
    with open(args.page, encoding="utf-8") as f:
        lines = f.read().splitlines()
    env = dict(os.environ)
    env["PATH"] = os.pathsep.join([os.path.abspath(p) for p in args.path] + [env.get("PATH", "")])
    env["LC_ALL"] = "C.UTF-8"
    ran = checked = skipped = 0
    with tempfile.TemporaryDirectory(prefix="sph-docs-") as work:
        os.symlink(os.path.join(os.path.abspath(args.source_dir), "data"), os.path.join(work, "data"))
        output = None  # of the last block run, for the quote that follows it
        for kind, start, body, example, adjacent in blocks(lines):
            if kind == "sh":
                command = ["bash", "-e", "-o", "pipefail", "-c", "\n".join(body)]
            elif kind == "cpp" and example in args.skip:
                skipped += 1
                output = None
                continue
            elif kind == "cpp" and example:
                if not args.examples:
                    raise SystemExit(f"{args.page}:{start}: example {example}: no --examples folder")
                command = [os.path.join(os.path.abspath(args.examples), example)]
            elif kind == "text" and adjacent and output is not None:
                if not check_quote(args.page, start, body, output):
                    return 1
                checked += 1
                output = None
                continue
            else:
                output = None
                continue
            run = subprocess.run(command, cwd=work, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                 text=True, errors="replace")
            ran += 1
            if run.returncode != 0:
                sys.stderr.write(f"{args.page}:{start}: exit {run.returncode}:\n{run.stdout}")
                return 1
            output = run.stdout
    if ran == 0:
        sys.stderr.write(f"{args.page}: nothing to run\n")
        return 1
    print(f"{args.page}: {ran} blocks run, {checked} quoted outputs found"
          + (f", {skipped} examples not built here: {' '.join(args.skip)}" if skipped else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
