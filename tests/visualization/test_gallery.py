"""The scene gallery (scenes/gallery, mitsuba_pbrdf.visualization.gallery): tiny renders of
every gallery scene, Malus's law on the polarizer renders, and the committed
README pictures."""

import os
import re

import matplotlib.image
import mitsuba as mi
import numpy as np
import pytest

from mitsuba_pbrdf.camera.polcam import ANGLES, stokes_from_intensities
from mitsuba_pbrdf.visualization import gallery
from mitsuba_pbrdf.visualization.gallery import _Settings, render_polarizer_images, run_gallery
from mitsuba_pbrdf.visualization.polarizer_figure import polarizer_check
from mitsuba_pbrdf.rendering import render_scene

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), os.pardir, os.pardir))
SCENES = os.path.join(ROOT, "scenes", "gallery")
TINY = dict(width=48, height=36)


# The code under test switches Mitsuba's variant (conftest.restore_variant).
pytestmark = pytest.mark.usefixtures("restore_variant")


def settings(tmp_path, spp=4, scale=0.2):
    from pathlib import Path

    return _Settings(scenes=Path(SCENES), out=tmp_path, exr_dir=None, spp=spp, scale=scale,
                     variant="llvm_ad_spectral_polarized", progress=False)


def test_polarization_camera_inverts_malus_law():
    rng = np.random.default_rng(0)
    s0 = rng.uniform(1, 2, (3, 4, 2))
    p, a = rng.uniform(0, 1, s0.shape), rng.uniform(-np.pi / 2, np.pi / 2, s0.shape)
    s1, s2 = s0 * p * np.cos(2 * a), s0 * p * np.sin(2 * a)
    intensities = {t: 0.5 * (s0 + s1 * np.cos(2 * np.radians(t)) + s2 * np.sin(2 * np.radians(t)))
                   for t in ANGLES}
    stokes = stokes_from_intensities(intensities, axis=-2)
    np.testing.assert_allclose(stokes[..., :3, :], np.stack([s0, s1, s2], axis=-2), atol=1e-12)
    assert np.all(stokes[..., 3, :] == 0)


def test_polarizer_renders_follow_malus_law(tmp_path):
    """Renders through the polarizer at 0/45/90/135 degrees and through clear
    glass (same seed, same paths: see polarizer.xml). No Monte Carlo noise
    enters, so the tolerance is about geometry, not noise: exact on the
    optical axis; off axis, rays cross the filter obliquely and Mitsuba's
    tilted-polarizer model turns its effective axis a little (worst pixel
    ~0.3 % of max S0 in a 30 degree field of view; 1 % allowed)."""
    filtered, clear = render_polarizer_images(settings(tmp_path))
    check = polarizer_check(filtered, clear)
    for name, error in check.items():
        assert error < 1e-2, (name, check)
    i = {a: filtered[a].s0.astype(np.float64) for a in ANGLES}
    s = clear.stokes.astype(np.float64)
    scale = s[:, :, 0].max()
    # The angle-0 channel is aligned with the Stokes frame: exact everywhere
    np.testing.assert_allclose(i[0], 0.5 * (s[:, :, 0] + s[:, :, 1]), atol=1e-5 * scale)
    # On the optical axis (the centre pixels) every channel is exact
    c = (slice(16, 20), slice(22, 26))
    np.testing.assert_allclose((i[0] + i[90])[c], s[c][:, :, 0], atol=1e-5 * scale)
    np.testing.assert_allclose((i[45] - i[135])[c], s[c][:, :, 2], atol=1e-5 * scale)
    # The sign of the angle: S2 > 0 light passes the 45 degree filter best
    # (the Stokes frame's x-axis is the image's right, y its up).
    assert np.sum(np.abs(s[:, :, 2])) > 0.01 * np.sum(s[:, :, 0])  # the sphere has S2
    np.testing.assert_allclose(i[45] - i[135], s[:, :, 2], atol=1e-2 * scale)
    # Image means: the filters pass half the light
    for a in ANGLES:
        assert i[a].mean() == pytest.approx(0.5 * s[:, :, 0].mean(), rel=0.05)


def test_clear_glass_equals_no_filter_within_noise():
    """The clear filter (polarizing=false, transmittance=2) is the identity:
    the polarizer scene's S0 and S1 match sphere.xml's (the same stage without
    the filter). These use the sampler differently, so Monte Carlo noise
    enters: over seeds, the image-mean S0 of 48x36 at 8 spp differs by 1.5 %
    (standard deviation, envmap fireflies); 6 % allowed."""
    clear = render_scene(os.path.join(SCENES, "polarizer.xml"), spp=8,
                         params=dict(TINY, polarizing="false", transmittance=2))
    plain = render_scene(os.path.join(SCENES, "sphere.xml"), spp=8, params=TINY)
    lum = np.array([0.2126, 0.7152, 0.0722])
    s_clear, s_plain = clear.stokes @ lum, plain.stokes @ lum
    assert s_clear[..., 0].mean() == pytest.approx(s_plain[..., 0].mean(), rel=0.06)
    # S1 on the sphere: positive at its top and bottom rims, negative at its
    # sides, in both (coarse 3x3 blocks of the sphere's bounding box)
    box = (slice(3, 30), slice(10, 37))
    for s in (s_clear, s_plain):
        blocks = s[box][..., 1].reshape(3, 9, 3, 9).mean(axis=(1, 3))
        assert blocks[0, 1] > 0 and blocks[2, 1] > 0
        assert blocks[1, 0] < 0 and blocks[1, 2] < 0


@pytest.mark.parametrize("material", ["Al", "Au"])
def test_sphere_scene_renders_each_metal(material):
    image = render_scene(os.path.join(SCENES, "sphere.xml"), spp=2,
                         params=dict(TINY, material=material, sigma=0.3, kdd=0.2))
    assert image.stokes.shape == (36, 48, 4, 3)
    assert np.all(np.isfinite(image.stokes)) and image.s0.mean() > 0


def test_run_gallery_writes_small_pngs(tmp_path):
    paths = run_gallery(out=tmp_path / "gallery", exr_dir=tmp_path / "exr", spp=2, scale=0.2,
                        variant="llvm_ad_spectral_polarized", only=["roughness", "plot"],
                        log=lambda *a: None)
    for item in ("roughness", "plot"):
        assert os.path.getsize(paths[item]) < 200_000
        pixels = matplotlib.image.imread(paths[item])
        assert pixels.shape[1] > pixels.shape[0] > 100
    assert len(os.listdir(tmp_path / "exr")) == len(gallery.ROUGHNESS)
    with pytest.raises(ValueError, match="unknown gallery item"):
        run_gallery(out=tmp_path, only=["nope"])


def test_the_sky_item_sets_the_polarized_sky_beside_sunsky(tmp_path):
    """sky.png at a small size: for each sun elevation, where the sky is seen
    directly (the top rows), the same intensity under both skies (the same
    seed, the same camera rays) and a polarization only under polarized_sky,
    within its dolp_max (0.8)."""
    from mitsuba_pbrdf.stokes import dolp, luminance_stokes, read_stokes_exr

    paths = run_gallery(out=tmp_path / "gallery", exr_dir=tmp_path / "exr", spp=2, scale=0.15,
                        variant="llvm_ad_spectral_polarized", only=["sky"], log=lambda *a: None)
    assert os.path.getsize(paths["sky"]) < 200_000
    assert matplotlib.image.imread(paths["sky"]).shape[1] > 600
    for elevation in gallery.SUN_ELEVATIONS:
        polarized, plain = (read_stokes_exr(tmp_path / "exr" / f"sky_{sky}_{elevation:g}.exr")
                            for sky in ("polarized_sky", "sunsky"))
        assert polarized.stokes.shape == (27, 36, 4, 3)
        top = slice(0, 4)
        np.testing.assert_allclose(polarized.stokes[top, :, 0], plain.stokes[top, :, 0],
                                   rtol=1e-6)
        degree = dolp(luminance_stokes(polarized), axis=-1)[top]
        assert 0.2 < degree.min() and degree.max() <= 0.8 + 1e-5
        assert np.all(plain.stokes[top, :, 1:] == 0)


def test_find_scenes(tmp_path, monkeypatch):
    assert gallery.find_scenes(SCENES).samefile(SCENES)
    monkeypatch.chdir(tmp_path)
    assert gallery.find_scenes().samefile(SCENES)  # the repository this package is in
    with pytest.raises(FileNotFoundError, match="--scenes"):
        gallery.find_scenes(tmp_path)


def test_studio_envmap_is_what_the_scene_uses():
    """scenes/gallery/studio.exr is write_studio_envmap's output (half float)."""
    import OpenEXR

    with OpenEXR.File(os.path.join(SCENES, "studio.exr"), separate_channels=True) as f:
        channels = f.channels()
        stored = np.stack([channels[c].pixels.astype(np.float32) for c in "RGB"], axis=-1)
    np.testing.assert_allclose(stored, gallery.studio_envmap(), rtol=1e-3, atol=1e-4)


def test_readme_pictures_are_committed_and_small():
    with open(os.path.join(ROOT, "README.md")) as f:
        readme = f.read()
    pictures = re.findall(r"\]\((gallery/[\w.-]+\.png)\)", readme)
    assert {"gallery/materials.png", "gallery/roughness.png", "gallery/polarizer.png",
            "gallery/stokes_sheet.png", "gallery/pbrdf_plot.png"} <= set(pictures)
    for picture in pictures:
        path = os.path.join(ROOT, picture)
        assert os.path.isfile(path), picture
        assert os.path.getsize(path) < 200_000, picture
