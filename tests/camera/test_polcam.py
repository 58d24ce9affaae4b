"""Polarization-camera images (mitsuba_pbrdf.camera.polcam, ``pbrdf polcam``):
the frame convention against renders through Mitsuba's ``polarizer``, the
mosaics against polanalyser's demosaicing (an independent reading of the
IMX250MZR / IMX250MYR layouts), and the sensor model's statistics."""

import os

import numpy as np
import polanalyser as pa
import pytest
from PIL import Image

from mitsuba_pbrdf.cli import main
from mitsuba_pbrdf.stokes.exr import read_exr_channels, write_stokes_exr
from mitsuba_pbrdf.camera.polcam import (ANGLES, SensorModel, colour_layout, colour_mosaic,
                                         malus, mono_layout, mono_mosaic, polarizer_images)
from mitsuba_pbrdf.stokes.image import StokesImage, aolp, dolp

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), os.pardir, os.pardir))
SCENES = os.path.join(ROOT, "scenes", "gallery")
RADIANS = np.radians(ANGLES)
#: polanalyser's float input is scaled so that the maximum is 65535 and truncated
#: to uint16 (error < 1 count), and OpenCV's bilinear output is rounded to uint16
#: (0.5 count): each demosaiced intensity is within 1.5 counts.
COUNTS = 1.5


def random_stokes(h, w, bands=("R", "G", "B"), seed=0, smooth=False):
    """Physical Stokes vectors: S0 in [1, 2], DoLP in [0, 1), any AoLP; with
    *smooth*, S0, S1 and S2 are linear in the pixel position (which bilinear
    demosaicing reproduces exactly)."""
    rng = np.random.default_rng(seed)
    n = len(bands)
    if smooth:
        y, x = np.mgrid[0:h, 0:w] / max(h, w)
        c = rng.uniform(-0.3, 0.3, (3, 3, n))  # per component: offset, d/dy, d/dx
        s = [c[i, 0] + c[i, 1] * y[..., None] + c[i, 2] * x[..., None] for i in range(3)]
        s0 = 2.0 + s[0]
        s1, s2 = 0.4 * s[1] / 0.6, 0.4 * s[2] / 0.6
    else:
        s0 = rng.uniform(1, 2, (h, w, n))
        p, a = rng.uniform(0, 1, s0.shape), rng.uniform(-np.pi / 2, np.pi / 2, s0.shape)
        s1, s2 = s0 * p * np.cos(2 * a), s0 * p * np.sin(2 * a)
    stokes = np.stack([s0, s1, s2, np.zeros_like(s0)], axis=2)
    return StokesImage(stokes, list(bands))


def test_malus_images_invert_to_the_stokes_image():
    image = random_stokes(6, 8)
    i = polarizer_images(image)
    s = image.stokes
    np.testing.assert_allclose(i[0] + i[90], s[:, :, 0], rtol=1e-6)
    np.testing.assert_allclose(i[45] + i[135], s[:, :, 0], rtol=1e-6)
    np.testing.assert_allclose(i[0] - i[90], s[:, :, 1], atol=1e-6)
    np.testing.assert_allclose(i[45] - i[135], s[:, :, 2], atol=1e-6)
    # light polarized at AoLP = 30 degrees passes a 30 degree polarizer fully
    v = np.array([1.0, np.cos(np.radians(60)), np.sin(np.radians(60)), 0.0])
    assert malus(v, 30) == pytest.approx(1.0) and malus(v, 120) == pytest.approx(0.0, abs=1e-15)


def test_layouts():
    assert mono_layout(2, 2).tolist() == [[90, 45], [135, 0]]
    angles, colours = colour_layout(4, 4)
    assert angles.tolist() == [[90, 45, 90, 45], [135, 0, 135, 0]] * 2
    assert colours.tolist() == [[0, 0, 1, 1], [0, 0, 1, 1], [1, 1, 2, 2], [1, 1, 2, 2]]


def demosaic(raw, code):
    """polanalyser's demosaicing of a float frame (its own 16-bit quantization)
    and the Stokes vectors it computes, (H, W[, 3], 3), and the count size."""
    images = pa.demosaicing(raw.astype(np.float64), code)
    stokes = pa.calcLinearStokes(np.stack(images), RADIANS)
    return images, stokes, float(raw.max()) / 65535.0


@pytest.mark.parametrize("sensor", ["mono", "colour"])
def test_polanalyser_reads_our_mosaic_at_the_sampled_pixels(sensor):
    """At each pixel, the demosaiced image of that pixel's polarizer angle (and
    colour) is the value we put there, up to polanalyser's quantization
    (:data:`COUNTS`). OpenCV's bilinear Bayer filter recomputes a 1-pixel
    border (a 2-pixel one in the colour path's half-size Bayer images): left out."""
    image = random_stokes(24, 32, seed=1)
    if sensor == "mono":
        raw, b = mono_mosaic(image, band="G"), 2
        images, _, count = demosaic(raw, pa.COLOR_PolarMono)
        angles, colours = mono_layout(*raw.shape), np.zeros(raw.shape, int)
        planes = [im[..., None] for im in images]
    else:
        raw, b = colour_mosaic(image), 4
        images, _, count = demosaic(raw, pa.COLOR_PolarRGB)
        angles, colours = colour_layout(*raw.shape)
        planes = [im[..., ::-1] for im in images]  # OpenCV's BGR order
    inner = (slice(b, -b), slice(b, -b))
    for k, a in enumerate(ANGLES):
        for c in range(planes[k].shape[-1]):
            mask = np.zeros(raw.shape, bool)
            mask[inner] = True
            mask &= (angles == a) & (colours == c)
            assert mask.sum() > 10
            error = np.abs(planes[k][..., c][mask] - raw[mask]).max()
            assert error <= COUNTS * count, (a, c, error / count)


@pytest.mark.parametrize("sensor", ["mono", "colour"])
def test_polanalyser_stokes_dolp_aolp_round_trip(sensor):
    """On a Stokes image linear in the pixel position, bilinear demosaicing is
    exact in the interior, so polanalyser's S0, S1, S2 equal ours up to its
    quantization: S0 = (I0 + I45 + I90 + I135)/2 and S1 = I0 - I90 (pinv of
    the four polarizers) are within 3 counts. DoLP within 3 (1 + DoLP) counts
    / S0; AoLP (polanalyser's in [0, 180) degrees, ours in (-90, 90]: compared
    modulo 180) within 3 counts / (2 sqrt(S1² + S2²)) radians, where DoLP >
    0.05."""
    image = random_stokes(32, 48, seed=2, smooth=True)
    if sensor == "mono":
        ours = image.band("G")[..., None, :]  # (H, W, 1, 4)
        _, stokes, count = demosaic(mono_mosaic(image, band="G"), pa.COLOR_PolarMono)
        stokes, b = stokes[..., None, :], 2
    else:
        ours = np.moveaxis(image.stokes, 2, 3)  # (H, W, 3, 4), R, G, B
        _, stokes, count = demosaic(colour_mosaic(image), pa.COLOR_PolarRGB)
        stokes, b = stokes[..., ::-1, :], 4  # BGR -> RGB
    inner = (slice(b, -b), slice(b, -b))
    ours, theirs = ours[inner].astype(np.float64), stokes[inner]
    np.testing.assert_allclose(theirs[..., :3], ours[..., :3], rtol=0, atol=3 * COUNTS * count)
    s0 = ours[..., 0]
    p_ours = dolp(ours, axis=-1)
    p_theirs = pa.cvtStokesToDoLP(theirs)
    assert np.all(np.abs(p_theirs - p_ours) <= 3 * COUNTS * count * (1 + p_ours) / s0)
    a_ours = np.degrees(aolp(ours, axis=-1))
    a_theirs = np.degrees(pa.cvtStokesToAoLP(theirs))
    assert a_theirs.min() >= 0 and a_theirs.max() < 180 and a_ours.min() > -90
    diff = (a_theirs - a_ours + 90) % 180 - 90
    linear = np.hypot(ours[..., 1], ours[..., 2])
    ok = p_ours > 0.05
    assert ok.sum() > 0.5 * ok.size
    bound = np.degrees(3 * COUNTS * count / (2 * linear))
    assert np.all(np.abs(diff[ok]) <= bound[ok])


def test_sensor_model_statistics_and_png(tmp_path):
    """Shot noise: electrons are Poisson, so the variance of a flat frame at
    half the full well, in electrons, is the mean (5000 +- 3 %: 40 000 pixels
    give a relative standard error of sqrt(2/40000) = 0.7 %); read noise adds
    its variance. Quantization to N bits: counts within 0 .. 2^N - 1, and the
    PNG holds them as they are (16-bit, values in the low bits)."""
    flat = np.full((200, 200), 0.5, np.float32)
    frame, counts = SensorModel(exposure=1.0, full_well=10000, seed=3).apply(flat)
    assert counts is None
    electrons = frame.astype(np.float64) * 10000
    assert electrons.mean() == pytest.approx(5000, rel=2e-3)
    assert electrons.var() == pytest.approx(5000, rel=0.03)
    frame, _ = SensorModel(exposure=1.0, full_well=10000, read_noise=40, seed=3).apply(flat)
    assert (frame * 10000.0).var() == pytest.approx(5000 + 1600, rel=0.03)
    same, _ = SensorModel(exposure=1.0, full_well=10000, read_noise=40, seed=3).apply(flat)
    assert np.array_equal(frame, same)  # the seed fixes the noise

    ramp = np.linspace(0, 2, 64 * 64, dtype=np.float32).reshape(64, 64)
    frame, counts = SensorModel(exposure=1.0, bits=12).apply(ramp)
    assert counts.dtype == np.uint16 and counts.max() == 4095 and counts.min() == 0
    np.testing.assert_allclose(frame[ramp <= 1], ramp[ramp <= 1], atol=0.5 / 4095 + 1e-7)
    assert np.all(frame[ramp > 1] == 1.0)  # saturated
    from mitsuba_pbrdf.camera.polcam import write_png16

    path = write_png16(tmp_path / "c.png", counts)
    with Image.open(path) as png:
        assert png.mode.startswith("I")
        assert np.array_equal(np.asarray(png).astype(np.uint16), counts)


def test_cli_writes_every_output(tmp_path, capsys):
    image = random_stokes(12, 16, seed=4)
    src = write_stokes_exr(tmp_path / "scene.exr", image)
    out = tmp_path / "cam"
    assert main(["polcam", src, "--out", str(out), "--sensor", "colour", "--bits", "12",
                 "--full-well", "10500", "--read-noise", "2.5", "--seed", "1"]) == 0
    names = sorted(os.listdir(out))
    assert names == sorted(["scene_I0.exr", "scene_I45.exr", "scene_I90.exr", "scene_I135.exr",
                            "scene_mosaic_rgb.exr", "scene_mosaic_rgb.png",
                            "scene_mosaic_rgb_preview.png"])
    ideal = polarizer_images(image)
    for a in ANGLES:
        channels = read_exr_channels(out / f"scene_I{a}.exr")
        assert sorted(channels) == ["B", "G", "R"]
        np.testing.assert_allclose(channels["G"], ideal[a][..., 1], rtol=1e-6)
    mosaic = read_exr_channels(out / "scene_mosaic_rgb.exr")["Y"]
    # noisy: within 5 % of the ideal frame where it is bright
    raw = colour_mosaic(image)
    np.testing.assert_allclose(mosaic, raw, atol=0.05 * raw.max())
    assert main(["polcam", src, "--out", str(out), "--band", "R"]) == 0
    np.testing.assert_array_equal(read_exr_channels(out / "scene_mosaic.exr")["Y"],
                                  mono_mosaic(image, band="R"))


@pytest.mark.usefixtures("restore_variant")
@pytest.mark.slow
def test_frame_convention_matches_renders_through_mitsubas_polarizer(tmp_path):
    """polcam's I_θ of the unfiltered Stokes render equals the render through
    Mitsuba's ``polarizer`` BSDF turned to θ (scenes/gallery/polarizer.xml:
    θ counter-clockwise in the picture from the image's right). With the same
    seed every render traces the same paths (the filter changes no direction,
    Russian roulette is off, one emitter), so no Monte Carlo noise enters:
    on the optical axis they agree to float32 rounding (1e-5 of the largest
    S0). Off axis, rays cross the tilted filter obliquely and Mitsuba turns its
    effective axis (Korger et al. 2013), by up to ~0.3 % of the largest S0 in
    this 30° field of view: 1 % allowed. A handedness flip (θ clockwise)
    would swap I45 and I135, an error of |S2| (checked to be well above 1 %)."""
    from pathlib import Path

    from mitsuba_pbrdf.visualization.gallery import _Settings, render_polarizer_images

    settings = _Settings(scenes=Path(SCENES), out=tmp_path, exr_dir=None, spp=2, scale=0.2,
                         variant="llvm_ad_spectral_polarized", progress=False)
    filtered, clear = render_polarizer_images(settings)
    ours = polarizer_images(clear)
    scale = float(clear.s0.max())
    centre = (slice(16, 20), slice(22, 26))
    for a in ANGLES:
        mitsuba = filtered[a].s0  # (H, W, bands)
        assert np.abs(ours[a] - mitsuba).max() <= 1e-2 * scale, a
        assert np.abs(ours[a] - mitsuba)[centre].max() <= 1e-5 * scale, a
    flipped = np.abs(polarizer_images(clear)[135] - filtered[45].s0).max()
    assert flipped > 5e-2 * scale


def test_polcam_figure_draws_eight_panels(tmp_path):
    from mitsuba_pbrdf.visualization.polcam_figure import _most_polarized_block, polcam_figure

    image = random_stokes(24, 32, seed=5, smooth=True)
    image.stokes[8:16, 12:20, 1] *= 3  # the most polarized block
    assert _most_polarized_block(image, 8) == (8, 12)
    fig = polcam_figure(image, title="t")
    assert len(fig.axes) == 8
    fig.savefig(tmp_path / "f.png")


# ---------------------------------------------------------------- looking at polcam's files


def uniform_stokes(h=8, w=12, bands=("R", "G", "B")):
    """The same physical Stokes vector in every pixel (per band), S3 = 0."""
    vector = np.array([[1.0, 0.3, -0.2, 0.0], [2.0, -0.5, 0.4, 0.0], [1.5, 0.1, 0.6, 0.0]])
    stokes = np.broadcast_to(vector[:len(bands)].T, (h, w, 4, len(bands)))
    return StokesImage(np.ascontiguousarray(stokes, dtype=np.float32), list(bands))


def test_super_pixel_demosaicing_recovers_a_uniform_stokes_image():
    """Where the Stokes vector is the same in every pixel, the super-pixels
    of the raw frames give it back (S3 = 0 apart, which no polarizer sees)."""
    from mitsuba_pbrdf.camera.raw_frames import demosaic, stokes_of_polarizer_images

    image = uniform_stokes()
    mono = demosaic(mono_mosaic(image, band="G"), "mono")
    assert mono.stokes.shape == (4, 6, 4, 1) and mono.bands == ["Y"]
    np.testing.assert_allclose(mono.stokes[..., 0], np.broadcast_to(image.stokes[0, 0, :, 1],
                                                                     (4, 6, 4)), atol=1e-6)
    colour = demosaic(colour_mosaic(image), "colour")
    assert colour.stokes.shape == (2, 3, 4, 3) and colour.bands == ["R", "G", "B"]
    np.testing.assert_allclose(colour.stokes, image.stokes[:2, :3], atol=1e-6)
    images = {a: {b: plane[..., i] for i, b in enumerate(image.bands)}
              for a, plane in polarizer_images(image).items()}
    np.testing.assert_allclose(stokes_of_polarizer_images(images, image.bands).stokes,
                               image.stokes, atol=1e-6)
    with pytest.raises(ValueError, match="2 x 2 blocks"):
        demosaic(np.zeros((3, 4)), "mono")


def test_preview_of_a_12_bit_frame_uses_the_whole_8_bit_range(tmp_path):
    """The 16-bit PNG of a 12-bit frame holds counts up to 4095 (1/16 of its
    range: black in a viewer); the preview beside it maps full scale to 255."""
    image = random_stokes(12, 16, seed=2)
    src = write_stokes_exr(tmp_path / "scene.exr", image)
    out = tmp_path / "cam"
    assert main(["polcam", src, "--out", str(out), "--bits", "12"]) == 0
    with Image.open(out / "scene_mosaic.png") as png:
        counts = np.asarray(png).astype(np.int64)
    with Image.open(out / "scene_mosaic_preview.png") as png:
        assert png.mode == "L"
        preview = np.asarray(png)
    assert counts.max() == 4095 and preview.max() == 255  # the brightest pixel at full scale
    from mitsuba_pbrdf.camera.raw_frames import mosaic_preview

    np.testing.assert_array_equal(preview, mosaic_preview(counts, bits=12))
    assert mosaic_preview(np.array([[0, 4095]]), bits=12).tolist() == [[0, 255]]
    assert main(["polcam", src, "--out", str(out)]) == 0  # float frame: its own top
    with Image.open(out / "scene_mosaic_preview.png") as png:
        assert np.asarray(png).max() == 255


def test_view_draws_polcams_files_as_the_stokes_image_the_camera_measures(tmp_path, capfd):
    image = random_stokes(12, 16, seed=5, smooth=True)
    src = write_stokes_exr(tmp_path / "scene.exr", image)
    out = tmp_path / "cam"
    assert main(["polcam", src, "--out", str(out), "--sensor", "colour"]) == 0
    for name in ("scene_mosaic_rgb.exr", "scene_I45.exr"):
        png = tmp_path / (name + ".png")
        assert main(["view", str(out / name), "--out", str(png)]) == 0
        assert png.stat().st_size > 0
    from mitsuba_pbrdf.camera.raw_frames import read_polcam_exr

    stokes = read_polcam_exr(out / "scene_I45.exr")
    np.testing.assert_allclose(stokes.stokes[..., :3, :], image.stokes[..., :3, :], atol=1e-5)
    assert "polarization camera" in stokes.metadata["title"]
    assert read_polcam_exr(src) is None  # a Stokes EXR is not a polcam file
    os.remove(out / "scene_I90.exr")
    capfd.readouterr()
    assert main(["view", str(out / "scene_I45.exr"), "--out", str(tmp_path / "x.png")]) == 2
    err = capfd.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "scene_I90.exr" in err and "needs all four" in err
    assert not (tmp_path / "x.png").exists()


def test_view_reads_what_read_viewable_exr_reads(tmp_path):
    """``pbrdf view``'s reader in one call: a Stokes EXR as it is, a file of
    ``pbrdf polcam`` as the camera's Stokes image, anything else the Stokes
    reader's error."""
    from mitsuba_pbrdf.camera.raw_frames import read_polcam_exr, read_viewable_exr
    from mitsuba_pbrdf.stokes.exr import write_exr
    from mitsuba_pbrdf.stokes.image import StokesChannelError

    image = random_stokes(4, 6, seed=7)
    src = write_stokes_exr(tmp_path / "scene.exr", image)
    assert main(["polcam", src, "--out", str(tmp_path)]) == 0
    read, from_camera = read_viewable_exr(src)
    assert not from_camera
    np.testing.assert_array_equal(read.stokes, image.stokes)
    read, from_camera = read_viewable_exr(tmp_path / "scene_mosaic.exr")
    assert from_camera
    np.testing.assert_array_equal(read.stokes,
                                  read_polcam_exr(tmp_path / "scene_mosaic.exr").stokes)
    plain = write_exr(tmp_path / "plain.exr", {"Z": np.zeros((2, 2), np.float32)})
    with pytest.raises(StokesChannelError):
        read_viewable_exr(plain)

