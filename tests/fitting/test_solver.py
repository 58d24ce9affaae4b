"""Fitting the model to measurements (mitsuba_pbrdf.fitting, mitsuba_pbrdf.measured): recovery of known
parameters from synthetic noisy measurements, the Dr.Jit backend against the
reference one, the two-component model's larger error, malformed CSV files,
and the command line."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from mitsuba_pbrdf import fitting, measured, reference

ROOT = os.path.join(os.path.dirname(__file__), os.pardir, os.pardir)
DATA = os.path.join(os.path.dirname(__file__), os.pardir, "data")
TRUTH = dict(n=1.2, k=7.26, sigma=0.12, ks=0.9, kdd=0.15, sigma_dd=0.45, kid=0.02)


def synthetic(quantities=("m00", "dolp"), seed=1, **kw):
    return fitting.synthetic_measurements(TRUTH, quantities=quantities, noise=0.02, seed=seed, **kw)


def test_recovers_parameters_from_m00_and_dolp():
    """M00 + DoLP with 2 % noise (270 measurements, 633 nm): every parameter
    within 3 standard uncertainties of the truth; n, k within 5 % and sigma,
    ks, kdd, sigma_dd within 2 % of it. kid is weakly constrained (its lobe,
    kid / pi = 0.006 /sr, is a small addition to the directional diffuse one):
    its standard uncertainty must stay below 8 % of its value (measured 7.1 %),
    so it is held to 3 x that, about 21 %, and no tighter. The fit's
    chi-square matches the noise."""
    data = synthetic()
    r = fitting.fit_model(data, "three", material="Al")
    assert r.success
    for p in ("n", "k"):
        v, e = r.values[p][0], r.errors[p][0]
        assert abs(v - TRUTH[p]) <= 3 * e and abs(v / TRUTH[p] - 1) < 0.05, (p, v, e)
    for p in ("sigma", "ks", "kdd", "sigma_dd"):
        v, e = r.values[p], r.errors[p]
        assert abs(v - TRUTH[p]) <= 3 * e and abs(v / TRUTH[p] - 1) < 0.02, (p, v, e)
    v, e = r.values["kid"], r.errors["kid"]
    assert abs(v - TRUTH["kid"]) <= 3 * e and e < 0.08 * TRUTH["kid"], (v, e)
    assert 0.7 < r.reduced_chi2 < 1.3


def test_m00_alone_cannot_separate_n_and_k():
    """Unpolarized reflectance alone leaves n and k undetermined (ks absorbs
    the Fresnel level; their uncertainties exceed their values), while the
    roughness and lobe weights are still recovered. (Started from aluminium's
    tabulated index; naming n and k in ``init`` keeps them free, where a named
    material alone would fix them: test_fit_real.py.)"""
    n0, k0 = reference.conductor_ior("Al", [633.0])
    r = fitting.fit_model(synthetic(("m00",)), "three", init=dict(n=n0[0], k=k0[0]))
    assert r.errors["n"][0] > r.values["n"][0] or "n(633 nm)" in r.at_bound
    assert r.errors["k"][0] > 0.5 * r.values["k"][0] or "k(633 nm)" in r.at_bound
    assert abs(r.values["sigma"] / TRUTH["sigma"] - 1) < 0.01


def test_two_component_model_fits_worse():
    """Data from the three-component model: the two-component fit's reduced
    chi-square and relative M00 error are several times larger (as the paper
    reports against measurements)."""
    results = fitting.fit_models(synthetic(), material="Al")
    three, two = results["three"], results["two"]
    assert two.reduced_chi2 > 5 * three.reduced_chi2
    assert two.relative_rms["m00"] > 2 * three.relative_rms["m00"]
    text = fitting.report(synthetic(), results, TRUTH)
    assert "Model comparison" in text and "two-component" in text


def test_several_wavelengths_and_mueller_elements():
    """n, k per wavelength from M00, m10, m22 (a subset of Mueller elements),
    two wavelengths; uncertainties not given (assumed and scaled)."""
    data = fitting.synthetic_measurements(dict(TRUTH, n=(1.0, 1.6), k=(6.5, 8.0)),
                                      quantities=("m00", "m10", "m22"), wavelengths=(500, 700),
                                      theta_i=(30.0, 60.0), noise=0.01, seed=2)
    data.uncertainty.clear()
    r = fitting.fit_model(data, "three", init="n=1.3,k=7")
    np.testing.assert_allclose(r.values["n"], [1.0, 1.6], rtol=0.05)
    np.testing.assert_allclose(r.values["k"], [6.5, 8.0], rtol=0.05)
    assert np.all(np.isfinite(r.errors["n"]))


@pytest.mark.slow
def test_drjit_backend_agrees_with_reference():
    """The same fit with the plugin (float32, forward-mode Jacobian)."""
    data = synthetic(theta_i=(45.0,))
    ref_fit = fitting.fit_model(data, "three", material="Al", starts=1)
    dr_fit = fitting.fit_model(data, "three", material="Al", starts=1, backend="drjit")
    for p in ("n", "k"):
        assert abs(dr_fit.values[p][0] - ref_fit.values[p][0]) < 0.2 * ref_fit.errors[p][0]
    for p in ("sigma", "ks", "kdd", "sigma_dd", "kid"):
        assert abs(dr_fit.values[p] - ref_fit.values[p]) < 0.2 * ref_fit.errors[p], p
    assert dr_fit.chi2 == pytest.approx(ref_fit.chi2, rel=1e-3)


def test_fixed_parameters_stay_fixed():
    r = fitting.fit_model(synthetic(), "three", fix="n=1.2,k=7.26,kid=0.02")
    assert r.values["n"][0] == 1.2 and r.values["kid"] == 0.02
    assert np.isnan(r.errors["n"][0]) and np.isnan(r.errors["kid"])
    assert abs(r.values["sigma"] / TRUTH["sigma"] - 1) < 0.01


# ------------------------------------------------------------------ files

def test_csv_round_trip(tmp_path):
    data = synthetic()
    path = measured.write_measurements(data, tmp_path / "m.csv")
    back = measured.read_measurements(path)
    assert len(back) == len(data)
    np.testing.assert_allclose(back.observed["m00"], data.observed["m00"], rtol=1e-8)
    np.testing.assert_allclose(back.uncertainty["dolp"], data.uncertainty["dolp"], rtol=1e-8)


def test_example_file_reads():
    data = measured.read_measurements(os.path.join(DATA, "fit_example.csv"))
    assert set(data.observed) == {"m00", "dolp"} and "dolp" in data.uncertainty
    assert len(data) > 100


GOOD_HEADER = "theta_i,phi_i,theta_r,phi_r,wavelength,m00,dolp"
GOOD_ROW = "30,0,30,180,633,2.5,0.05"

BAD_FILES = {
    "missing-column": ("theta_i,phi_i,theta_r,wavelength,m00\n30,0,30,633,1\n",
                       "missing column(s) phi_r"),
    "no-quantity": ("theta_i,phi_i,theta_r,phi_r,wavelength\n30,0,30,180,633\n",
                    "no measured quantity"),
    "nan": (f"{GOOD_HEADER}\n{GOOD_ROW}\n30,0,nan,180,633,1,0.1\n", "line 3: column 'theta_r' is NaN"),
    "text": (f"{GOOD_HEADER}\n{GOOD_ROW}\n30,0,abc,180,633,1,0.1\n", "is not a number: 'abc'"),
    "theta-out-of-range": (f"{GOOD_HEADER}\n{GOOD_ROW}\n95,0,30,180,633,1,0.1\n",
                           "line 3: theta_i"),
    "negative-theta": (f"{GOOD_HEADER}\n-5,0,30,180,633,1,0.1\n", "out of range [0, 90)"),
    "phi-out-of-range": (f"{GOOD_HEADER}\n30,400,30,180,633,1,0.1\n", "phi_i is out of range"),
    "wavelength": (f"{GOOD_HEADER}\n30,0,30,180,0,1,0.1\n", "wavelength must be > 0"),
    "negative-m00": (f"{GOOD_HEADER}\n30,0,30,180,633,-1,0.1\n", "m00 is negative"),
    "dolp-above-1": (f"{GOOD_HEADER}\n30,0,30,180,633,1,1.5\n", "dolp is outside [0, 1]"),
    "empty-row-value": (f"{GOOD_HEADER}\n30,0,30,180,633,,\n", "no measured value"),
    "bad-uncertainty": (f"{GOOD_HEADER},m00_err\n30,0,30,180,633,1,0.1,0\n", "m00_err must be > 0"),
    "orphan-uncertainty": (f"{GOOD_HEADER},m11_err\n30,0,30,180,633,1,0.1,1\n",
                           "has no column 'm11'"),
    "ragged": (f"{GOOD_HEADER}\n30,0,30,180,633,1\n", "6 fields, the header has 7"),
    "header-only": (f"{GOOD_HEADER}\n", "no data rows"),
    "empty": ("", "empty file"),
    "duplicate": ("theta_i,theta_i,phi_i,theta_r,phi_r,wavelength,m00\n", "duplicate column"),
}


@pytest.mark.parametrize("name", sorted(BAD_FILES))
def test_malformed_csv_gives_clear_error(tmp_path, name):
    text, message = BAD_FILES[name]
    path = tmp_path / f"{name}.csv"
    path.write_text(text)
    with pytest.raises(measured.MeasurementError, match=message.replace("(", r"\(").replace(")", r"\)")
                       .replace("[", r"\[").replace("]", r"\]")):
        measured.read_measurements(path)


def test_unknown_columns_are_reported_not_fatal(tmp_path):
    path = tmp_path / "extra.csv"
    path.write_text(f"{GOOD_HEADER},operator\n{GOOD_ROW},me\n")
    assert measured.read_measurements(path).ignored_columns == ["operator"]


def test_missing_file():
    with pytest.raises(measured.MeasurementError, match="no such file"):
        measured.read_measurements("/nonexistent/measurements.csv")


# ------------------------------------------------------------------ command line

def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "mitsuba_pbrdf", "fit", *args], cwd=ROOT,
                          capture_output=True, text=True, timeout=300)


def test_command_line_fits_and_plots(tmp_path):
    out_png, out_json = tmp_path / "fit.png", tmp_path / "fit.json"
    proc = run_cli(os.path.join(DATA, "fit_example.csv"), "--material", "Al", "--starts", "1",
                   "--plot", str(out_png), "--json", str(out_json))
    assert proc.returncode == 0, proc.stderr
    assert "Model comparison" in proc.stdout and "+/-" in proc.stdout
    assert out_png.stat().st_size > 10_000
    results = json.loads(out_json.read_text())
    assert set(results) == {"three", "two"}
    assert results["three"]["reduced_chi2"] < results["two"]["reduced_chi2"]


def test_command_line_error_is_one_line(tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("theta_i,phi_i,theta_r,wavelength,m00\n30,0,30,633,1\n")
    proc = run_cli(str(bad))
    assert proc.returncode == 2
    assert proc.stderr.startswith("pbrdf fit: error:") and "phi_r" in proc.stderr
    assert proc.stderr.count("\n") == 1
