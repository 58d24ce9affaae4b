"""``pbrdf plot`` for anisotropic surfaces: the hemisphere maps turn with the
light's azimuth, the stretched highlight lies along the axis of the larger
RMS slope, and the sheet adds maps with the light turned by 90 degrees."""

import math
import os
import subprocess
import sys

import numpy as np
import pytest

from mitsuba_pbrdf.visualization.pbrdf_plots import PBRDFParams, hemisphere, pbrdf_figure

ROOT = os.path.join(os.path.dirname(__file__), os.pardir, os.pardir)
BRUSHED = PBRDFParams(material="Al", sigma_u=0.3, sigma_v=0.03)


def _elongation(X, Y, M, direction):
    """Ratio of M00's second moments about its peak along *direction* (unit
    (x, y)) and across it."""
    w = np.nan_to_num(M[..., 0, 0])
    x0, y0 = (np.sum(w * a) / np.sum(w) for a in (X, Y))
    along = (X - x0) * direction[0] + (Y - y0) * direction[1]
    across = -(X - x0) * direction[1] + (Y - y0) * direction[0]
    return np.sum(w * along**2) / np.sum(w * across**2)


@pytest.mark.parametrize("phi_i", [0.0, 30.0, 90.0])
def test_the_highlight_is_stretched_along_the_rough_axis(phi_i):
    """The s axis (azimuth 0, where the RMS slope is sigma_u = 10 sigma_v) is
    drawn at (-cos phi_i, -sin phi_i): the M00 map's spread along it is
    several times the spread across it (a factor > 4; a 10:1 slope ratio
    gives about 10:1 in angle near the mirror direction, less at grazing)."""
    X, Y, M = hemisphere(BRUSHED, 30.0, resolution=160, phi_i=phi_i)
    c, s = math.cos(math.radians(phi_i)), math.sin(math.radians(phi_i))
    assert _elongation(X, Y, M, (-c, -s)) > 4.0
    # the isotropic lobe is round to within the projection's distortion
    X, Y, M = hemisphere(PBRDFParams(material="Al", sigma=0.1), 30.0, resolution=160,
                         phi_i=phi_i)
    assert 0.5 < _elongation(X, Y, M, (-c, -s)) < 2.0


def test_turning_an_isotropic_surface_changes_nothing():
    a = hemisphere(PBRDFParams(material="Al", sigma=0.1, kdd=0.2), 40.0, resolution=40)[2]
    b = hemisphere(PBRDFParams(material="Al", sigma=0.1, kdd=0.2), 40.0, resolution=40,
                   phi_i=57.0)[2]
    np.testing.assert_allclose(np.nan_to_num(b), np.nan_to_num(a), rtol=1e-9, atol=1e-12)


def test_anisotropic_sheet_adds_the_turned_maps():
    fig = pbrdf_figure(BRUSHED, 45.0, resolution=40, phi_i=10.0)
    titles = [ax.get_title() for ax in fig.axes if ax.get_title()]
    assert len(titles) == 8
    assert sum("φi = 100°" in t for t in titles) == 2
    assert "σu=0.3, σv=0.03" in fig.get_suptitle()


def test_command_line_plots_an_anisotropic_surface(tmp_path):
    out = tmp_path / "aniso.png"
    result = subprocess.run([sys.executable, "-m", "mitsuba_pbrdf", "plot", "--sigma-u", "0.3",
                             "--sigma-v", "0.03", "--distribution", "ggx", "--phi-i", "30",
                             "--out", str(out)], capture_output=True, text=True, cwd=ROOT,
                            timeout=300)
    assert result.returncode == 0, result.stderr
    assert out.stat().st_size > 50_000 and "GGX" in result.stdout
    bad = subprocess.run([sys.executable, "-m", "mitsuba_pbrdf", "plot", "--sigma-v", "-1",
                          "--out", str(tmp_path / "x.png")], capture_output=True, text=True,
                         cwd=ROOT, timeout=300)
    assert bad.returncode == 2 and "sigma_v" in bad.stderr and bad.stderr.count("\n") == 1


def test_export_describes_the_anisotropic_directional_diffuse_widths(tmp_path, capsys):
    """pbrdf export's line named sigma_dd only, though it tabulated sigma_dd_u
    (issue 28); the description now gives both widths of that lobe."""
    from mitsuba_pbrdf.cli import main

    out = str(tmp_path / "t.pbsdf")
    assert main(["export", "--kdd", "0.2", "--sigma-dd-u", "0.3", "--grid", "4x6x6",
                 "--out", out]) == 0
    line = capsys.readouterr().out
    assert "σdd_u=0.3, σdd_v=0.5" in line, line
    table = PBRDFParams(material="Al", kdd=0.2, sigma_dd_u=0.3)
    assert "σdd=" not in table.label()
