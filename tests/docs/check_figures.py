#!/usr/bin/env python3
"""Lists the figures of the evidence pages that lack a command or a commit.

Usage: check_figures.py [--source-dir DIR] [PAGE ...]   (default: docs/validation.md docs/performance.md)

A figure is a paragraph, list item or table of a page's prose that states a measured number: a
decimal number, a percentage, a ratio "N×", a count "N of M" or "N / M" (a heading, a code block
and an inline code span are not prose). It is backed when its own text, the paragraph the lists
and tables before it hang from (with a code block after that paragraph) or, for a paragraph, the
block just before it gives
- a command: an inline code span or a code block that runs something (`build/…`, `sph_…`, `ctest`,
  `tests/…`, `bench/…`, a GoogleTest name `Suite.Test`, `python3 …`), and
- a commit: an inline code span of 7 to 40 hexadecimal digits, or the page's re-run mark
  (*re-run*, which the page's introduction ties to a commit).
Prints each figure that lacks one, with its line and what it lacks; exits 1 when any does.
"""
import argparse
import os
import re
import sys

NUMBER = re.compile(r"(?<![\w.`])(\d+\.\d+|\d+(\.\d+)?\s?%|\d+(\.\d+)?\s?×|\d+ of \d+|\d+ / \d+)")
CODE = re.compile(r"`([^`]+)`")
COMMIT = re.compile(r"^[0-9a-f]{7,40}$")
RUNS = re.compile(r"^(nice -n \d+ )?(build/|sph_|ctest|tests/|bench/|python3|/usr/bin/python3|cmake|valgrind|[A-Z]\w+\.[A-Z*]\w*)")


def blocks(lines):
    """(first line number, text, heading path) of each prose block; code blocks as their own text."""
    out, current, start, fence, code = [], [], 0, False, []
    heading = ""
    for n, line in enumerate(lines, 1):
        if line.startswith("```"):
            if fence:
                out.append((start, "\n".join(code), heading, True))
                code = []
            else:
                if current:
                    out.append((start, "\n".join(current), heading, False))
                    current = []
                start = n
            fence = not fence
            continue
        if fence:
            code.append(line)
            continue
        if line.startswith("#"):
            if current:
                out.append((start, "\n".join(current), heading, False))
                current = []
            heading = line.strip()
            out.append((n, "", heading, False))
            continue
        starts_item = line.startswith(("- ", "* ", "| ")) and not (current and current[-1].startswith("| ")
                                                                   and line.startswith("| "))
        if not line.strip() or starts_item:
            if current:
                out.append((start, "\n".join(current), heading, False))
                current = []
            if not line.strip():
                continue
        if not current:
            start = n
        current.append(line)
    if current:
        out.append((start, "\n".join(current), heading, False))
    return out


def has_command(text, code_block):
    if code_block:
        return bool(text.strip())
    return any(RUNS.match(c.strip()) for c in CODE.findall(text))


def has_commit(text):
    return any(COMMIT.match(c.strip()) for c in CODE.findall(text)) or "re-run*" in text.lower()


def check(path):
    with open(path, encoding="utf-8") as f:
        lines = f.read().split("\n")
    missing = []
    lead = previous = ("", False)  # the paragraph a list or table hangs from; the block before
    for start, text, heading, code_block in blocks(lines):
        if not text and heading:
            lead = previous = ("", False)
            continue
        item = not code_block and text.startswith(("- ", "* ", "| "))
        context = [(text, code_block), lead] if item else [(text, code_block), previous, lead]
        if not code_block:
            prose = CODE.sub("", text)
            if NUMBER.search(prose):
                command = any(has_command(t, c) for t, c in context)
                commit = any(has_commit(t) for t, c in context)
                lacks = [w for w, ok in (("a command", command), ("a commit", commit)) if not ok]
                if lacks:
                    first = prose.strip().split("\n")[0][:90]
                    missing.append(f"{path}:{start}: lacks {' and '.join(lacks)}: {first}")
        if code_block and not item:
            lead = (lead[0] + "\n" + text, True) if lead[0] else (text, True)
        elif not item:
            lead = (text, False)
        previous = (text, code_block)
    return missing


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--source-dir", default=".")
    parser.add_argument("pages", nargs="*")
    args = parser.parse_args()
    pages = args.pages or [os.path.join(args.source_dir, "docs", p) for p in ("validation.md", "performance.md")]
    missing = [m for p in pages for m in check(p)]
    for m in missing:
        print(m)
    print(f"{len(missing)} figures lack a command or a commit")
    return 1 if missing else 0


if __name__ == "__main__":
    sys.exit(main())
