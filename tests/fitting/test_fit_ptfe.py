"""The fit of a real diffuser (``validation/fit_ptfe.py``, CI-sized): NIST's
PTFE measurement, the subset in ``tests/data`` at 532 nm, read as published
and fitted by ``pbrdf fit``. No number here is taken from the study's
results: the checks are properties that hold whatever the file holds (the
command's outputs, the nesting of the two models) or that physics fixes (the
mirror symmetry of an isotropic sample in the plane of incidence)."""

import json
import os

import numpy as np

from mitsuba_pbrdf.cli import main
from mitsuba_pbrdf.fitting import fit_model
from mitsuba_pbrdf.measured import read_measurements
from mitsuba_pbrdf.measured.selection import select_wavelengths

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), os.pardir, os.pardir))
PTFE = os.path.join(ROOT, "tests", "data", "nist_ptfe_subset.csv")
ELEMENTS = [f"m{i}{j}" for i in range(4) for j in range(4)]


def test_pbrdf_fit_reads_and_fits_the_published_file(tmp_path, capsys):
    out = tmp_path / "ptfe.json"
    assert main(["fit", PTFE, "--wavelength", "532", "--starts", "1",
                 "--init", "n=1.35,k=0.01", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "304 measurements, 4864 values" in text and "wavelengths 532 nm" in text
    results = json.loads(out.read_text())
    assert set(results) == {"three", "two"}
    for r in results.values():
        assert r["wavelengths"] == [532.0] and sorted(r["rms"]) == sorted(ELEMENTS)
        assert all(np.isfinite(v) for v in r["rms"].values()) and np.isfinite(r["chi2"])


def test_three_components_fit_at_least_as_well_as_two():
    """The two-component model is the three-component one with kdd = 0: started
    from the two-component optimum, the three-component fit (a descent method
    that accepts no step raising chi-square) cannot end worse. The 1e-6 covers
    the start being moved from kdd = 0 into the interior of the bounds."""
    data = select_wavelengths(read_measurements(PTFE), [532])
    two = fit_model(data, "two", starts=1, init=dict(n=1.35, k=0.01))
    start = {p: float(two.values[p]) for p in ("sigma", "ks", "kid")}
    start.update(n=float(two.values["n"][0]), k=float(two.values["k"][0]), kdd=0.0)
    three = fit_model(data, "three", starts=1, init=start)
    assert three.chi2 <= two.chi2 * (1 + 1e-6), (three.chi2, two.chi2)


def test_in_plane_symmetry_of_the_measured_matrices():
    """An isotropic sample is mirror-symmetric about the plane of incidence:
    there the Mueller matrix is block-diagonal (m02, m03, m12, m13, m20, m21,
    m30, m31 vanish) in the global s/p frames, up to the measurement's noise.
    Read with the elements where the conversion puts them, the off-block
    elements (normalized by M00) are smaller than the in-block ones; an index
    or frame wrongly mapped mixes the two groups."""
    data = read_measurements(PTFE)
    dphi = np.radians(data.phi_r - data.phi_i)
    rows = np.abs(np.sin(dphi)) < 1e-3
    assert rows.sum() >= 10
    m00 = data.observed["m00"][rows]
    rms = lambda names: np.sqrt(np.mean([(data.observed[q][rows] / m00) ** 2 for q in names]))
    off = rms(["m02", "m03", "m12", "m13", "m20", "m21", "m30", "m31"])
    block = rms(["m01", "m10", "m11", "m22", "m23", "m32", "m33"])
    assert off < block, (off, block)
    # the model is block-diagonal there exactly (its in-plane symmetry)
    from mitsuba_pbrdf.fitting.observables import model_observables
    values = dict(n=1.35, k=0.01, sigma=0.2, ks=0.5, kdd=0.1, sigma_dd=0.5, kid=0.9)
    model = model_observables(data, values, names=ELEMENTS)
    scale = np.abs(model["m00"][rows]).max()
    for q in ("m02", "m03", "m12", "m13", "m20", "m21", "m30", "m31"):
        assert np.abs(model[q][rows]).max() <= 1e-12 * scale, q
