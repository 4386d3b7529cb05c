#!/usr/bin/env python3
"""Checks the manual's links and the apps' pointers into it.

Usage: check_links.py --source-dir DIR [--app PROGRAM ...]

- Every relative link or image of README.md, CONTRIBUTING.md, data/README.md and docs/**/*.md
  must name a file or folder that exists; a #fragment must name a heading of the Markdown file it
  points to (GitHub's anchors: lower case, punctuation dropped, spaces as hyphens).
- Every --app's --help must name its own page, docs/apps/<program>.md, and every docs/... or
  data/... path that a --help names must exist; every option docs/apps/<program>.md names must be
  an option of one of the apps.
"""
import argparse
import os
import re
import subprocess
import sys

LINK = re.compile(r"!?\[(?:[^\]\[]|\[[^\]]*\])*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
HEADING = re.compile(r"^(#{1,6})\s+(.*?)\s*#*\s*$")
FENCE = re.compile(r"^```")


def pages(source):
    found = []
    for name in ("README.md", "CONTRIBUTING.md", os.path.join("data", "README.md")):
        if os.path.exists(os.path.join(source, name)):
            found.append(name)
    for root, _, files in os.walk(os.path.join(source, "docs")):
        for f in sorted(files):
            if f.endswith(".md"):
                found.append(os.path.relpath(os.path.join(root, f), source))
    return sorted(found)


def text_lines(path):
    """The lines of a Markdown file outside fenced code blocks, with their numbers."""
    out, fenced = [], False
    with open(path, encoding="utf-8") as f:
        for n, line in enumerate(f, 1):
            if FENCE.match(line):
                fenced = not fenced
                continue
            if not fenced:
                out.append((n, line.rstrip("\n")))
    return out


def slug(heading):
    s = re.sub(r"`([^`]*)`", r"\1", heading).strip().lower()
    s = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", s)
    s = re.sub(r"[^\w\- ]", "", s)
    return s.replace(" ", "-")


def anchors(path, cache={}):
    if path not in cache:
        seen, result = {}, set()
        for _, line in text_lines(path):
            m = HEADING.match(line)
            if not m:
                continue
            base = slug(m.group(2))
            k = seen.get(base, 0)
            seen[base] = k + 1
            result.add(base if k == 0 else f"{base}-{k}")
        cache[path] = result
    return cache[path]


def check_pages(source):
    errors, count = [], 0
    for page in pages(source):
        full = os.path.join(source, page)
        for n, line in text_lines(full):
            for target in LINK.findall(re.sub(r"`[^`]*`", "", line)):
                if re.match(r"^[a-z][a-z0-9+.-]*:", target):
                    continue  # https:, mailto:
                count += 1
                path, _, fragment = target.partition("#")
                dest = os.path.normpath(os.path.join(os.path.dirname(full), path)) if path else full
                if not os.path.exists(dest):
                    errors.append(f"{page}:{n}: link to {target}: {os.path.relpath(dest, source)} does not exist")
                elif fragment and dest.endswith(".md") and fragment not in anchors(dest):
                    errors.append(f"{page}:{n}: link to {target}: no heading #{fragment} in "
                                  f"{os.path.relpath(dest, source)}")
    return errors, count


def check_apps(source, apps):
    errors, helps = [], {}
    for app in apps:
        name = os.path.basename(app)
        run = subprocess.run([app, "--help"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        if run.returncode != 0:
            errors.append(f"{name} --help: exit {run.returncode}")
            continue
        helps[name] = run.stdout
        named = set(re.findall(r"\b((?:docs|data)/[\w./-]*\w)", run.stdout))
        own = f"docs/apps/{name}.md"
        if own not in named:
            errors.append(f"{name} --help does not name its page {own}")
        for path in sorted(named):
            if not os.path.exists(os.path.join(source, path)):
                errors.append(f"{name} --help names {path}, which does not exist")
    # Every option an app's page names is an option of one of the apps (a renamed or removed
    # option leaves its page stale).
    options = set()
    for text in helps.values():
        options.update(re.findall(r"(--[a-z0-9][a-z0-9-]*)", text))
    for name in helps:
        page = os.path.join(source, "docs", "apps", name + ".md")
        if not os.path.exists(page):
            continue
        with open(page, encoding="utf-8") as f:
            for n, line in enumerate(f, 1):
                for option in re.findall(r"(?<![\w-])(--[a-z0-9][a-z0-9-]*[a-z0-9])(?![\w…-])", line):
                    if option not in options:
                        errors.append(f"docs/apps/{name}.md:{n}: {option} is no option of the apps")
    return errors


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--source-dir", required=True)
    ap.add_argument("--app", action="append", default=[])
    args = ap.parse_args()
    errors, count = check_pages(args.source_dir)
    errors += check_apps(args.source_dir, args.app)
    for e in errors:
        sys.stderr.write(e + "\n")
    if errors:
        return 1
    print(f"{count} relative links in {len(pages(args.source_dir))} pages and the --help of {len(args.app)} apps: "
          f"all point to something")
    return 0


if __name__ == "__main__":
    sys.exit(main())
