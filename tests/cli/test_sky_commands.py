"""A ``polarized_sky`` scene (``scenes/gallery/sky.xml``) through every
command that renders or reads Stokes images: a Stokes cube (``pbrdf render
--bands``), a narrow band (``--wavelength``), ``pbrdf polcam`` on the EXR,
and a ``pbrdf batch`` sweep over the sun's position. Each checks a physical
property of the sky where it is seen directly (the top rows, above the tube
and the horizon at every size used here):

* its DoLP is positive and at most ``dolp_max`` (0.8), in every band: the
  Rayleigh pattern does not depend on the wavelength, so every band of a
  cube, the narrow band and the RGB render see the same DoLP, to
  ``SAME = 1e-3`` (a pixel averages its samples' vectors weighted by their
  band's S0, which differs by band; measured: 4.6e-4 for 50 nm bands, 1.7e-4
  for 550 nm, at 4 spp);
* the polarization camera's four images give back that DoLP and AoLP;
* the sky's AoLP follows the sun's azimuth: each job of the sweep against
  the single-scattering formula at the pixel centres (``proof/polarized_light.py``),
  within ``AOLP_DEG = 1`` degree (a pixel averages rays over its area, where
  the AoLP turns; measured: 0.19 and 0.23 degrees at 32 x 24).
"""

import csv
from pathlib import Path

import numpy as np
import pytest

from mitsuba_pbrdf.cli import main
from mitsuba_pbrdf.stokes import aolp, dolp, luminance_stokes, read_stokes_exr
from proof import polarized_light as pl

SKY = Path(__file__).resolve().parents[2] / "scenes" / "gallery" / "sky.xml"
SIZE = dict(width=32, height=24, spp=4)
TOP = slice(0, 4)            # rows of sky only
DOLP_MAX = 0.8
SAME = 1e-3
AOLP_DEG = 1.0


def render(tmp_path, name, *options, **params):
    argv = ["render", str(SKY), "--out", str(tmp_path / name), "--no-progress", *options]
    for key, value in dict(SIZE, **params).items():
        argv += ["-D", f"{key}={value}"]
    assert main(argv) == 0
    return read_stokes_exr(tmp_path / f"{name}.exr")


def band_dolp(image):
    """(H, W, bands) DoLP of each band."""
    s = image.stokes.astype(np.float64)
    return np.hypot(s[:, :, 1], s[:, :, 2]) / s[:, :, 0]


def check_sky(degree):
    assert 0.2 < degree.min() and degree.max() <= DOLP_MAX + 1e-5, (degree.min(), degree.max())


def test_a_stokes_cube_and_a_narrow_band_of_the_sky_see_the_same_dolp(tmp_path):
    rgb = render(tmp_path, "rgb")
    reference = dolp(luminance_stokes(rgb), axis=-1)[TOP]
    check_sky(reference)
    cube = render(tmp_path, "cube", "--bands", "450:650:50")
    assert cube.bands == ["475nm", "525nm", "575nm", "625nm"]
    for k in range(len(cube.bands)):
        degree = band_dolp(cube)[TOP][..., k]
        check_sky(degree)
        assert np.abs(degree - reference).max() < SAME
    narrow = render(tmp_path, "narrow", "--wavelength", "550")
    assert narrow.bands == ["550nm"]
    degree = band_dolp(narrow)[TOP][..., 0]
    check_sky(degree)
    assert np.abs(degree - reference).max() < SAME


def test_polcam_of_the_sky_gives_back_its_dolp_and_aolp(tmp_path):
    from mitsuba_pbrdf.stokes.exr import read_exr_channels
    from mitsuba_pbrdf.camera.polcam import stokes_from_intensities

    image = render(tmp_path, "sky", "--wavelength", "550")
    assert main(["polcam", str(tmp_path / "sky.exr"), "--out", str(tmp_path / "cam")]) == 0
    intensities = {a: read_exr_channels(tmp_path / "cam" / f"sky_I{a}.exr")["550nm"][..., None]
                   for a in (0, 45, 90, 135)}
    camera = stokes_from_intensities(intensities, axis=-2)[..., 0]
    stokes = image.stokes[..., 0].astype(np.float64)
    assert np.abs(dolp(camera, axis=-1) - dolp(stokes, axis=-1))[TOP].max() < 1e-5
    turn = np.degrees(aolp(camera, axis=-1) - aolp(stokes, axis=-1))[TOP]
    assert np.abs((turn + 90) % 180 - 90).max() < 1e-3
    check_sky(dolp(camera, axis=-1)[TOP])
    mosaic = read_exr_channels(tmp_path / "cam" / "sky_mosaic.exr")["Y"]
    assert mosaic.shape == (24, 32) and np.all(np.isfinite(mosaic))


def test_a_batch_sweep_over_the_suns_azimuth_turns_the_skys_aolp(tmp_path):
    """Two jobs, the sun 35 degrees high at azimuths -30 and -150 degrees:
    the sky's AoLP per pixel on the Rayleigh formula in each, and different
    between them."""
    pytest.importorskip("distributed")
    import mitsuba as mi

    suns = [pl.sun_vector(35.0, a) for a in (-30.0, -150.0)]
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(f'scene = "{SKY}"\nspp = 4\nout = "out"\n[params]\n'
                     f"sun_x = [{suns[0][0]:.6f}, {suns[1][0]:.6f}]\n"
                     f"sun_y = {suns[0][1]:.6f}\nsun_z = {suns[0][2]:.6f}\n"
                     "width = 32\nheight = 24\n")
    assert main(["batch", str(sweep), "--workers", "1", "--no-progress"]) == 0
    loaded = mi.load_file(str(SKY), **{k: str(v) for k, v in SIZE.items()})
    _, d = pl.pixel_rays(loaded)
    x, y = pl.camera_basis(d, pl.camera_up(loaded))
    with open(tmp_path / "out" / "manifest.csv", newline="") as f:
        files = {float(row["sun_x"]): row["file"] for row in csv.DictReader(f)
                 if row["status"] == "done"}
    measured = []
    for sun in suns:
        stokes = luminance_stokes(read_stokes_exr(tmp_path / "out" / files[round(sun[0], 6)]))
        stokes = stokes.astype(np.float64)
        check_sky(dolp(stokes, axis=-1)[TOP])
        degree, e = pl.rayleigh(d, pl.unit(sun), DOLP_MAX)
        q, u = pl.linear_stokes(degree, e, x, y)
        expected = np.degrees(0.5 * np.arctan2(u, q))[TOP]
        angle = np.degrees(aolp(stokes, axis=-1))[TOP]
        assert np.abs((angle - expected + 90) % 180 - 90).max() < AOLP_DEG
        measured.append(angle)
    assert np.abs((measured[0] - measured[1] + 90) % 180 - 90).mean() > 10
