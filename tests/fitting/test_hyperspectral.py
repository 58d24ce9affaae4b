"""Hyperspectral ``.pbsdf`` tables (any number of wavelengths, not the 5 that
Mitsuba's ``measured_polarized`` renders): ``pbrdf export --bands`` writes
them, ``read_pbsdf`` and ``pbrdf fit`` read and fit them."""

import os
import subprocess
import sys

import numpy as np
import pytest

from mitsuba_pbrdf import fitting
from mitsuba_pbrdf.errors import ParameterError
from mitsuba_pbrdf.measured.table_sampling import sample_table
from mitsuba_pbrdf.measured import export, pbsdf
from mitsuba_pbrdf.reference.params import PBRDFParams

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), os.pardir, os.pardir))
BANDS = list(range(450, 701, 25))            # 11 bands: more than one chunk of tabulate


def run_cli(*args):
    env = dict(os.environ, PYTHONPATH=ROOT)
    return subprocess.run([sys.executable, "-m", "mitsuba_pbrdf", *args], capture_output=True,
                          text=True, env=env, cwd=ROOT, timeout=300)


@pytest.mark.parametrize("text, expected", [
    ("450:700:25", BANDS),
    ("400,450,500", [400, 450, 500]),
    ("400:420:10,500,600:610:5", [400, 410, 420, 500, 600, 605, 610]),
    ("400:430:20", [400, 420]),                      # STOP off the grid: not included
    (" 555 ", [555]),
])
def test_parse_bands(text, expected):
    assert export.parse_bands(text) == expected


@pytest.mark.parametrize("call, parameter", [
    (lambda: export.parse_grid("49x80"), "grid"),
    (lambda: export.Grid(1, 9, 9), "grid"),
    (lambda: export.Grid(5, 5, 5, "log"), "grid"),
    (lambda: export.parse_bands("blue"), "bands"),
    (lambda: export.parse_bands("500,450", what="wavelengths"), "wavelengths"),
])
def test_library_errors_name_the_parameter_not_a_cli_option(call, parameter):
    """The library names its parameter (the command line turns it into ``--grid``)."""
    with pytest.raises(ParameterError) as info:
        call()
    assert info.value.parameter == parameter
    assert str(info.value).startswith(f"{parameter}: ") and "--" not in str(info.value)


def test_chunked_tabulation_equals_one_pass():
    """tabulate evaluates a few wavelengths at a time (BAND_CHUNK); the
    wavelengths are independent, so the chunks give the values of one pass
    (to rounding: NumPy may vectorize a different array length differently)."""
    assert len(BANDS) > export.BAND_CHUNK
    p = PBRDFParams(material="Cu", sigma=0.2, kdd=0.1, kid=0.02)
    axes = export.Grid(5, 6, 7).axes()
    chunked = export.tabulate(p, *axes, BANDS)
    one = np.concatenate([export.tabulate(p, *axes, [w]) for w in BANDS], axis=-3)
    assert chunked.shape == (5, 6, 7, len(BANDS), 4, 4)
    np.testing.assert_allclose(chunked, one, rtol=1e-12, atol=1e-15)


def test_export_bands_writes_a_hyperspectral_table_that_fits(tmp_path):
    """11 bands of copper: the table reads (not renderable: measured_polarized
    reads exactly 5) and the fit recovers Mitsuba's n, k of copper at every band
    and the shared parameters within 1e-3 (noise-free float32 entries, the
    criterion of tests/fitting/test_table_sampling.py for 5 bands)."""
    out = str(tmp_path / "cu11.pbsdf")
    r = run_cli("export", "--material", "Cu", "--sigma", "0.15", "--kdd", "0.1",
                "--sigma-dd", "0.5", "--kid", "0.02", "--bands", "450:700:25",
                "--grid", "13x18x18", "--out", out)
    assert r.returncode == 0, r.stderr
    assert "11 from 450 to 700 nm" in r.stdout and "renders only tables of exactly 5" in r.stdout
    t = pbsdf.read_pbsdf(out)
    assert t.shape == (13, 18, 18, 11, 4, 4) and t.wavelengths.tolist() == BANDS
    assert not t.renderable
    data = sample_table(t, cells=150)
    fit = fitting.fit_model(data, "three", starts=1, material="Cu")
    n, k = PBRDFParams(material="Cu").ior(np.array(BANDS, dtype=float))
    assert fit.success and not fit.undetermined
    np.testing.assert_allclose(fit.values["n"], n, rtol=1e-3)
    np.testing.assert_allclose(fit.values["k"], k, rtol=1e-3)
    for p, v in dict(sigma=0.15, ks=1.0, kdd=0.1, sigma_dd=0.5, kid=0.02).items():
        assert abs(fit.values[p] / v - 1) < 1e-3, (p, fit.values[p])


def test_bands_outside_a_named_material_are_refused_before_writing(tmp_path):
    out = tmp_path / "x.pbsdf"
    r = run_cli("export", "--material", "Al", "--bands", "400:1000:100", "--grid", "5x5x5",
                "--out", str(out))
    assert r.returncode == 2 and "table range" in r.stderr and not out.exists()
    r = run_cli("export", "--eta", "1.5", "--k", "0", "--bands", "400:1600:100",
                "--grid", "5x5x5", "--out", str(out))
    assert r.returncode == 0, r.stderr
    assert pbsdf.read_pbsdf(str(out)).wavelengths.tolist() == list(range(400, 1601, 100))


def test_fit_chosen_bands_of_a_hyperspectral_table(tmp_path, capsys):
    """pbrdf fit --wavelength fits only the chosen bands of a table (n, k at
    those bands, within 1e-3 on noise-free entries) and draws them."""
    import json

    from mitsuba_pbrdf.cli import main

    path = str(tmp_path / "cu.pbsdf")
    p = PBRDFParams(material="Cu", sigma=0.15, kdd=0.1, sigma_dd=0.5, kid=0.02)
    export.export_pbsdf(path, p, export.Grid(13, 18, 18), wavelengths=BANDS)
    out, png = tmp_path / "fit.json", tmp_path / "fit.png"
    assert main(["fit", path, "--wavelength", "500,600", "--cells", "150", "--starts", "1",
                 "--model", "three", "--material", "Cu", "--json", str(out),
                 "--plot", str(png)]) == 0
    assert "at 2 of its wavelengths" in capsys.readouterr().out and png.stat().st_size > 0
    r = json.loads(out.read_text())["three"]
    assert r["wavelengths"] == [500.0, 600.0]
    n, k = p.ior(np.array([500.0, 600.0]))
    np.testing.assert_allclose(r["values"]["n"], n, rtol=1e-3)
    np.testing.assert_allclose(r["values"]["k"], k, rtol=1e-3)
    assert main(["fit", path, "--wavelength", "510"]) == 2
    assert "no measurement at 510 nm" in capsys.readouterr().err
