"""Pictures of Stokes images (mitsuba_pbrdf.visualization.panels) and pBRDF plots
(mitsuba_pbrdf.visualization.pbrdf_plots): the figures are built, saved and opened again, and the
numbers behind them are checked against the reference evaluator."""

import math

import matplotlib.image
import numpy as np
import pytest
from PIL import Image

from mitsuba_pbrdf import reference
from mitsuba_pbrdf.visualization.pbrdf_plots import (
                                               PBRDFParams,
                                               dop_unpolarized,
                                               hemisphere,
                                               in_plane,
                                               pbrdf_figure,
                                               save_pbrdf_plot,
                                               )
from mitsuba_pbrdf.stokes.image import StokesImage
from matplotlib.figure import Figure

from mitsuba_pbrdf.visualization.colours import nice_ceiling
from mitsuba_pbrdf.visualization.panels import (
                                           PANEL_PRESETS,
                                           draw_aolp,
                                           draw_docp,
                                           draw_dolp,
                                           overview_figure,
                                           parse_panels,
                                           polarization_hsv,
                                           save_overview_png,
                                           save_png,
                                           tonemap,
                                           )


def synthetic_image(h=24, w=32):
    """A Stokes image whose AoLP turns with x and whose DoLP grows with y
    (to 0.99, with a DoCP of up to 0.1: physical, DoP <= 0.995)."""
    y, x = np.mgrid[0:h, 0:w]
    angle = np.pi * (x / w - 0.5)                     # AoLP from -90 to 90 degrees
    p = y / (h - 1)                                   # DoLP from 0 to 0.99
    s0 = 1.0 + 0.5 * np.sin(x / 5.0)
    stokes = np.stack([s0, 0.99 * s0 * p * np.cos(2 * angle), 0.99 * s0 * p * np.sin(2 * angle),
                       0.1 * s0 * p], axis=-1)[..., None].repeat(3, axis=-1)
    return StokesImage(stokes.astype(np.float32), ["R", "G", "B"], metadata={"title": "synthetic"})


# ---------------------------------------------------------------- Stokes pictures


def test_parse_panels_presets_and_errors():
    assert parse_panels("intensity, DoLP") == ("intensity", "dolp")
    assert parse_panels("all") == PANEL_PRESETS["all"]
    assert len(PANEL_PRESETS["all"]) == 8
    with pytest.raises(ValueError, match="unknown panel.*bogus.*choose from"):
        parse_panels("intensity,bogus")
    with pytest.raises(ValueError, match="none"):
        parse_panels(" , ")


def test_full_sheet_has_every_panel_with_colour_bars(tmp_path):
    image = synthetic_image()
    fig = overview_figure(image, "all", title="t")
    panels = [ax for ax in fig.axes if ax.get_title()]
    titles = " | ".join(ax.get_title() for ax in panels)
    for word in ("Intensity", "Degree of linear", "Angle of linear", "circular", "S1/S0",
                 "S2/S0", "S3/S0", "AoLP (hue)"):
        assert word in titles
    colour_bars = [ax for ax in fig.axes if ax.get_label() == "<colorbar>"]
    assert len(colour_bars) == 7  # every panel but the intensity
    path = save_overview_png(tmp_path / "sheet.png", image, panels="all")
    pixels = matplotlib.image.imread(path)
    assert pixels.shape[1] > pixels.shape[0] > 200  # two rows of four


def test_python_pictures_take_the_command_lines_defaults(tmp_path):
    """save_overview_png without options draws what pbrdf view draws: one
    defaults table (DoLP scaled to the data, not 0-1), read by both."""
    from mitsuba_pbrdf.cli import build_parser
    from mitsuba_pbrdf.visualization.defaults import PICTURE_DEFAULTS

    parser = build_parser()
    view = parser.parse_args(["view", "x.exr"])
    render = parser.parse_args(["render", "x.xml"])
    for keyword in ("dolp_limit", "dolp_cmap", "min_dolp", "stokes_scale", "exposure"):
        assert getattr(view, keyword) == getattr(render, keyword) == PICTURE_DEFAULTS[keyword]
    image = synthetic_image()
    image.stokes[..., 1:3, :] *= 0.2  # DoLP at most 0.2: "auto" and 1.0 differ
    fig = overview_figure(image, "all")
    labels = [ax.get_ylabel() for ax in fig.axes if ax.get_label() == "<colorbar>"]
    dolp_label = next(label for label in labels if label.startswith("DoLP"))
    assert dolp_label.endswith(", auto)") and "0–1)" not in dolp_label
    assert PICTURE_DEFAULTS["dolp_limit"] == "auto"


def axes():
    from matplotlib.figure import Figure

    return Figure().subplots()


def test_dolp_greyscale_and_band_options(tmp_path):
    image = synthetic_image()
    fig = overview_figure(image, ["dolp", "aolp"], dolp_cmap="gray", band="G", dolp_limit=0.5)
    dolp_ax, aolp_ax = [ax for ax in fig.axes if ax.get_title()]
    assert "[G]" in dolp_ax.get_title()
    bars = [ax for ax in fig.axes if ax.get_label() == "<colorbar>"]
    assert "DoLP (0–0.5)" in bars[0].get_ylabel()
    drawing = draw_dolp(axes(), image, dolp_cmap="gray", dolp_limit=0.5, band="G")
    assert drawing.mappable.get_cmap().name == "gray"
    assert drawing.mappable.get_clim() == (0.0, 0.5)
    assert drawing.extend == "max"  # DoLP reaches 1: the bar says values are clipped
    # AoLP is grey (no value) where DoLP < min_dolp: the first row has DoLP 0
    angle = draw_aolp(axes(), image, band="G").values
    assert np.isnan(angle[0]).all() and np.isfinite(angle[-1]).all()
    with pytest.raises(KeyError, match="no band 'X'"):
        overview_figure(image, ["dolp"], band="X")


def test_automatic_scales_follow_the_data():
    """DoLP and DoCP tops are the 99.5th percentile rounded up to 1, 2, 2.5 or
    5 x 10^k; S1, S2, S3 / S0 share one symmetric scale in the sheet."""
    image = synthetic_image()
    image.stokes[..., 1:, :] *= 0.3          # DoLP up to 0.3, DoCP up to 0.03
    assert draw_dolp(axes(), image).mappable.get_clim() == (0.0, 1.0)  # Python's default
    d = draw_dolp(axes(), image, dolp_limit="auto")
    assert d.mappable.get_clim() == (0.0, 0.5) and "auto" in d.label
    c = draw_docp(axes(), image)
    assert c.mappable.get_clim() == (0.0, 0.05)
    fig = overview_figure(image, ["s1", "s2", "s3"])
    bars = [ax for ax in fig.axes if ax.get_label() == "<colorbar>"]
    assert [b.get_ylim() for b in bars] == [(-0.5, 0.5)] * 3
    assert all("shared scale" in b.get_ylabel() for b in bars)
    fig = overview_figure(image, ["s1", "s3"], stokes_scale="separate")
    bars = [ax for ax in fig.axes if ax.get_label() == "<colorbar>"]
    assert bars[0].get_ylim() == (-0.5, 0.5) and bars[1].get_ylim() == (-0.05, 0.05)
    assert nice_ceiling(0.031) == 0.05 and nice_ceiling(0.2) == 0.2 and nice_ceiling(1.7) == 2.0


def test_aolp_panel_values_follow_the_stokes_angle():
    image = synthetic_image()
    angle = draw_aolp(axes(), image).values
    w = image.width
    expected = np.degrees(np.pi * (np.arange(w) / w - 0.5))
    expected = (expected + 90.0) % 180.0 - 90.0  # -90 and 90 are the same angle
    got = (np.asarray(angle[-1]) + 90.0) % 180.0 - 90.0
    np.testing.assert_allclose(got, expected, atol=1e-3)


def test_aolp_colours_are_polanalysers_hue_wheel():
    """The AoLP panel's colours are those of polanalyser's applyColorToAoLP
    (hue = AoLP / 180 deg, full saturation and value) up to its 8-bit
    rounding, no angle is dark, and grey marks DoLP below the threshold."""
    from mitsuba_pbrdf.visualization.colours import MASKED_GREY, aolp_rgb

    angles = np.linspace(-90.0, 90.0, 181)
    rgb = aolp_rgb(angles)
    assert rgb.max(axis=-1).min() > 0.99  # every angle at full value: none is dark
    np.testing.assert_allclose(rgb[0], rgb[-1], atol=1e-9)  # -90 and +90 meet
    polanalyser = pytest.importorskip("polanalyser")
    from matplotlib.colors import rgb_to_hsv

    bgr = polanalyser.applyColorToAoLP(np.radians(angles % 180.0)[None, :])[0]
    theirs = rgb_to_hsv(bgr[:, ::-1] / 255.0)
    ours = rgb_to_hsv(rgb)
    # OpenCV stores hue in 2-degree steps, truncated, and scales AoLP by 179/180:
    # at most 2 + 2 degrees of hue apart
    gap = np.abs((ours[:, 0] - theirs[:, 0] + 0.5) % 1.0 - 0.5) * 360.0
    assert gap.max() <= 4.0 + 1e-6
    np.testing.assert_allclose(theirs[:, 1:], 1.0, atol=1 / 255)  # full saturation and value
    image = synthetic_image()
    fig = Figure()
    ax = fig.subplots()
    draw_aolp(ax, image, min_dolp=0.5)
    drawn = ax.images[0].get_array()
    np.testing.assert_allclose(drawn[0, 0], MASKED_GREY)  # first row: DoLP 0


def test_polarization_hsv_colours():
    stokes = np.zeros((1, 4, 4, 1), np.float32)
    stokes[0, :, 0, 0] = 1.0
    stokes[0, 0, 1, 0] = 1.0        # horizontal, DoLP 1: hue 0, red
    stokes[0, 1, 1, 0] = -1.0       # vertical, DoLP 1: hue 0.5, cyan
    stokes[0, 2, 2, 0] = 1.0        # +45: hue 0.25, yellow-green
    image = StokesImage(stokes, ["Y"])  # pixel 3: unpolarized, grey
    rgb = polarization_hsv(image, exposure=1.0)
    assert rgb.shape == (1, 4, 3)
    r, g, b = rgb[0, 0]
    assert r > 0.9 and g < 0.05 and b < 0.05
    r, g, b = rgb[0, 1]
    assert r < 0.05 and g > 0.9 and b > 0.9
    r, g, b = rgb[0, 2]
    assert r > 0.4 and g > 0.9 and b < 0.05
    np.testing.assert_allclose(rgb[0, 3], rgb[0, 3, 0], atol=1e-6)  # grey


def test_tonemap_exposure():
    rgb = np.full((2, 2, 3), 0.25, np.float32)
    srgb, exposure = tonemap(rgb)
    assert exposure == pytest.approx(4.0) and np.allclose(srgb, 1.0)
    srgb, exposure = tonemap(rgb, exposure=1.0)
    assert exposure == 1.0 and np.allclose(srgb, 1.055 * 0.25 ** (1 / 2.4) - 0.055, atol=1e-6)
    _, exposure = tonemap(np.zeros((2, 2, 3)))
    assert exposure == 1.0


def test_save_png_quantized_is_a_palette_png(tmp_path):
    fig = overview_figure(synthetic_image(), "all")
    full = save_png(fig, tmp_path / "full.png", dpi=80)
    small = save_png(fig, tmp_path / "sub" / "small.png", dpi=80, colors=256)
    with Image.open(small) as picture, Image.open(full) as unquantized:
        assert picture.mode == "P" and len(picture.getcolors(256)) <= 256
        assert picture.size == unquantized.size
        difference = (np.asarray(picture.convert("RGB"), float)
                      - np.asarray(unquantized.convert("RGB"), float))
    h, w = (n // 8 * 8 for n in difference.shape[:2])
    blocks = difference[:h, :w].reshape(h // 8, 8, w // 8, 8, 3).mean(axis=(1, 3))
    assert np.abs(blocks).mean() < 6.0  # 2 % of full scale on average: not posterized


# ---------------------------------------------------------------- pBRDF plots


def test_params_validation_names_the_parameter():
    with pytest.raises(ValueError, match="unknown material 'Unobtainium'.*Cu"):
        PBRDFParams(material="Unobtainium").validate()
    with pytest.raises(ValueError, match="sigma must be > 0"):
        PBRDFParams(sigma=0.0).validate()
    with pytest.raises(ValueError, match="kdd must be >= 0"):
        PBRDFParams(kdd=-0.1).validate()
    with pytest.raises(ValueError, match="sigma_dd"):
        PBRDFParams(sigma_dd=float("nan")).validate()
    with pytest.raises(ValueError, match="both eta and k"):
        PBRDFParams(eta=1.5).validate()
    with pytest.raises(ValueError, match="shadowing"):
        PBRDFParams(shadowing="smooth").validate()
    with pytest.raises(ValueError, match="theta_i"):
        in_plane(PBRDFParams(), 90.0)
    p = PBRDFParams(material="Cu", eta=1.2, k=7.0).validate()
    assert p.material is None and "n=1.2" in p.label()


def test_in_plane_mirror_direction_is_fresnel():
    """Specular only, at the mirror direction (h = n, beta = theta_i): M is the
    facet's Fresnel Mueller matrix times D G / (4 cos^2), so the normalized
    elements and the DoP are Fresnel's, and S1 > 0 (s-polarized)."""
    params = PBRDFParams(material="Au", sigma=0.05)
    theta_i = 60.0
    data = in_plane(params, theta_i, wavelengths=[550.0], n_angles=720)
    k = np.argmin(np.abs(data.angles - theta_i))
    theta_r = data.angles[k]
    n, kk = reference.conductor_ior("Au", 550.0)
    # In the plane of incidence the s/p frames need no rotation: M = D G F(beta)
    # / (4 cos_i cos_r) exactly, from the reference's pieces, not its assembly.
    ti, tr = math.radians(theta_i), math.radians(theta_r)
    alpha, cos_h, cos_b = math.sqrt(2) * 0.05, math.cos((tr - ti) / 2), math.cos((ti + tr) / 2)
    G = reference.shadowing_G(ti, tr, cos_h, cos_b, alpha, "vgroove")
    M = reference.beckmann_D(cos_h, alpha) * G / (4 * math.cos(ti) * math.cos(tr)) \
        * reference.fresnel_mueller(cos_b, n, kk)
    np.testing.assert_allclose(data.M[k, 0], M, rtol=1e-9, atol=1e-12 * M[0, 0])
    F = reference.fresnel_mueller(math.cos(math.radians((theta_i + theta_r) / 2)), n, kk)
    np.testing.assert_allclose(M / M[0, 0], F / F[0, 0], atol=2e-3)
    dop = dop_unpolarized(data.M)[k, 0]
    assert dop == pytest.approx(F[1, 0] / F[0, 0], abs=2e-3)
    assert data.M[k, 0, 1, 0] > 0


def test_in_plane_lobes_add_up():
    params = PBRDFParams(material="Cu", sigma=0.1, kdd=0.2, kid=0.05)
    data = in_plane(params, 30.0, wavelengths=[450.0, 650.0], n_angles=200)
    assert data.M.shape == (200, 2, 4, 4)
    assert set(data.lobes) == {"specular", "directional_diffuse", "ideal_diffuse"}
    total = sum(data.lobes.values())
    np.testing.assert_allclose(total, data.M[..., 0, 0], rtol=1e-12)
    np.testing.assert_allclose(data.lobes["ideal_diffuse"], 0.05 / np.pi, rtol=1e-12)
    assert 0.0 not in data.angles  # the global frame's switch at the normal is left out


def test_hemisphere_orientation_mirror_on_the_right():
    """The plots put the light on the left and the mirror direction on the
    right, like the in-plane curves (positive angles on the specular side)."""
    X, Y, M = hemisphere(PBRDFParams(material="Al", sigma=0.1), 40.0, resolution=80)
    m00 = np.nan_to_num(M[..., 0, 0], nan=-1.0)
    iy, ix = np.unravel_index(np.argmax(m00), m00.shape)
    assert X[iy, ix] == pytest.approx(math.sin(math.radians(40.0)), abs=0.05)
    assert abs(Y[iy, ix]) < 0.05
    assert np.isnan(M[0, 0, 0, 0])  # outside the disk


def test_pbrdf_figure_has_six_panels_and_saves(tmp_path):
    params = PBRDFParams(material="Cu", sigma=0.1, kdd=0.2, kid=0.05)
    fig = pbrdf_figure(params, 40.0, resolution=60)
    titles = [ax.get_title() for ax in fig.axes if ax.get_title()]
    assert len(titles) == 6
    assert "reference evaluator" in fig.get_suptitle()
    path = save_pbrdf_plot(tmp_path / "p.png", params, 40.0, colors=256)
    pixels = matplotlib.image.imread(path)
    assert pixels.shape[1] > pixels.shape[0] > 500
    assert (tmp_path / "p.png").stat().st_size < 200_000
