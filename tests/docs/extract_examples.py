#!/usr/bin/env python3
"""Writes each example of a page to OUTDIR/NAME.cpp and prints "NAME LIBRARY" lines.

An example is a ```cpp block right after the comment <!-- example: NAME (LIBRARY) -->. A file
is rewritten only when its text changed, so that an unchanged example is not rebuilt.
"""
import os
import re
import sys

MARK = re.compile(r"^<!--\s*example:\s*([A-Za-z0-9_]+)\s*\(([A-Za-z0-9_:]+)\)\s*-->\s*$")


def main():
    page, outdir = sys.argv[1], sys.argv[2]
    os.makedirs(outdir, exist_ok=True)
    with open(page, encoding="utf-8") as f:
        lines = f.read().splitlines()
    found, i = [], 0
    while i < len(lines):
        m = MARK.match(lines[i])
        if not m:
            if lines[i].startswith("<!-- example"):
                sys.exit(f"{page}:{i + 1}: write the marker as <!-- example: NAME (LIBRARY) -->")
            i += 1
            continue
        if i + 1 >= len(lines) or lines[i + 1].strip() != "```cpp":
            sys.exit(f"{page}:{i + 1}: the example marker must be followed by a ```cpp block")
        j = i + 2
        while j < len(lines) and lines[j].strip() != "```":
            j += 1
        if j == len(lines):
            sys.exit(f"{page}:{i + 2}: code block not closed")
        text = "\n".join(lines[i + 2:j]) + "\n"
        path = os.path.join(outdir, m.group(1) + ".cpp")
        old = open(path, encoding="utf-8").read() if os.path.exists(path) else None
        if old != text:
            with open(path, "w", encoding="utf-8") as f:
                f.write(text)
        found.append(f"{m.group(1)} {m.group(2)}")
        i = j + 1
    if not found:
        sys.exit(f"{page}: no example")
    print("\n".join(found))


if __name__ == "__main__":
    main()
