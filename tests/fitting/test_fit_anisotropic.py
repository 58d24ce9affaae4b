"""Anisotropic fits (``fit_model(anisotropic=True)``, ``pbrdf fit
--anisotropic``): sigma_u and sigma_v recovered where the measurements'
azimuths resolve them; on an isotropic surface they come out equal within
their uncertainty, or undetermined where the azimuths cannot tell them apart
(never a false split); the GGX specular lobe is fitted too."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from mitsuba_pbrdf import fitting

ROOT = os.path.join(os.path.dirname(__file__), os.pardir, os.pardir)
TRUTH = dict(n=1.2, k=7.26, sigma=0.12, ks=0.9, kdd=0.15, sigma_dd=0.45, kid=0.02)
BRUSHED = dict(TRUTH, sigma_u=0.2, sigma_v=0.07)


def synthetic(truth, seed, **kw):
    """M00 and DoLP with 2 % noise; light at azimuths 0 and 90 deg unless told."""
    kw.setdefault("phi_i", (0.0, 90.0))
    return fitting.synthetic_measurements(truth, quantities=("m00", "dolp"), noise=0.02,
                                          seed=seed, **kw)


def test_recovers_sigma_u_and_sigma_v():
    """Brushed surface (sigma_u/sigma_v = 2.9), two light azimuths: both within
    3 standard uncertainties of the truth, and the split resolved."""
    r = fitting.fit_model(synthetic(BRUSHED, 1), "three", material="Al", anisotropic=True)
    for p in ("sigma_u", "sigma_v"):
        assert abs(r.values[p] - BRUSHED[p]) <= 3 * r.errors[p], (p, r.values[p], r.errors[p])
    difference, sd = r.anisotropy["sigma"]
    assert difference > 3 * sd
    assert "sigma" not in r.values and "resolved: the surface is anisotropic" in fitting.report(
        synthetic(BRUSHED, 1), {"three": r})


@pytest.mark.parametrize("seed", [2, 3])
def test_an_isotropic_surface_reports_equal_widths(seed):
    """Isotropic data, anisotropic fit: |sigma_u - sigma_v| within 3 standard
    uncertainties of their difference (a 3-sigma test: a false split in
    fewer than 0.3 % of noise draws)."""
    data = synthetic(TRUTH, seed)
    r = fitting.fit_model(data, "three", material="Al", anisotropic=True)
    difference, sd = r.anisotropy["sigma"]
    assert np.isfinite(sd) and abs(difference) <= 3 * sd, (difference, sd)
    assert abs(r.values["sigma_u"] - TRUTH["sigma"]) <= 3 * r.errors["sigma_u"]
    assert "not resolved: consistent with an isotropic surface" in fitting.report(
        data, {"three": r})


def test_in_plane_measurements_leave_the_split_undetermined():
    """Light and detector in one plane (azimuth 0): every facet seen has
    slope 0 along y, so sigma_v only scales the lobe's peak, as ks does. The
    fit must say undetermined, never report a split."""
    data = synthetic(TRUTH, 4, phi_i=(0.0,), out_of_plane=False)
    r = fitting.fit_model(data, "three", material="Al", anisotropic=True)
    assert "sigma_v" in r.undetermined and r.errors["sigma_v"] == np.inf
    assert r.anisotropy["sigma"][1] == np.inf
    assert "undetermined" in fitting.report(data, {"three": r})
    assert r.as_dict()["anisotropy"]["sigma"]["uncertainty"] is None


def test_sigma_sets_both_refinements_and_refinements_need_an_anisotropic_fit():
    data = synthetic(BRUSHED, 5)
    r = fitting.fit_model(data, "three", material="Al", anisotropic=True, fix="sigma=0.1",
                          starts=1)
    assert r.values["sigma_u"] == r.values["sigma_v"] == 0.1
    assert "sigma_u" not in r.free and "sigma_v" not in r.free
    with pytest.raises(ValueError, match="sigma_u is fitted only in an anisotropic fit"):
        fitting.fit_model(data, "three", init="sigma_u=0.2")


def test_ggx_specular_lobe_is_fitted():
    truth = dict(BRUSHED, sigma_u=0.15, sigma_v=0.05)
    data = synthetic(truth, 6, distribution="ggx")
    r = fitting.fit_model(data, "three", material="Al", anisotropic=True, distribution="ggx")
    assert r.distribution == "ggx"
    for p in ("sigma_u", "sigma_v"):
        assert abs(r.values[p] - truth[p]) <= 3 * r.errors[p]


def test_command_line_anisotropic_fit(tmp_path):
    from mitsuba_pbrdf.measured import write_measurements

    path = tmp_path / "brushed.csv"
    write_measurements(synthetic(BRUSHED, 7), str(path))
    out = tmp_path / "fit.json"
    result = subprocess.run([sys.executable, "-m", "mitsuba_pbrdf", "fit", str(path),
                             "--anisotropic", "--model", "three", "--material", "Al",
                             "--starts", "1", "--json", str(out)],
                            capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert result.returncode == 0, result.stderr
    assert "sigma_u - sigma_v" in result.stdout and "resolved" in result.stdout
    fit = json.loads(out.read_text())["three"]
    assert fit["anisotropic"] and abs(fit["values"]["sigma_u"] - 0.2) < 0.01
