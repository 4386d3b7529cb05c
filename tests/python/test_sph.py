"""The Python module sph against the library's apps and files."""
import json
import math
import os
import subprocess

import numpy as np
import pytest

import sph


def test_version_is_the_projects():
    assert sph.__version__ == os.environ["SPH_VERSION"]


def test_read_points_gives_arrays_of_the_readings(example_points):
    p = sph.read_points(example_points)
    assert len(p) == 288
    for name in ("theta_deg", "phi_deg", "r_mm", "t_s"):
        a = getattr(p, name)
        assert a.dtype == np.float64 and a.shape == (288,), name
    assert p.setup.dtype == np.int32 and p.setup.shape == (288,)
    assert p.header["sphere_radius_mm"] == "20"
    assert p.header["columns"] == "theta_deg phi_deg r_mm t_s"
    first = open(example_points).read().splitlines()
    row = next(line for line in first if not line.startswith("#")).split()
    assert p.theta_deg[0] == float(row[0]) and p.r_mm[0] == float(row[2])
    assert "288 readings" in repr(p)


def test_write_points_reads_back_the_same(example_points, tmp_path):
    p = sph.read_points(example_points)
    out = tmp_path / "copy.txt"
    sph.write_points(out, p)  # os.PathLike as str
    q = sph.read_points(out)
    for name in ("theta_deg", "phi_deg", "r_mm", "t_s", "setup"):
        assert np.array_equal(getattr(p, name), getattr(q, name)), name
    assert q.header == p.header


def test_points_from_arrays_are_checked_as_a_file_is():
    p = sph.Points([0.0, 90.0], [10.0, 20.0], [5.0, 5.1], header={"sphere_radius_mm": 20}, source="mine")
    assert p.header["sphere_radius_mm"] == "20" and p.t_s.shape == (2,)
    with pytest.raises(sph.Error, match=r"^mine:2: sphere_radius_mm"):
        sph.Points([0.0], [10.0], [5.0], header={"sphere_radius_mm": -1}, source="mine")
    with pytest.raises(sph.Error, match="one length"):
        sph.Points([0.0, 1.0], [10.0], [5.0])


def test_calibrate_report_equals_sph_calibrate_json(example_points, tmp_path):
    out = tmp_path / "app.json"
    subprocess.run([os.environ["SPH_CALIBRATE"], example_points, "--json", str(out), "-q"], check=True)
    app = json.loads(out.read_text())
    result = sph.calibrate(example_points)
    assert result.report == app  # every key and number, exactly
    assert result.report["program"] == "sph_calibrate " + sph.__version__
    text = subprocess.run([os.environ["SPH_CALIBRATE"], example_points], check=True, capture_output=True, text=True)
    assert result.text == text.stdout


def test_calibrate_options_equal_the_apps(source_dir, tmp_path):
    points = os.path.join(source_dir, "data", "example", "undeclared", "points.txt")
    validate = os.path.join(source_dir, "data", "example", "undeclared", "validate.txt")
    out, cal = tmp_path / "app.json", tmp_path / "cal.json"
    subprocess.run([os.environ["SPH_CALIBRATE"], points, "--validate", validate, "--seed", "3", "--json", str(out),
                    "-o", str(cal), "-q"], check=True)
    result = sph.calibrate(points, validate=validate, seed=3)
    assert result.report == json.loads(out.read_text())
    assert result.calibration_file == cal.read_text()


def test_calibrate_compare_equals_the_apps(source_dir, tmp_path):
    points = os.path.join(source_dir, "data", "example", "undeclared", "points.txt")
    cal, out = tmp_path / "yesterday.json", tmp_path / "today.json"
    subprocess.run([os.environ["SPH_CALIBRATE"], points, "-o", str(cal), "-q"], check=True)
    subprocess.run([os.environ["SPH_CALIBRATE"], points, "--compare", str(cal), "--json", str(out), "-q"], check=True)
    result = sph.calibrate(points, compare=cal)
    assert result.report == json.loads(out.read_text())
    assert [c["parameter"] for c in result.report["comparison"]][:7] == ["alpha", "a", "beta", "b", "epsilon", "c",
                                                                         "d_prime"]
    assert result.report["comparison_summary"]["unchanged"]


def test_calibrate_sphere_form_equals_the_apps(source_dir, tmp_path):
    separation = os.path.join(source_dir, "data", "example", "separation")
    cal, out = tmp_path / "separated.json", tmp_path / "daily.json"
    subprocess.run([os.environ["SPH_CALIBRATE"], os.path.join(separation, "points.txt"), "-o", str(cal), "-q"],
                   check=True)
    daily = os.path.join(separation, "one_placement.txt")
    subprocess.run([os.environ["SPH_CALIBRATE"], daily, "--sphere-form", str(cal), "--json", str(out), "-q"],
                   check=True)
    app = json.loads(out.read_text())
    assert sph.calibrate(daily, sphere_form=cal).report == app  # a path
    assert sph.calibrate(daily, sphere_form=[str(cal)]).report == app  # a list, one file per sphere
    assert app["known_form"]["source"] == str(cal)


def test_calibrate_statements_and_requirement_equal_the_apps(example_points, tmp_path):
    out, cal = tmp_path / "app.json", tmp_path / "cal.json"
    # A prior the readings reject, accepted against them; a target the example's beta meets.
    args = ["--no-trace", "--prior", "alpha_deg=0.03,1e-6", "--accept-rejected", "--target-u", "alpha_urad=5"]
    subprocess.run([os.environ["SPH_CALIBRATE"], example_points, *args, "--json", str(out), "-o", str(cal), "-q"],
                   check=True)
    result = sph.calibrate(example_points, no_trace=True, prior="alpha_deg=0.03,1e-6", accept_rejected=True,
                           target_u="alpha_urad=5")
    assert result.report == json.loads(out.read_text())
    assert result.calibration_file == cal.read_text()
    test = result.report["statements"]["tests"][0]
    assert test["rejected"] and test["accepted"] and test["statement"] == "--prior alpha_deg=0.03,1e-06"
    assert result.report["usable_against"].startswith("the stated requirement: expanded uncertainties within "
                                                      "--target-u alpha_urad=5")
    # Not accepted, the same prior makes the calibration not usable.
    refused = sph.calibrate(example_points, no_trace=True, prior="alpha_deg=0.03,1e-6")
    assert not refused.usable
    assert any(w.startswith("the readings reject --prior alpha_deg=0.03,1e-06") for w in refused.report["why_not_usable"])
    with pytest.raises(sph.Error, match="target_u alpha: expected NAME_UNIT=U"):
        sph.calibrate(example_points, no_trace=True, target_u="alpha")


def test_calibrate_result_views(example_points):
    r = sph.calibrate(example_points, no_trace=True)
    names = r.report["parameter_order"]
    assert r.parameter_names == names and len(names) == 10
    assert r.covariance.shape == (10, 10) and r.covariance.dtype == np.float64
    for i, name in enumerate(names):
        p = r.report["parameters"][name]
        assert r.parameters[name] == {"value": p["value"], "std": p["std"], "U": p["U"], "unit": p["unit"]}
        assert math.isclose(r.covariance[i, i], p["std"] ** 2, rel_tol=1e-12)
    # The report's correlations are symmetric to their last bit (2.2e-16 apart at most).
    assert np.allclose(r.covariance, r.covariance.T, rtol=1e-15, atol=0)
    assert r.usable and json.loads(r.calibration_file)
    # The report ends with the verdict and the requirement it was judged against.
    verdict = r.text[r.text.rindex("\nresult: ") + 1 :]
    assert verdict.startswith("result: usable calibration\n  judged against the default requirement: ")
    assert verdict.count("\n") == 2 and r.report["usable_against"] in verdict
    assert "usable" in repr(r) and "10 parameters" in repr(r)


def test_calibrate_takes_points_in_memory(example_points):
    p = sph.read_points(example_points)
    assert sph.calibrate(p, no_trace=True).report == sph.calibrate(example_points, no_trace=True).report


def test_unknown_keyword_is_a_type_error_naming_it(example_points):
    with pytest.raises(TypeError, match="'sphere_radius'"):
        sph.calibrate(example_points, sphere_radius=20.0)


def test_errors_carry_the_librarys_message(tmp_path, example_points):
    bad = tmp_path / "bad.txt"
    bad.write_text("# sph-points 1\n0 10 5\n0 20 x\n")
    with pytest.raises(sph.Error, match=r"bad\.txt:3: ") as e:
        sph.read_points(str(bad))
    assert isinstance(e.value, ValueError)
    with pytest.raises(sph.Error, match=r"max_std_um"):
        sph.calibrate(example_points, max_std_um=0.0)
    with pytest.raises(sph.Error, match=r"unknown effect 'no_such'"):
        sph.calibrate(example_points, effects="no_such")


def _rss_bytes():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def test_memory_is_stable_over_repeated_calls(example_points, capsys):
    """RSS over 100 calls of each workflow after 10 (the allocator's and Ceres' first-use growth), against
    what a result left behind each call would add: at least its JSON text (its dict is larger) and, for
    simulate, its four columns of float64. bench/python_memory.py measures 1000 calls of each."""
    p = sph.read_points(example_points)
    workflows = {
        "calibrate": (lambda: sph.calibrate(p), lambda r: len(json.dumps(r.report))),
        "simulate": (lambda: sph.simulate(), lambda r: 4 * r[0].r_mm.nbytes + len(json.dumps(r[1]))),
        "monte_carlo": (lambda: sph.monte_carlo(trials=2, eccentricities_mm=[2], table3=False, threads=1),
                        lambda r: len(json.dumps(r.report))),
    }
    calls = 100
    for name, (call, result_bytes) in workflows.items():
        for _ in range(10):
            r = call()
        before = _rss_bytes()
        for _ in range(calls):
            r = call()
        grown = _rss_bytes() - before
        leak = calls * result_bytes(r)  # what results left behind would hold, at least
        with capsys.disabled():
            print(f"\n{name}: RSS grew by {grown / 1e3:.0f} kB over {calls} calls "
                  f"(results left behind: {leak / 1e3:.0f} kB or more)", end="")
        assert grown < leak / 2, f"{name}: RSS grew by {grown / 1e3:.0f} kB over {calls} calls"


def _undeclared(source_dir, name):
    return os.path.join(source_dir, "data", "example", "undeclared", name)


def test_measure_and_compensate_equal_sph_measure(source_dir, tmp_path):
    cal, report = tmp_path / "cal.json", tmp_path / "measure.json"
    subprocess.run([os.environ["SPH_CALIBRATE"], _undeclared(source_dir, "points.txt"), "-o", str(cal), "-q"],
                   check=True, capture_output=True)
    validate = _undeclared(source_dir, "validate.txt")
    text = subprocess.run([os.environ["SPH_MEASURE"], validate, "-c", str(cal), "--json", str(report)],
                          check=True, capture_output=True, text=True).stdout
    m = sph.measure(validate, calibration=cal)
    assert m.report == json.loads(report.read_text())
    assert m.text == text
    assert m.points_mm.shape == (288, 3) and m.points_mm.dtype == np.float64
    p = sph.read_points(validate)
    assert np.array_equal(sph.compensate(p, cal), m.points_mm)
    columns = np.column_stack([p.theta_deg, p.phi_deg, p.r_mm])
    assert np.array_equal(sph.compensate(columns, str(cal)), m.points_mm)
    # A calibration result compensates as its calibration file does.
    assert np.array_equal(sph.compensate(p, sph.calibrate(_undeclared(source_dir, "points.txt"))), m.points_mm)


def test_dcc_equals_the_apps_and_names_what_is_missing(source_dir, tmp_path):
    lab = os.path.join(source_dir, "tests", "data", "dcc", "lab.txt")
    dated = tmp_path / "lab.txt"  # the laboratory's settings and the day of the readings
    dated.write_text(open(lab).read() + "performance_date: 2026-12-04\n")
    points = _undeclared(source_dir, "points.txt")
    out, cal = tmp_path / "cal.xml", tmp_path / "cal.json"
    subprocess.run([os.environ["SPH_CALIBRATE"], points, "-q", "-o", str(cal), "--dcc", str(out), "--dcc-settings",
                    str(dated)], check=True, capture_output=True)
    result = sph.calibrate(points)
    assert result.dcc(dated) == out.read_text()
    assert result.dcc(lab, performance_date="2026-12-04") == out.read_text()  # a keyword as a line of the file
    with pytest.raises(sph.Error, match="performance_date"):
        result.dcc(lab)
    validate = _undeclared(source_dir, "validate.txt")
    measured = tmp_path / "m.xml"
    subprocess.run([os.environ["SPH_MEASURE"], validate, "-c", str(cal), "-q", "--dcc", str(measured),
                    "--dcc-settings", str(dated)], check=True, capture_output=True)
    m = sph.measure(validate, calibration=cal)
    assert m.dcc(dated) == measured.read_text()
    with pytest.raises(sph.Error, match="(?s)certificate_id.*laboratory_name"):
        m.dcc(performance_date="2026-12-04")
    with pytest.raises(sph.Error, match="country_code: 'Germany' is not an ISO 3166-1"):
        m.dcc(dated, country_code="Germany")


def test_measure_errors(source_dir):
    with pytest.raises(TypeError, match="'calib'"):
        sph.measure(_undeclared(source_dir, "validate.txt"), calib="x.json")
    with pytest.raises(sph.Error, match="calibration"):
        sph.measure(_undeclared(source_dir, "validate.txt"))
    with pytest.raises(sph.Error, match=r"\(n, 3\)"):
        sph.compensate(np.zeros((4, 2)), "x.json")


def test_residuals_are_the_reports(source_dir):
    r = sph.calibrate(_undeclared(source_dir, "points.txt"))
    assert r.residuals_um.shape == r.residuals_seven_um.shape == (576,)
    assert math.isclose(np.sqrt(np.mean(r.residuals_um ** 2)), r.report["after"]["rms_um"], rel_tol=1e-12)
    assert math.isclose(np.sqrt(np.mean(r.residuals_seven_um ** 2)), r.report["before"]["rms_um"], rel_tol=1e-12)


def test_the_stubs_name_what_the_module_has():
    import ast
    stub = ast.parse(open(os.path.join(os.path.dirname(sph.__file__), "sph.pyi")).read())
    stubbed = {n.name for n in stub.body if isinstance(n, (ast.FunctionDef, ast.ClassDef))}
    public = {name for name in dir(sph) if not name.startswith("_")}
    assert stubbed == public
    for cls in (n for n in stub.body if isinstance(n, ast.ClassDef)):
        members = {n.name for n in cls.body if isinstance(n, ast.FunctionDef) and not n.name.startswith("_")}
        assert members <= set(dir(getattr(sph, cls.name))), cls.name
    for function in ("calibrate", "measure"):  # each keyword stubbed is one the module takes (None: not given)
        stubbed = next(n for n in stub.body if isinstance(n, ast.FunctionDef) and n.name == function)
        for keyword in (a.arg for a in stubbed.args.kwonlyargs if a.arg != "center_mm"):
            with pytest.raises(sph.Error, match="/nonexistent"):
                getattr(sph, function)("/nonexistent", **{keyword: None})
    with pytest.raises(TypeError, match="'bogus'"):
        sph.calibrate("/nonexistent", bogus=None)
    # simulate and monte_carlo: each keyword stubbed is taken (None: not given), a bad value stops the run.
    for function, bad in (("simulate", {"theta_steps": 0, "noise_r_um": -1}), ("monte_carlo", {"trials": 1, "setups": 0})):
        stubbed = next(n for n in stub.body if isinstance(n, ast.FunctionDef) and n.name == function)
        assert stubbed.args.kwonlyargs
        for keyword in (a.arg for a in stubbed.args.kwonlyargs):
            other = next(k for k in bad if k != keyword)
            with pytest.raises(sph.Error, match="^--" + other.replace("_", "-")):
                getattr(sph, function)(**{other: bad[other], keyword: None})


def test_the_python_example_runs(source_dir, tmp_path):
    import sys
    png = tmp_path / "map.png"
    script = os.path.join(source_dir, "examples", "python", "calibrate_undeclared.py")
    out = subprocess.run([sys.executable, script, os.path.join(source_dir, "data", "example", "undeclared"), str(png)],
                         check=True, capture_output=True, text=True).stdout
    assert "residual rms 0.1560 -> 0.0491 um" in out
    assert "effects added: probe_drift, theta_encoder" in out
    assert "validation rms 0.0507 -> 0.0472 um" in out
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


# sph_simulate's options and the same as keywords: setups, effects, form, mount, scan order, outliers.
_SIMULATE_ARGS = ["--center-mm", "2,0,0", "--center-mm", "0,2,0", "--mount-rotation-deg", "1:0,0,90",
                  "--form-flat-um", "0.5,1,0,0", "--form-bump-um", "0.2,3,0,0,1", "--scan-order", "1:serpentine",
                  "--effect-arcsec", "theta_encoder.c2=6", "--effect-um", "probe_drift.t1=0.6", "--seed", "7",
                  "--noise-theta-arcsec", "0.5", "--outlier-fraction", "0.01", "--outlier-um", "5",
                  "--theta-steps", "36", "--alpha-deg", "0.01"]
_SIMULATE_KEYWORDS = dict(center_mm=[(2, 0, 0), "0,2,0"], mount_rotation_deg="1:0,0,90", form_flat_um="0.5,1,0,0",
                          form_bump_um=["0.2,3,0,0,1"], scan_order="1:serpentine", effect_arcsec="theta_encoder.c2=6",
                          effect_um=["probe_drift.t1=0.6"], seed=7, noise_theta_arcsec=0.5, outlier_fraction=0.01,
                          outlier_um=5, theta_steps=36, alpha_deg=0.01)


def test_simulate_equals_sph_simulate(tmp_path):
    app_points, app_truth = tmp_path / "app.txt", tmp_path / "truth.json"
    subprocess.run([os.environ["SPH_SIMULATE"], "-o", str(app_points), "--truth", str(app_truth)] + _SIMULATE_ARGS,
                   check=True)
    points, truth = sph.simulate(**_SIMULATE_KEYWORDS)
    assert truth == json.loads(app_truth.read_text())  # every key and number
    assert len(points) == 2 * 36 * 12 and points.setup.dtype == np.int32
    mine = tmp_path / "mine.txt"
    sph.write_points(mine, points)
    assert mine.read_bytes() == app_points.read_bytes()  # every reading as the file writes it
    app = sph.read_points(app_points)
    assert np.array_equal(points.setup, app.setup) and np.array_equal(points.t_s, app.t_s)
    for name in ("theta_deg", "phi_deg", "r_mm"):  # the file rounds to 10 decimals
        assert np.max(np.abs(getattr(points, name) - getattr(app, name))) <= 5.1e-11, name
    assert points.header["generator"] == "sph_simulate " + sph.__version__


def test_simulate_defaults_are_the_papers_study():
    points, truth = sph.simulate()
    assert len(points) == 288 and points.header["sphere_radius_mm"] == "20"
    assert truth["centers_mm"] == [[2.0, 0.0, 0.0]] and truth["seed"] == 1


def test_simulate_takes_a_setup_as_a_number():
    points, _ = sph.simulate(center_mm=[(2, 0, 0), (0, 2, 0)], mount_rotation_deg="1:0,0,90", mount_unknown=1)
    assert points.header["mount_rotation_deg@1"] == "unknown"
    assert sph.simulate(center_mm=[(2, 0, 0), (0, 2, 0)], mount_rotation_deg="1:0,0,90",
                        mount_unknown=[1])[0].header == points.header


def test_a_keyword_out_of_its_range_is_refused_by_the_librarys_check(example_points):
    cases = {"sphere_radius_u_um": (-5, r"must be >= 0 and <= 1000 um, got -5$"),
             "sphere_temperature_u_c": (-1, r"must be >= 0 and <= 50 K, got -1$"),
             "probe_range_mm": (math.inf, r"must be >= 0.002 and <= 10000 mm, got inf$"),
             "sphere_cte_per_k": (5, r"must be >= 0 and <= 0.001 1/K, got 5$"),
             "robust_scale_sigma": (1e300, r"must be >= 0.01 and <= 100, got 1e\+300$")}
    for key, (value, message) in cases.items():
        with pytest.raises(sph.Error, match=r"^calibration options: .*" + key + ": " + message):
            sph.calibrate(example_points, no_trace=True, **{key: value})
    with pytest.raises(sph.Error, match=r"^calibration options: alpha is held twice$"):
        sph.calibrate(example_points, no_trace=True, fix=["alpha", "alpha"])
    with pytest.raises(sph.Error, match=r"^calibration options: alpha is both held and given a prior"):
        sph.calibrate(example_points, no_trace=True, fix="alpha", prior="alpha_deg=0.02,0.001")


def test_a_keyword_of_the_wrong_type_is_named_with_the_type_it_takes(example_points):
    with pytest.raises(TypeError, match=r"^calibrate\(\): sphere_radius_mm takes a float \(or an int\), "
                                        r"not the str '20'$"):
        sph.calibrate(example_points, sphere_radius_mm="20")
    with pytest.raises(TypeError, match=r"^calibrate\(\): seed takes an int from 0 to \d+, not the int -1$"):
        sph.calibrate(example_points, seed=-1)
    with pytest.raises(TypeError, match=r"^calibrate\(\): effects takes a str or a sequence of str, not the int 5$"):
        sph.calibrate(example_points, effects=5)
    with pytest.raises(TypeError, match=r"^measure\(\): setup takes an int from -2147483648 to 2147483647, "
                                        r"not the str '1'$"):
        sph.measure(example_points, calibration="c.json", setup="1")
    with pytest.raises(TypeError, match=r"^monte_carlo\(\): trials takes an int from -2147483648 to 2147483647, "
                                        r"not the int 1099511627776$"):
        sph.monte_carlo(trials=2**40)
    with pytest.raises(sph.Error, match=r"^--eccentricities-mm: no eccentricity given"):
        sph.monte_carlo(trials=2, eccentricities_mm=[])


def test_simulate_errors():
    with pytest.raises(TypeError, match="'noise_um'"):
        sph.simulate(noise_um=0.1)
    with pytest.raises(TypeError, match=r"^simulate\(\): seed takes an int from 0 to 18446744073709551615, "
                                        r"not the str '7'$"):
        sph.simulate(seed="7")
    with pytest.raises(TypeError, match="center_mm takes a str, a number or a sequence of them, not the dict"):
        sph.simulate(center_mm={"x": 2})
    with pytest.raises(sph.Error, match=r"^--noise-r-um: must be >= 0 and <= 1000 um, got -1$"):
        sph.simulate(noise_r_um=-1)
    with pytest.raises(sph.Error, match=r"^--center-mm '1,0': expected x,y,z in mm$"):
        sph.simulate(center_mm="1,0")
    with pytest.raises(sph.Error, match="unknown effect 'probe_heat'"):
        sph.simulate(effect_um="probe_heat.t1=1")
    with pytest.raises(sph.Error, match="misses the sphere"):
        sph.simulate(center_mm=(0, 40, 0))


def test_monte_carlo_equals_sph_montecarlo(tmp_path):
    out = tmp_path / "mc.json"
    subprocess.run([os.environ["SPH_MONTECARLO"], "--trials", "4", "--eccentricities-mm", "1,2", "--seed", "5",
                    "--noise-r-um", "0.1", "--json", str(out), "--no-progress"], check=True, capture_output=True)
    app = json.loads(out.read_text())
    r = sph.monte_carlo(trials=4, eccentricities_mm=[1, 2], seed=5, noise_r_um=0.1)
    assert r.report["wall_time_s"] > 0
    del app["wall_time_s"], r.report["wall_time_s"]  # the one number a run measures
    assert r.report == app  # every other key and number, Table 3 too
    names = [f"{n}_{u}" for n, u in zip(("alpha", "a", "beta", "b", "epsilon", "c", "d_prime"),
                                        ("deg", "mm", "deg", "mm", "deg", "mm", "mm"))]
    assert list(r.trials) == ["eccentricity_mm", "trial"] + names
    converged = sum(row["converged"] for row in app["eccentricities"])
    for name, column in r.trials.items():
        assert column.shape == (converged,) and column.dtype == (np.int32 if name == "trial" else np.float64), name
    for row in app["eccentricities"]:  # the table's means are the report's
        at = r.trials["eccentricity_mm"] == row["eccentricity_mm"]
        assert list(r.trials["trial"][at]) == [t for t in range(1, 5) if t not in row["not_converged_trials"]]
        for name in names:
            p = row["parameters"][name.rsplit("_", 1)[0]]
            assert math.isclose(np.mean(r.trials[name][at]), p["mean"], rel_tol=1e-12), name
    assert "4 trials at 2 eccentricities" in repr(r)


def test_monte_carlo_errors():
    with pytest.raises(TypeError, match="'trial'"):
        sph.monte_carlo(trial=3)
    with pytest.raises(sph.Error, match=r"^--trials: must be >= 2 and <= 1e\+06, got 1$"):
        sph.monte_carlo(trials=1)
    with pytest.raises(sph.Error, match=r"--eccentricities-mm: 25 is not in \[0, R0\)"):
        sph.monte_carlo(trials=2, eccentricities_mm=25)
    with pytest.raises(sph.Error, match="--table3-calibration-e-mm 2: Table 3 uses"):
        sph.monte_carlo(trials=2, eccentricities_mm=[1])


def test_monte_carlo_releases_the_gil():
    import threading
    import time
    span = []

    def study():
        span.append(time.monotonic())
        sph.monte_carlo(trials=200, eccentricities_mm=[1, 2], table3=False, threads=1)
        span.append(time.monotonic())

    worker = threading.Thread(target=study)
    ticks = []
    worker.start()
    while worker.is_alive():
        ticks.append(time.monotonic())
        time.sleep(0.001)
    worker.join()
    start, end = span
    quarter = (end - start) / 4
    # Held, the GIL would keep this thread still from the call's start to its end.
    inside = [t for t in ticks if start + quarter < t < end - quarter]
    assert len(inside) > 5, f"{len(inside)} ticks in the middle of a {end - start:.3f} s study"


def test_the_pages_examples_print_what_it_quotes(source_dir):
    """Each ```python block of docs/python.md followed by a ```text block prints those lines, in order."""
    import re
    import sys
    page = open(os.path.join(source_dir, "docs", "python.md")).read()
    examples = re.findall(r"```python\n((?:(?!```).)*)```\n```text\n((?:(?!```).)*)```", page, re.S)
    assert len(examples) == 2
    for code, quoted in examples:
        out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True,
                             cwd=source_dir).stdout.splitlines()
        assert out == quoted.splitlines(), code
