"""Narrow-band Stokes renders (``pbrdf render --wavelength NM[:WIDTH]``,
mitsuba_pbrdf.rendering.narrowband) against the float64 reference evaluator on
scenes/analytic_plane.xml, with a complex index that changes with wavelength
(so that a render at the wrong wavelength, or with the wrong normalization,
fails)."""

import os

import mitsuba as mi
import numpy as np
import pytest

from mitsuba_pbrdf import use_variant
from mitsuba_pbrdf.cli import main
from mitsuba_pbrdf.errors import ParameterError
from mitsuba_pbrdf.rendering import render_scene
from mitsuba_pbrdf.rendering.render import check_render
from mitsuba_pbrdf.stokes import read_stokes_exr
from mitsuba_pbrdf.stokes.exr import read_exr_channels
from mitsuba_pbrdf.rendering.narrowband import (parse_wavelength, passband_response,
                                                rgb_response)
from tests.rendering.test_render import LIGHT_DIR, SCENE, expected_stokes

pytestmark = pytest.mark.usefixtures("restore_variant")
VARIANT = "llvm_ad_spectral_polarized"
WIDTH, HEIGHT, SPP, PASSES = 32, 24, 64, 4
#: n and k (irregular spectra: wavelength nm, value) flat outside 600-670 nm and
#: steep inside, so that the wavelength matters
N_TABLE = ((360, 0.3), (600, 0.3), (670, 1.5), (830, 1.5))
K_TABLE = ((360, 3.0), (600, 3.0), (670, 6.0), (830, 6.0))
CASE = dict(sigma=0.15, kdd=0.2, sigma_dd=0.5, kid=0.05, shadowing="vgroove",
            dd_distribution="beckmann")


def index_at(lam):
    return tuple(float(np.interp(lam, *zip(*table))) for table in (N_TABLE, K_TABLE))


def params():
    spectrum = lambda table: ", ".join(f"{w}:{v}" for w, v in table)  # noqa: E731
    return dict(width=WIDTH, height=HEIGHT, eta=spectrum(N_TABLE), k=spectrum(K_TABLE),
                **{k: str(v) for k, v in CASE.items()})


def test_parse_wavelength():
    passband = parse_wavelength("632.8")
    assert (passband.centre, passband.width, passband.name) == (632.8, 0.0, "632.8nm")
    assert parse_wavelength(passband) is passband
    assert parse_wavelength("550:10").limits == (545.0, 555.0)
    for bad, text in [("red", "expects NM or NM:WIDTH"), ("550:-1", "width >= 0"),
                      ("nan", "finite"), ("300", "within 360-830 nm"),
                      ("825:20", "835 nm must lie within")]:
        with pytest.raises(ParameterError, match=text) as error:
            parse_wavelength(bad)
        # the library names its parameter; only the command line names the option
        assert error.value.parameter == "wavelength" and "--" not in str(error.value)


def test_check_render_refuses_a_band_in_a_non_spectral_variant_before_loading():
    """check_render makes the render's checks once, without setting a variant:
    a passband in an RGB variant is refused by parameter name; a good request
    carries the parsed passband in its render mode."""
    with pytest.raises(ParameterError, match="needs a spectral variant, not "
                                             "llvm_ad_rgb_polarized") as error:
        check_render(SCENE, variant="llvm_ad_rgb_polarized", wavelength="600")
    assert error.value.parameter == "wavelength"
    for name, value in (("spp", 0), ("passes", 0)):
        with pytest.raises(ParameterError, match="must be at least 1") as error:
            check_render(SCENE, variant=VARIANT, **{name: value})
        assert error.value.parameter == name
    request = check_render(SCENE, spp=2, variant=VARIANT, wavelength="550:10")
    assert request.mode.passband.limits == (545.0, 555.0) and request.spp == 2


def test_sampled_wavelengths_weigh_the_band_evenly():
    """Wavelengths drawn from the band's spectral response (Mitsuba's own
    ``regular`` spectrum sampling) times the stokes integrator's K_c(λ) times
    the band's scale average to 1: every wavelength of the band counts alike
    (10^4 stratified samples; the linear interpolation of 1/K_c between points
    0.5 nm apart leaves < 1e-4)."""
    use_variant(VARIANT)
    for text in ("632.8", "632.8:20", "450:30"):
        r = passband_response(parse_wavelength(text))
        srf = mi.load_dict({"type": "regular", "wavelength_min": float(r.wavelengths[0]),
                            "wavelength_max": float(r.wavelengths[-1]),
                            "values": ", ".join(f"{v:.9g}" for v in r.values)})
        u = mi.Float((np.arange(10000) + 0.5) / 10000)
        lam, _ = srf.sample_spectrum(mi.SurfaceInteraction3f(),
                                     mi.UnpolarizedSpectrum(u, u, u, u))
        lam = np.array(lam)[0]
        low, high = r.passband.limits
        assert low - 1e-3 <= lam.min() and lam.max() <= high + 1e-3
        weight = rgb_response(lam)[r.channel] * r.scale
        assert weight.mean() == pytest.approx(1.0, abs=1e-4), text
        # and the weighted average of λ is the centre (1e-3 nm: the 1e-4 above times
        # the offsets, at most 15 nm)
        assert np.mean(weight * (lam - r.passband.centre)) == pytest.approx(0, abs=1e-3), text


def reference_image(lams):
    """E(λ) cos θi × the footprint-averaged reference Mueller column in the
    camera frame, averaged over *lams* (nm), shape (H, W, 4); E(λ) as the
    scene's emitter gives it."""
    import drjit as dr

    scene = mi.load_file(SCENE, **{k: str(v) for k, v in params().items()})
    it = dr.zeros(mi.Interaction3f)
    cos_i = -LIGHT_DIR[2] / np.linalg.norm(LIGHT_DIR)
    total = 0.0
    for lam in lams:
        it.wavelengths = mi.UnpolarizedSpectrum(lam)
        _, weight = scene.emitters()[0].sample_direction(it, mi.Point2f(0.5, 0.5), True)
        e = float(np.array(weight).ravel()[0])
        n, k = index_at(lam)
        total = total + e * cos_i / np.pi * expected_stokes(scene, dict(CASE, eta=n, k=k),
                                                             LIGHT_DIR)
    return total / len(lams)


@pytest.mark.parametrize("wavelength", ["632.8", "632.8:20"])
def test_narrow_band_render_matches_the_reference(wavelength):
    """Renders at 632.8 nm (a HeNe line) and over 622.8-642.8 nm against the
    reference at the same wavelengths (the band: its average over 21 points,
    midpoint rule; n, k are linear over the band and the BRDF smooth in them,
    so that rule is exact to < 1e-5). Tolerance as in test_render.py: 5 standard
    errors of the Monte Carlo mean (pixel-footprint noise, pooled over the
    image from independent passes) plus 2e-3 of S0 for the reference's 8 x 8
    footprint quadrature and float32. The render at 600 nm differs from the
    632.8 nm reference by far more than that (checked), so the test sees the
    wavelength."""
    use_variant(VARIANT)
    passband = parse_wavelength(wavelength)
    passes = np.stack([render_scene(SCENE, spp=SPP, seed=11 + i, params=params(), passes=1,
                                    variant=VARIANT, wavelength=wavelength).stokes[..., 0]
                       for i in range(PASSES)])
    mean = passes.mean(axis=0).astype(np.float64)
    low, high = passband.limits
    lams = [passband.centre] if passband.width == 0 else list(
        low + (np.arange(21) + 0.5) * (high - low) / 21)
    expected = reference_image(lams)
    s0 = expected[..., :1]
    assert s0.min() > 0 and np.all(np.isfinite(mean))
    stderr = passes[..., 0].std(axis=0, ddof=1) / np.sqrt(PASSES) / mean[..., 0]
    pooled = float(np.sqrt(np.mean(stderr ** 2)))
    bound = (5 * pooled + 2e-3) * s0
    error = np.abs(mean - expected)
    worst = np.unravel_index(np.argmax(error / bound), error.shape)
    assert np.all(error <= bound), (worst, mean[worst], expected[worst], bound[worst])
    if passband.width == 0:
        other = render_scene(SCENE, spp=SPP, seed=11, params=params(), passes=1,
                             variant=VARIANT, wavelength="600").stokes[..., 0]
        assert (np.abs(other - expected) / bound).max() > 3


def test_cli_render_wavelength_then_polcam(tmp_path, capsys):
    stem = tmp_path / "plane"
    argv = ["render", SCENE, "--wavelength", "632.8", "--spp", "4", "--out", str(stem),
            "--variant", VARIANT, "--no-progress"]
    for key, value in dict(width=16, height=12).items():
        argv += ["-D", f"{key}={value}"]
    assert main(argv) == 0
    assert "Stokes bands 632.8nm" in capsys.readouterr().out
    image = read_stokes_exr(f"{stem}.exr")
    assert image.bands == ["632.8nm"] and image.metadata["wavelength_nm"] == "632.8"
    assert main(["polcam", f"{stem}.exr", "--out", str(tmp_path / "cam")]) == 0
    i0 = read_exr_channels(tmp_path / "cam" / "plane_I0.exr")
    assert list(i0) == ["632.8nm"]
    mosaic = read_exr_channels(tmp_path / "cam" / "plane_mosaic.exr")["Y"]
    assert mosaic.shape == (12, 16) and np.all(np.isfinite(mosaic))


def test_a_sensor_with_a_response_of_its_own_is_refused_before_loading(tmp_path):
    """The passband is the sensor's spectral response: one the scene has
    already, in an included file too, is refused by check_render, naming
    the parameter."""
    (tmp_path / "cam.xml").write_text(
        '<scene version="3.0.0"><sensor type="perspective"><spectrum name="srf" '
        'type="regular"><float name="wavelength_min" value="500"/><float '
        'name="wavelength_max" value="600"/><string name="values" value="1, 1"/></spectrum>'
        '</sensor></scene>')
    (tmp_path / "s.xml").write_text('<scene version="3.0.0"><include filename="cam.xml"/>'
                                    '</scene>')
    with pytest.raises(ParameterError, match="has a spectral response") as error:
        check_render(tmp_path / "s.xml", variant=VARIANT, wavelength="600")
    assert error.value.parameter == "wavelength" and "cam.xml line 1" in str(error.value)
