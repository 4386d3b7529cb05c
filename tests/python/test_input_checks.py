"""The Python module against what a script may hand it: results the app reports as not usable, Ctrl-C
during long work, header fields and arrays that a points file could not hold, and large arrays."""
import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import sph


# ---- every result the app can give is a result object -----------------------------------------------

@pytest.mark.parametrize("options, app_args", [
    ({"max_std_um": 0.01}, ["--max-std-um", "0.01"]),  # every error undetermined: not usable
    ({"fix": "a_mm=5"}, ["--fix", "a_mm=5"]),  # a held value far from the machine's: no convergence, not usable
    ({"fix": "beta"}, ["--fix", "beta"]),  # usable, beta held (no U)
    ({"prior": "alpha_deg=0.03,1e-6"}, ["--prior", "alpha_deg=0.03,1e-6"]),  # rejected by the readings: not usable
], ids=["undetermined", "held_far_off", "held", "prior_rejected"])
def test_every_result_the_app_gives_is_a_result(example_points, tmp_path, options, app_args):
    out = tmp_path / "app.json"
    app = subprocess.run([os.environ["SPH_CALIBRATE"], example_points, "--no-trace", *app_args, "--json", str(out),
                          "-q"], capture_output=True, text=True)
    assert app.returncode in (0, 1), app.stderr  # a result, usable or not
    r = sph.calibrate(example_points, no_trace=True, **options)
    assert r.report == json.loads(out.read_text())
    assert r.usable == (app.returncode == 0)
    assert r.why_not_usable == r.report["why_not_usable"]
    assert bool(r.why_not_usable) != r.usable
    for name, p in r.parameters.items():  # None where the report states nothing
        stated = r.report["parameters"][name]
        assert p["U"] == stated.get("U") and p["std"] == stated.get("std"), name
    assert r.covariance.shape == (len(r.parameter_names),) * 2
    assert ("not usable" in repr(r)) != r.usable


def test_a_held_parameter_has_no_uncertainty_and_no_covariance(example_points):
    r = sph.calibrate(example_points, fix="beta", no_trace=True)
    assert r.usable
    assert r.parameters["beta"]["std"] == 0 and r.parameters["beta"]["U"] is None
    i = r.parameter_names.index("beta")
    assert not r.covariance[i].any() and not r.covariance[:, i].any()
    assert r.parameters["alpha"]["U"] > 0


# ---- Ctrl-C ------------------------------------------------------------------------------------------

_INTERRUPTED = """
import sys, time, sph
print("started", flush=True)
try:
    {call}
    print("finished", flush=True)
except KeyboardInterrupt:
    caught = time.monotonic()
    points, _ = sph.simulate()  # the module works on after it
    print("KeyboardInterrupt", caught, len(points), flush=True)
"""


@pytest.mark.parametrize("call", [
    "sph.monte_carlo(trials=200000, threads=1)",
    "sph.monte_carlo(trials=200000, threads=2)",
])
def test_ctrl_c_stops_a_long_study_within_a_second(call):
    child = subprocess.Popen([sys.executable, "-c", _INTERRUPTED.format(call=call)], stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True)
    try:
        assert child.stdout.readline() == "started\n"
        time.sleep(1.0)  # well into the study (200000 trials take minutes)
        sent = time.monotonic()  # CLOCK_MONOTONIC: one clock for both processes
        child.send_signal(signal.SIGINT)
        out, err = child.communicate(timeout=10)
    finally:
        child.kill()
        child.wait()
    words = out.split()
    assert words[0] == "KeyboardInterrupt", out + err
    assert float(words[1]) - sent < 1.0
    assert words[2] == "288"


# ---- header fields and setups a points file could not hold -----------------------------------------

def test_a_header_value_with_a_line_break_is_refused():
    header = {"sphere_radius_mm": "20", "operator": "bob\n# probe_offset_mm: 30"}
    with pytest.raises(sph.Error, match=r"^mine:3: operator: 'bob\\x0A# probe_offset_mm: 30' holds a line break"):
        sph.Points([0.0], [10.0], [5.0], header=header, source="mine")
    with pytest.raises(sph.Error, match="holds a line break"):
        sph.Points([0.0], [10.0], [5.0], header={"operator": "bob\r"})


def test_a_key_outside_the_format_is_refused():
    with pytest.raises(sph.Error, match=r"^mine:2: header key 'my key!' is not a header key"):
        sph.Points([0.0], [10.0], [5.0], header={"my key!": "x"}, source="mine")
    p = sph.Points([0.0], [10.0], [5.0], header={"my_key-2": "x y: z"})  # a key of the format, any one-line value
    assert p.header["my_key-2"] == "x y: z"


def test_setup_ids_must_be_integers():
    with pytest.raises(sph.Error, match=r"^mine: sample 1: column setup: '0.4' is not an integer$"):
        sph.Points([0.0, 1.0], [10.0, 11.0], [5.0, 5.0], setup=[0.4, 1.6], source="mine")
    with pytest.raises(sph.Error, match=r"^<points>: sample 2: column setup: '10000000000' is out of the range of an"):
        sph.Points([0.0, 1.0], [10.0, 11.0], [5.0, 5.0], setup=[0, 1e10])
    for setup in ([0.0, 1.0], np.array([0, 1], dtype=np.int64), np.array([0, 1], dtype=np.int8)):
        assert list(sph.Points([0.0, 1.0], [10.0, 11.0], [5.0, 5.0], setup=setup).setup) == [0, 1]


def test_readings_from_arrays_are_checked_as_rows_are():
    with pytest.raises(sph.Error, match=r"^m: sample 2: column r_mm: 'nan' is not a finite number$"):
        sph.Points([0.0, 1.0], [10.0, 11.0], [5.0, np.nan], source="m")
    with pytest.raises(sph.Error, match=r"^m: sample 1: column theta_deg: '10000000000' is beyond 1e\+09 deg from 0"):
        sph.Points([1e10], [10.0], [5.0], source="m")
    with pytest.raises(sph.Error, match=r"^m: sample 1: column t_s: 'inf' is not a finite number$"):
        sph.Points([0.0], [10.0], [5.0], t_s=[np.inf], source="m")
    with pytest.raises(sph.Error, match=r"^m: theta_deg must be a 1-D array$"):
        sph.Points(np.zeros((2, 2)), [10.0, 11.0], [5.0, 5.0], source="m")


# ---- large arrays -----------------------------------------------------------------------------------

def test_points_of_arrays_are_the_arrays_exactly(example_points):
    rng = np.random.default_rng(3)
    n = 1000
    theta, phi, r, t = rng.uniform(0, 360, n), rng.uniform(0, 180, n), rng.uniform(0, 10, n), rng.uniform(0, 1e9, n)
    p = sph.Points(theta, phi, r, t_s=t, setup=np.arange(n) % 3)
    for name, a in (("theta_deg", theta), ("phi_deg", phi), ("r_mm", r), ("t_s", t)):
        assert np.array_equal(getattr(p, name), a), name
    q = sph.read_points(example_points)
    same = sph.Points(q.theta_deg, q.phi_deg, q.r_mm, t_s=q.t_s, header=q.header, source=example_points)
    assert same.header == q.header  # its columns field passed over: the arrays say which there are
    assert sph.calibrate(same, no_trace=True).report == sph.calibrate(q, no_trace=True).report


_PEAK = """
import resource, sys, numpy as np, sph
n = 1_000_000
theta, phi, r = np.linspace(0, 360, n), np.linspace(1, 179, n), np.linspace(4, 6, n)
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
p = sph.Points(theta, phi, r)
after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print((after - before) * 1024, theta.nbytes + phi.nbytes + r.nbytes, len(p))
"""


def test_points_of_large_arrays_take_no_copy_through_text():
    """The peak memory sph.Points adds for a million readings (in a process of its own): the readings it
    holds (40 bytes each, 1.7 times the three arrays) and no text of them. bench/python_memory.py gives the
    time and memory of ten million."""
    out = subprocess.run([sys.executable, "-c", _PEAK], check=True, capture_output=True, text=True).stdout
    grown, arrays, n = (int(w) for w in out.split())
    assert n == 1_000_000
    assert grown <= 2 * arrays, f"peak grew by {grown / 1e6:.0f} MB for {arrays / 1e6:.0f} MB of arrays"


# ---- sph.compensate's arrays and sph.measure's points -------------------------------------------------

@pytest.fixture(scope="module")
def calibration():
    points = os.path.join(os.environ["SPH_SOURCE_DIR"], "data", "example", "points.txt")
    return sph.calibrate(points, no_trace=True)


@pytest.mark.parametrize("row, message", [
    ((0.0, 10.0, np.nan), r"sample 2: column r_mm: 'nan' is not a finite number"),
    ((np.inf, 10.0, 5.0), r"sample 2: column theta_deg: 'inf' is not a finite number"),
    ((0.0, 10.0, 1e300), r"sample 2: column r_mm: '1e\+300' is beyond 1e\+06 mm from 0: not a probe reading in mm"),
], ids=["nan", "inf", "far"])
def test_compensate_checks_its_arrays_as_the_reader_does(calibration, row, message):
    readings = np.array([(0.0, 10.0, 5.0), row])
    with pytest.raises(sph.Error, match="^compensate: readings: " + message):
        sph.compensate(readings, calibration)


def test_compensate_checks_the_centre(calibration):
    readings = np.array([(0.0, 10.0, 5.0)])
    with pytest.raises(sph.Error, match=r"^compensate: center_mm x: must be >= -1000 and <= 1000 mm, got nan$"):
        sph.compensate(readings, calibration, center_mm=[np.nan, 0, 0])
    with pytest.raises(sph.Error, match=r"^compensate: center_mm z: must be"):
        sph.compensate(readings, calibration, center_mm=[0, 0, 1e9])
    assert sph.compensate(readings, calibration, center_mm=[0, 0, 0]).shape == (1, 3)


def test_measure_takes_points(source_dir, tmp_path):
    cal = tmp_path / "cal.json"
    undeclared = os.path.join(source_dir, "data", "example", "undeclared")
    subprocess.run([os.environ["SPH_CALIBRATE"], os.path.join(undeclared, "points.txt"), "-o", str(cal), "-q"],
                   check=True, capture_output=True)
    validate = os.path.join(undeclared, "validate.txt")
    from_file = sph.measure(validate, calibration=cal)
    from_points = sph.measure(sph.read_points(validate), calibration=cal)
    assert from_points.report == from_file.report and from_points.text == from_file.text
    assert np.array_equal(from_points.points_mm, from_file.points_mm)
    with pytest.raises(sph.Error, match="not x y z coordinates"):
        sph.measure(sph.read_points(validate), xyz=True)


# ---- what a design cannot resolve ---------------------------------------------------------------------

def test_harmonics_the_angles_cannot_resolve_are_null(example_points):
    p = sph.read_points(example_points)
    at = p.theta_deg % 45 == 0  # 8 angles of theta: harmonics up to order 3
    eight = sph.Points(p.theta_deg[at], p.phi_deg[at], p.r_mm[at], t_s=p.t_s[at], header=p.header)
    r = sph.calibrate(eight)
    for fit in ("before", "after"):
        amplitudes = r.report[fit]["theta_harmonics_um"]
        assert len(amplitudes) == 8
        assert all(isinstance(a, float) and a < 1 for a in amplitudes[:3]), amplitudes
        assert amplitudes[3:] == [None] * 5, amplitudes
    assert " 4: unresolved 5: unresolved 6: unresolved 7: unresolved 8: unresolved\n" in r.text
