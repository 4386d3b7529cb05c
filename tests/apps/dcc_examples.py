#!/usr/bin/env python3
"""The Digital Calibration Certificates of the examples, validated and read back.

For each example (a calibration with effects, the separation of the sphere's form, a daily run with
the form known, a comparison with an earlier calibration, a measurement) the program writes its JSON
report and its DCC (--dcc, with the laboratory's settings of tests/data/dcc/lab.txt and the header's
`started`, as sph_acquired writes it). Each DCC must validate against PTB's schema 3.1.2 offline
(xmllint --schema, the D-SI schema through the XML catalog), and every value of the JSON report that
a certificate states must be found in it, in SI units, within its rounding: the value within half a
unit of its last decimal, U to two significant digits at the value's decimal place. A DCC asked for
without the administrative data fails, naming the keys, and writes nothing.

Usage: dcc_examples.py SPH_CALIBRATE SPH_MEASURE SOURCE_DIR WORK_DIR
Exits 77 (skipped) when xmllint is missing.
"""
import json
import math
import os
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET

NS = {"dcc": "https://ptb.de/dcc", "si": "https://ptb.de/si"}
TO_SI = {"deg": math.pi / 180, "urad": 1e-6, "arcsec": math.pi / 648000, "mm": 1e-3, "um": 1e-6, "nm": 1e-9}
STARTED = "# started: 2026-12-04T09:30:00Z\n"
# The devices sph_acquired identified over SDO, as it writes them (a replay runs no SDO).
DEVICES = ('# device_theta_encoder: node 1; name "sph_cansim theta encoder"; vendor_id 0x00535048; product_code '
           '0x00004060; revision 0x00010000; serial 0x00010001; tpdo 1 cob_id 0x181\n')
failures = []


def fail(message):
    failures.append(message)
    print("FAIL: " + message)


def run(args, expect=(0, 1)):
    r = subprocess.run(args, capture_output=True, text=True)
    if r.returncode not in expect:
        raise SystemExit(f"{' '.join(args)}: exit {r.returncode}\n{r.stderr}")
    return r


def with_started(source, target, extra=""):
    """The points file with sph_acquired's `started` (and `extra`) in its header, before the columns."""
    with open(source) as f:
        text = f.read()
    at = text.index("# columns:")
    with open(target, "w") as f:
        f.write(text[:at] + STARTED + extra + text[at:])
    return target


def validate(dcc_path, data):
    env = dict(os.environ, XML_CATALOG_FILES=os.path.join(data, "catalog.xml"))
    r = subprocess.run(["xmllint", "--noout", "--nonet", "--schema", os.path.join(data, "dcc.xsd"), dcc_path],
                       capture_output=True, text=True, env=env)
    if r.returncode != 0:
        fail(f"{dcc_path} does not validate: {r.stderr.strip()[-2000:]}")
    return r.returncode == 0


def decimals(text):
    return len(text.split(".")[1]) if "." in text else 0


def half_unit(text):
    return 0.5 * 10.0 ** -decimals(text)


def quantities(dcc_path):
    """Every quantity with an id: its value and U as printed, unit, k and p."""
    found = {}
    for q in ET.parse(dcc_path).getroot().iter("{https://ptb.de/dcc}quantity"):
        if "id" not in q.attrib:
            continue
        real = q.find("si:real", NS)
        if real is None:
            found[q.attrib["id"]] = None
            continue
        u = real.find("si:expandedUnc", NS)
        found[q.attrib["id"]] = {
            "value": real.find("si:value", NS).text,
            "unit": real.find("si:unit", NS).text,
            "U": None if u is None else u.find("si:uncertainty", NS).text,
            "k": None if u is None else float(u.find("si:coverageFactor", NS).text),
            "p": None if u is None else float(u.find("si:coverageProbability", NS).text),
        }
    return found


def check(found, where, qid, value, unit, U=None, k=None, p=None, rounded=True):
    """The quantity `qid` states `value` [unit] (and U, k, p) within its rounding."""
    if qid not in found:
        fail(f"{where}: no quantity {qid}")
        return
    q = found[qid]
    if q is None:
        fail(f"{where}: {qid} has no number")
        return
    f = TO_SI.get(unit, 1.0)
    expected_unit = "\\radian" if unit in ("deg", "urad", "arcsec") else "\\metre" if unit in ("mm", "um", "nm") \
        else "\\one"
    if q["unit"] != expected_unit:
        fail(f"{where}: {qid} in {q['unit']}, not {expected_unit}")
    v = float(q["value"])
    tolerance = half_unit(q["value"]) if rounded else 5e-6 * abs(value * f)
    if abs(v - value * f) > tolerance * (1 + 1e-9) + 1e-18:
        fail(f"{where}: {qid} = {q['value']}, the JSON's {value} {unit} is {value * f!r} in SI")
    if U is None:
        return
    if q["U"] is None:
        fail(f"{where}: {qid} has no expanded uncertainty")
        return
    if U == 0.0:
        if float(q["U"]) != 0.0:
            fail(f"{where}: {qid} U = {q['U']}, exact in the JSON")
        return
    # GUM 7.2.6: U to two significant digits, the value to the same decimal place.
    digits = q["U"].replace(".", "").lstrip("0")
    if len(digits) > 2 or decimals(q["U"]) != decimals(q["value"]):
        fail(f"{where}: {qid} = {q['value']} with U {q['U']}: not U to two digits and the value at its place")
    if abs(float(q["U"]) - U * f) > half_unit(q["U"]) * (1 + 1e-9) + 1e-18:
        fail(f"{where}: {qid} U = {q['U']}, the JSON's {U} {unit} is {U * f!r} in SI")
    if k is not None and abs(q["k"] - k) > 5e-4 * k:
        fail(f"{where}: {qid} k = {q['k']}, the JSON's {k}")
    if p is not None and abs(q["p"] - p) > 5e-5:
        fail(f"{where}: {qid} p = {q['p']}, the JSON's {p}")


def check_calibration(json_path, dcc_path):
    with open(json_path) as f:
        j = json.load(f)
    found = quantities(dcc_path)
    where = os.path.basename(dcc_path)
    count = len(failures)
    checked = 0
    for name in j["parameter_order"]:
        p = j["parameters"][name]
        if "@" in name or name.startswith("center"):
            continue
        if "held" in p:
            check(found, where, "parameters." + name, p["value"], p["unit"], 0.0)
        else:
            check(found, where, "parameters." + name, p["value"], p["unit"], p["U"], p["k"], p["coverage_probability"])
        checked += 1
    k = j["coverage"].get("k", 2.0)
    for e in j.get("effects", []):
        for par in e["parameters"]:
            check(found, where, "effects." + par["name"], par["value"], par["unit"], k * par["std"], k)
            checked += 1
    check(found, where, "fit.rms_um", j["fit"]["rms_um"], "um", rounded=False)
    check(found, where, "sphere_radius_mm", j["sphere_radius_mm"], "mm")
    checked += 2
    form = j.get("sphere_form", {})
    if "rms_um" in form:
        check(found, where, "sphere_form.rms_um", form["rms_um"], "um", k * form["rms_std_um"], k)
        checked += 1
    if "known_form" in j:
        check(found, where, "known_form.known_rms_um", j["known_form"]["known_rms_um"], "um", rounded=False)
        check(found, where, "known_form.fitted_rms_um", j["known_form"]["fitted_rms_um"], "um", rounded=False)
        checked += 2
    for i, c in enumerate(j.get("comparison", [])):
        if c["difference"] is not None and c["U"] is not None:
            check(found, where, f"comparison.{i}.difference", c["difference"], c["unit"], c["U"],
                  j["comparison_summary"]["k"])
            checked += 1
        if c["En"] is not None:
            check(found, where, f"comparison.{i}.En", c["En"], "", rounded=False)
            checked += 1
    print(f"{where}: {checked} values of the JSON report found within their rounding"
          + ("" if len(failures) == count else f"; {len(failures) - count} failures"))


def check_measurement(json_path, dcc_path):
    with open(json_path) as f:
        j = json.load(f)
    found = quantities(dcc_path)
    where = os.path.basename(dcc_path)
    count = len(failures)
    for key in ("radius", "sphericity_ls", "sphericity_mz"):
        b = j["budget"][key]
        unit = b["value_unit"]
        U = b["U"] / 1000.0 if unit == "mm" else b["U"]  # U is in um
        check(found, where, "budget." + key, b["value"], unit, U, b["k"], b["coverage_probability"])
    check(found, where, "rms_um", j["rms_um"], "um", rounded=False)
    print(f"{where}: 4 values of the JSON report found within their rounding"
          + ("" if len(failures) == count else f"; {len(failures) - count} failures"))


def main():
    calibrate, measure, source, work = sys.argv[1:5]
    if shutil.which("xmllint") is None:
        print("skipped: xmllint (libxml2-utils) is not installed (cmake/install-deps.sh installs it)")
        return 77
    data = os.path.join(source, "tests", "data", "dcc")
    lab = os.path.join(data, "lab.txt")
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    w = lambda name: os.path.join(work, name)  # noqa: E731
    # The schema, the D-SI schema and the catalog work offline: PTB's own example validates.
    if not validate(os.path.join(data, "example-silicon-sphere.xml"), data):
        return 1
    undeclared = with_started(os.path.join(source, "data/example/undeclared/points.txt"), w("undeclared.txt"),
                              DEVICES)
    separation = with_started(os.path.join(source, "data/example/separation/points.txt"), w("separation.txt"))
    daily = with_started(os.path.join(source, "data/example/separation/one_placement.txt"), w("daily.txt"))
    validate_points = with_started(os.path.join(source, "data/example/undeclared/validate.txt"), w("validate.txt"))
    dcc = ["--dcc-settings", lab, "-q"]
    runs = [
        ("effects", [calibrate, undeclared, "-o", w("traced.json")]),
        ("separation", [calibrate, separation, "-o", w("separated.json")]),
        ("daily", [calibrate, daily, "--sphere-form", w("separated.json")]),
        ("earlier", None),
        ("comparison", [calibrate, undeclared, "--compare", w("earlier.json")]),
    ]
    for name, args in runs:
        if args is None:
            run([calibrate, undeclared, "-q", "--no-trace", "-o", w("earlier.json")])
            continue
        run(args + dcc + ["--json", w(name + ".json"), "--dcc", w(name + ".xml")])
        if validate(w(name + ".xml"), data):
            check_calibration(w(name + ".json"), w(name + ".xml"))
    # The SCMS's devices are among the calibration's items, each with its serial number.
    items = ET.parse(w("effects.xml")).getroot().find("dcc:administrativeData/dcc:items", NS)
    serials = [i.text for i in items.iter("{https://ptb.de/dcc}value")]
    if "0x00010001" not in serials or "0042" not in serials:
        fail(f"effects.xml: the items' identifications {serials} lack the SCMS's or its encoder's serial")
    run([measure, validate_points, "-c", w("traced.json")] + dcc +
        ["--json", w("measurement.json"), "--dcc", w("measurement.xml")], expect=(0,))
    if validate(w("measurement.xml"), data):
        check_measurement(w("measurement.json"), w("measurement.xml"))
    # Without the administrative data: exit 2, every key missing named, nothing written.
    r = run([calibrate, os.path.join(source, "data/example/points.txt"), "-q", "--no-trace", "--dcc",
             w("none.xml"), "--json", w("none.json")], expect=(2,))
    for key in ("certificate_id", "country_code", "laboratory_name", "customer_email", "responsible_person",
                "scms_serial", "sphere_certificate", "performance_date"):
        if key not in r.stderr:
            fail(f"the message without settings does not name {key}: {r.stderr}")
    if os.path.exists(w("none.xml")) or os.path.exists(w("none.json")):
        fail("a run that failed for the certificate left an output")
    print(r.stderr.strip().splitlines()[0])
    if failures:
        print(f"{len(failures)} failures")
        return 1
    print("every certificate validates and states the JSON reports' values")
    return 0


if __name__ == "__main__":
    sys.exit(main())
