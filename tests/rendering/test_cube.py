"""Stokes cubes (``render_scene(..., bands=...)``, ``pbrdf render --bands``,
mitsuba_pbrdf.rendering.cube) against the float64 reference evaluator on
scenes/analytic_plane.xml, with the complex index of test_narrowband.py that is
flat outside 600-670 nm and steep inside (n 0.3 -> 1.5, k 3 -> 6), so that each
band of a cube over 600-680 nm sees a different BRDF; and against per-band
``--wavelength`` renders of the same scene."""

import os

import numpy as np
import pytest

from mitsuba_pbrdf import use_variant
from mitsuba_pbrdf.cli import main
from mitsuba_pbrdf.errors import ParameterError
from mitsuba_pbrdf.rendering import render_scene
from mitsuba_pbrdf.rendering.bands import MAX_BANDS, parse_bands
from mitsuba_pbrdf.rendering.render import check_render
from mitsuba_pbrdf.rendering.scene_setup import StokesSceneError
from mitsuba_pbrdf.stokes import read_stokes_exr
from mitsuba_pbrdf.stokes.exr import read_exr_channels
from tests.rendering.test_render import SCENE
from tests.rendering.test_narrowband import VARIANT, params, reference_image

pytestmark = pytest.mark.usefixtures("restore_variant")
#: 4 bands of 20 nm across the steep part of the index
BANDS = "600:680:20"
#: 256 spp: each band gets about a quarter of the wavelength samples, and the
#: test must resolve neighbouring bands (20 nm apart) from one another
SPP, PASSES = 256, 4


def test_parse_bands():
    cube = parse_bands("450:650:20")
    assert len(cube.edges) == 10 and cube.edges[0] == (450, 470) and cube.edges[-1] == (630, 650)
    assert cube.names[:2] == ["460nm", "480nm"] and cube.total_width == 200
    mixed = parse_bands("450:470, 532:533,600:650")
    assert mixed.names == ["460nm", "532.5nm", "625nm"]
    assert mixed.header() == "450-470,532-533,600-650" and mixed.total_width == 71
    assert len(parse_bands("400:720:5").edges) == MAX_BANDS
    assert parse_bands("450:500,500:550").edges == ((450, 500), (500, 550))  # touching is fine
    for bad, text in [("", "comma-separated list"), ("450", "START:STOP:STEP or LOW:HIGH"),
                      ("a:b", "expects START:STOP:STEP"), ("inf:500", "finite"),
                      ("500:500", "reversed or empty"), ("450:500:0", "STEP > 0"),
                      ("450:500,490:510", "overlap"), ("350:400", "within 360-830"),
                      ("400:725:5", "65 bands; at most 64"), ("450:450.005", "narrower"),
                      ("450:500:15", "whole number")]:
        with pytest.raises(ParameterError, match=text) as error:
            parse_bands(bad)
        # the library names its parameter; only the command line names the option
        assert error.value.parameter == "bands" and "--" not in str(error.value)


def test_check_render_refuses_bands_in_a_non_spectral_variant_and_with_a_wavelength():
    with pytest.raises(ParameterError, match="needs a spectral variant") as error:
        check_render(SCENE, variant="llvm_ad_mono_polarized", bands=BANDS)
    assert error.value.parameter == "bands"
    with pytest.raises(ParameterError, match="not both"):
        check_render(SCENE, variant=VARIANT, bands=BANDS, wavelength="600")
    assert check_render(SCENE, variant=VARIANT, bands=BANDS).mode.band_names[0] == "610nm"
    with pytest.raises(ParameterError, match="40 bands need at least 10 samples per pixel"):
        check_render(SCENE, variant=VARIANT, bands="450:650:5", spp=9)


def test_band_counts_are_even():
    """Every band gets the same number of wavelengths per pixel, to one."""
    from mitsuba_pbrdf.rendering.cube import band_counts

    assert list(band_counts(10, 16)) == [7, 7, 7, 7, 6, 6, 6, 6, 6, 6]
    assert band_counts(64, 16).min() == 1 and band_counts(3, 3).sum() == 12


def test_a_scene_whose_integrator_cannot_be_run_is_refused_before_loading(tmp_path):
    """The cube runs the integrator stokes wraps: stokes around two integrators,
    or around prb, is refused by check_render (a bare path is run as it is)."""
    text = open(SCENE).read().replace('<integrator type="stokes">', '<integrator type="stokes">'
                                      '<integrator type="path"/>', 1)
    (tmp_path / "two.xml").write_text(text)
    with pytest.raises(StokesSceneError, match="wraps no single integrator"):
        check_render(tmp_path / "two.xml", variant=VARIANT, bands=BANDS)
    prb = open(SCENE).read().replace('<integrator type="direct"/>', '<integrator type="prb"/>')
    (tmp_path / "prb.xml").write_text(prb)
    with pytest.raises(StokesSceneError, match="prb ignores Mueller frame rotations"):
        check_render(tmp_path / "prb.xml", variant=VARIANT, bands=BANDS)
    bare = open(SCENE).read().replace('<integrator type="stokes">', '', 1).replace(
        '<integrator type="direct"/>\n    </integrator>', '<integrator type="direct"/>', 1)
    (tmp_path / "bare.xml").write_text(bare)
    request = check_render(tmp_path / "bare.xml", variant=VARIANT, bands=BANDS)
    assert request.notice is None and request.setup.integrator == "nested"


def cube_passes(passes=1, **options):
    """PASSES independent renders (each in *passes* passes), shape
    (PASSES, H, W, 4, bands)."""
    return np.stack([render_scene(SCENE, spp=SPP, seed=11 + 100 * i, params=params(),
                                  passes=passes, variant=VARIANT, **options).stokes
                     for i in range(PASSES)]).astype(np.float64)


def pooled_stderr(passes, mean):
    """Standard error of the PASSES-pass mean of S0, relative to S0, pooled
    (root-mean-square) over the image: one figure per band."""
    stderr = passes[:, :, :, 0].std(axis=0, ddof=1) / np.sqrt(len(passes))
    return np.sqrt(np.mean((stderr / mean[:, :, 0]) ** 2, axis=(0, 1)))


def test_cube_matches_the_reference_band_by_band():
    """Each band of a 4-band cube over 600-680 nm against the reference
    averaged over its band (5 midpoints: n, k are piecewise linear and the
    BRDF smooth in them; against 21 midpoints the rule differs by < 1e-4 of S0,
    measured, far inside the 2e-3 floor). Tolerance as in
    test_narrowband.py: 5 pooled standard errors of the Monte Carlo mean of
    that band plus 2e-3 of S0 (the reference's 8 x 8 footprint quadrature,
    float32). The bands differ from one another by far more than that (checked
    against the neighbouring bands' references), so the test sees which band
    is which. Each render is split into 2 passes, so the bands' wavelength
    counts run on across passes."""
    use_variant(VARIANT)
    passes = cube_passes(passes=2, bands=BANDS)
    mean = passes.mean(axis=0)
    assert np.all(np.isfinite(mean))
    pooled = pooled_stderr(passes, mean)
    edges = parse_bands(BANDS).edges
    expected = []
    for b, (low, high) in enumerate(edges):
        lams = list(low + (np.arange(5) + 0.5) * (high - low) / 5)
        ref = reference_image(lams)
        expected.append(ref)
        s0 = ref[..., :1]
        assert s0.min() > 0
        bound = (5 * pooled[b] + 2e-3) * s0
        error = np.abs(mean[..., b] - ref)
        worst = np.unravel_index(np.argmax(error / bound), error.shape)
        assert np.all(error <= bound), (edges[b], worst, mean[..., b][worst], ref[worst],
                                        bound[worst])
    # the test sees which band is which: each band, compared with its
    # neighbour's reference, would fail
    for b in range(len(edges)):
        for other in (b - 1, b + 1):
            if 0 <= other < len(edges):
                bound = (5 * pooled[b] + 2e-3) * expected[other][..., :1]
                assert (np.abs(mean[..., b] - expected[other]) / bound).max() > 1, (b, other)


def test_cube_bands_equal_narrow_band_renders():
    """Band b of the cube against ``wavelength="c:20"`` renders of the same
    scene (two independent estimates of the same band average): their
    difference within 5 combined standard errors (sqrt of the sum of both
    pooled variances) plus 1e-3 of S0 for float32 and the narrow band's
    tabulated 1/K response (< 1e-4, test_narrowband.py)."""
    use_variant(VARIANT)
    cube = cube_passes(bands="620:640,650:670")
    cube_mean = cube.mean(axis=0)
    cube_err = pooled_stderr(cube, cube_mean)
    for b, centre in enumerate((630, 660)):
        narrow = cube_passes(wavelength=f"{centre}:20")[..., 0:1]
        narrow_mean = narrow.mean(axis=0)
        narrow_err = pooled_stderr(narrow, narrow_mean)[0]
        s0 = narrow_mean[..., 0:1, 0]
        bound = (5 * np.hypot(cube_err[b], narrow_err) + 1e-3) * s0
        error = np.abs(cube_mean[..., b] - narrow_mean[..., 0])
        assert np.all(error <= bound), (centre, float((error / bound).max()))


def test_cli_render_bands_writes_the_cube_layout(tmp_path, capsys):
    stem = tmp_path / "plane"
    argv = ["render", SCENE, "--bands", "450:470,532:533,600:650", "--spp", "4", "--out",
            str(stem), "--variant", VARIANT, "--no-progress", "-D", "width=16", "-D", "height=12"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "Stokes bands 460nm,532.5nm,625nm" in out
    channels = read_exr_channels(f"{stem}.exr")
    assert sorted(channels) == sorted(f"S{i}.{b}" for i in range(4)
                                      for b in ("460nm", "532.5nm", "625nm"))
    image = read_stokes_exr(f"{stem}.exr")
    assert image.bands == ["460nm", "532.5nm", "625nm"]
    assert image.metadata["band_edges_nm"] == "450-470,532-533,600-650"
    assert image.stokes.shape == (12, 16, 4, 3) and np.all(np.isfinite(image.stokes))
    assert np.all(image.stokes[:, :, 0] > 0)
    assert os.path.exists(f"{stem}.png")


def sphere_runs(scene, **options):
    return np.stack([render_scene(scene, spp=256, seed=1 + 7 * i, params=dict(width=24, height=18),
                                  passes=1, variant=VARIANT, **options).stokes[..., 0, :1]
                     for i in range(PASSES)]).astype(np.float64)[..., 0]


def rms_ratio(a, b):
    """RMS over the image of the difference of two PASSES-run means of S0,
    over the RMS of its standard error: about 1 for two estimates of the same
    image."""
    diff = a.mean(axis=0) - b.mean(axis=0)
    var = (a.var(axis=0, ddof=1) + b.var(axis=0, ddof=1)) / len(a)
    return float(np.sqrt(np.mean(diff ** 2) / np.mean(var)))


@pytest.mark.slow
def test_cube_splats_with_the_film_s_filter(tmp_path):
    """gallery/sphere.xml has Mitsuba's default Gaussian pixel filter and sharp
    edges (sphere, checkerboard). Its cube band 620-640 nm and a --wavelength
    630:20 render are two estimates of the same image: the RMS of their
    difference is about its standard error (the 1.5 bound leaves room for the
    error of 4-run variance estimates pooled over 432 pixels); the same render
    of a copy of the scene with a box filter would fail that bound (the test
    sees the filter; 256 spp so that the filters' difference stands well above
    the noise)."""
    import shutil

    use_variant(VARIANT)
    gallery = os.path.join(os.path.dirname(SCENE), "gallery")
    for name in ("sphere.xml", "_stage.xml", "studio.exr"):
        shutil.copy(os.path.join(gallery, name), tmp_path / name)
    text = (tmp_path / "sphere.xml").read_text()
    (tmp_path / "box.xml").write_text(text.replace('<film type="hdrfilm">',
                                                   '<film type="hdrfilm"><rfilter type="box"/>', 1))
    cube = sphere_runs(str(tmp_path / "sphere.xml"), bands="620:640")
    narrow = sphere_runs(str(tmp_path / "sphere.xml"), wavelength="630:20")
    box = sphere_runs(str(tmp_path / "box.xml"), wavelength="630:20")
    same, other = rms_ratio(cube, narrow), rms_ratio(cube, box)
    assert same < 1.5 and other > 1.5, (same, other)
