#!/usr/bin/env python3
"""Checks that every key the apps write into their JSON files is described in the formats pages.

Usage: check_report_keys.py --source-dir DIR --path APPS_DIR

Runs the apps on the shipped examples (in a fresh folder holding a link `data` to the source
tree's data/), collects every object key of each JSON file they write (and the columns of
sph_montecarlo --csv), and looks for each, in backticks, in the section of the formats pages that
describes that file or in that page's introduction: a key written as `center_x@1` is looked for as `center_x@<setup>`. The keys
under "metadata" and "source" are the points file's own header fields and are not looked for; a
parameter's name is looked for as `<id>.<parameter>` or `sphere_form.S(l,m)`.
"""
import argparse
import json
import os
import re
import subprocess
import sys
import tempfile

# (commands, the JSON files they write, page, heading of the section that describes them)
RUNS = [
    (["sph_calibrate data/example/undeclared/points.txt --validate data/example/undeclared/validate.txt -q "
      "--sphere-radius-u-um 0.1 --json calibrate_undeclared.json -o cal_undeclared.json",
      "sph_calibrate data/example/separation/points.txt -q --json calibrate_separation.json -o cal_separation.json",
      "sph_calibrate data/example/undeclared/points.txt -q --sphere-radius-u-um 0.1 --compare cal_undeclared.json "
      "--json calibrate_compare.json",
      "sph_calibrate data/example/separation/one_placement.txt -q --sphere-form cal_separation.json "
      "--json calibrate_known_form.json"],
     ["calibrate_undeclared.json", "calibrate_separation.json", "calibrate_compare.json", "calibrate_known_form.json"],
     "docs/formats/reports.md", "`sph_calibrate --json`"),
    ([], ["cal_undeclared.json", "cal_separation.json"], "docs/formats/calibration-files.md", None),
    (["sph_measure data/example/undeclared/validate.txt -c cal_undeclared.json -q --json measure.json",
      "sph_measure data/example/points.txt -c cal_undeclared.json -q --uncertainty-samples 0 --noise-floor-draws 0 "
      "--json measure_bare.json"],
     ["measure.json", "measure_bare.json"], "docs/formats/reports.md", "`sph_measure --json`"),
    (["sph_montecarlo --trials 20 --eccentricities-mm 1,2 --no-progress --json montecarlo.json --csv montecarlo.csv "
      ">/dev/null"],
     ["montecarlo.json", "montecarlo.csv"], "docs/formats/reports.md", "`sph_montecarlo --json`"),
    (["sph_montecarlo --plan --target-std-um 2 --json plan.json > /dev/null"],
     ["plan.json"], "docs/formats/reports.md", "`sph_montecarlo --plan --json`"),
    (["sph_montecarlo --plan-orientations --eccentricities-mm 2 --json orientations.json > /dev/null"],
     ["orientations.json"], "docs/formats/reports.md", "`sph_montecarlo --plan-orientations --json`"),
    (["sph_simulate -o simulated.txt --truth truth.json --center-mm 2,0,0 --center-mm 0,2,0 "
      "--mount-rotation-deg 1:0,0,90 --form-um 3,2,0.1 --form-flat-um 0.2,1,0,0 --form-bump-um 0.1,5,0,0,1 "
      "--effect-arcsec theta_encoder.c2=5 --effect-um probe_drift.t1=0.3 --outlier-fraction 0.01 --outlier-um 3"],
     ["truth.json"], "docs/formats/reports.md", "`sph_simulate --truth`"),
]
FREE_FORM = {"metadata", "source"}


def normalised(key):
    """center_x@1 -> center_x@<setup>; theta_encoder.c2 -> <id>.<parameter>; sphere_form.S(2,0) ->
    sphere_form.S(l,m)."""
    key = re.sub(r"@-?[0-9]+$", "@<setup>", key)
    if re.fullmatch(r"sphere_form\.S\(-?[0-9]+,-?[0-9]+\)", key):
        return "sphere_form.S(l,m)"
    if re.fullmatch(r"[a-z_]+\.[a-z0-9_]+", key):
        return "<id>.<parameter>"
    return key


def keys_of(value, found):
    if isinstance(value, dict):
        for k, v in value.items():
            found.add(normalised(k))
            if k not in FREE_FORM:
                keys_of(v, found)
    elif isinstance(value, list):
        for v in value:
            keys_of(v, found)


def section(text, heading):
    """The page's introduction (before its first ## heading) and the section under `heading`."""
    if heading is None:
        return text
    intro = text.split("\n## ", 1)[0]
    lines = text.splitlines()
    for i, line in enumerate(lines):
        m = re.match(r"^(#+)\s+(.*)$", line)
        if m and m.group(2).startswith(heading):
            level = len(m.group(1))
            body = []
            for other in lines[i + 1:]:
                n = re.match(r"^(#+)\s", other)
                if n and len(n.group(1)) <= level:
                    break
                body.append(other)
            return intro + "\n" + "\n".join(body)
    return None


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--source-dir", required=True)
    ap.add_argument("--path", required=True)
    args = ap.parse_args()
    env = dict(os.environ)
    env["PATH"] = os.path.abspath(args.path) + os.pathsep + env.get("PATH", "")
    missing, total = [], 0
    with tempfile.TemporaryDirectory(prefix="sph-keys-") as work:
        os.symlink(os.path.join(os.path.abspath(args.source_dir), "data"), os.path.join(work, "data"))
        for commands, files, page, heading in RUNS:
            for c in commands:
                run = subprocess.run(["bash", "-e", "-c", c], cwd=work, env=env, stdout=subprocess.PIPE,
                                     stderr=subprocess.STDOUT, text=True)
                if run.returncode != 0:
                    sys.stderr.write(f"'{c}': exit {run.returncode}\n{run.stdout}")
                    return 1
            with open(os.path.join(args.source_dir, page), encoding="utf-8") as f:
                text = section(f.read(), heading)
            if text is None:
                sys.stderr.write(f"{page}: no section headed {heading}\n")
                return 1
            # A span documents itself and, when it is a path (`parameters.*.std`), each of its parts.
            documented = set()
            for span in re.findall(r"`([^`\s]+)`", text):
                documented.add(span)
                documented.update(part for part in span.split(".") if part not in ("", "*"))
            for name in files:
                found = set()
                path = os.path.join(work, name)
                if name.endswith(".csv"):
                    with open(path, encoding="utf-8") as f:
                        found.update(f.readline().strip().split(","))
                else:
                    with open(path, encoding="utf-8") as f:
                        keys_of(json.load(f), found)
                total += len(found)
                for k in sorted(found - documented):
                    missing.append(f"{name}: key `{k}` is not described in {page}"
                                   + (f", section {heading}" if heading else ""))
    for m in missing:
        sys.stderr.write(m + "\n")
    if missing:
        return 1
    print(f"{total} keys of {sum(len(r[1]) for r in RUNS)} files, each described")
    return 0


if __name__ == "__main__":
    sys.exit(main())
