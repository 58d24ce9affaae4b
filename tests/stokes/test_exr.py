"""Stokes EXR I/O and derived quantities (mitsuba_pbrdf.stokes.image, .exr)."""

import mitsuba as mi
import numpy as np
import OpenEXR
import pytest

from mitsuba_pbrdf.stokes.image import (
                                        StokesChannelError,
                                        StokesImage,
                                        as_stokes_image,
                                        aolp,
                                        docp,
                                        dolp,
                                        dop,
                                        from_mitsuba,
                                        intensity,
                                        luminance_stokes,
                                        )
from mitsuba_pbrdf.stokes.exr import read_stokes_exr, write_stokes_exr

#: The channel order of Mitsuba's `stokes` integrator output (RGB/spectral variants).
MITSUBA_ORDER = ["R", "G", "B"] + [f"S{i}.{b}" for i in range(4) for b in "RGB"]


def random_image(h=5, w=7, bands=("R", "G", "B"), rgb=True, seed=0):
    rng = np.random.default_rng(seed)
    stokes = rng.normal(size=(h, w, 4, len(bands))).astype(np.float32)
    stokes[:, :, 0] = np.abs(stokes[:, :, 0]) + 2.0  # a plausible S0
    return StokesImage(
        stokes=stokes,
        bands=list(bands),
        rgb=rng.random((h, w, 3), dtype=np.float32) if rgb else None,
        metadata={"scene": "x.xml", "spp": 4},
    )


def write_exr(path, channels, half=False):
    """Write an EXR with exactly these {name: (H, W) array} channels."""
    dtype = np.float16 if half else np.float32
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    data = {k: np.ascontiguousarray(v, dtype=dtype) for k, v in channels.items()}
    with OpenEXR.File(header, data) as f:
        f.write(str(path))


def exr_channel_names(path):
    with OpenEXR.File(str(path), separate_channels=True, header_only=True) as f:
        return sorted(c.name for c in f.header()["channels"])


# ---------------------------------------------------------------- round trips


def test_round_trip_is_exact(tmp_path):
    image = random_image()
    path = write_stokes_exr(tmp_path / "a.exr", image)
    back = read_stokes_exr(path)
    assert back.bands == ["R", "G", "B"]
    assert back.stokes.dtype == np.float32 and back.stokes.shape == (5, 7, 4, 3)
    np.testing.assert_array_equal(back.stokes, image.stokes)
    np.testing.assert_array_equal(back.rgb, image.rgb)
    assert back.metadata == {"scene": "x.xml", "spp": "4"}
    assert exr_channel_names(path) == sorted(MITSUBA_ORDER)


def test_round_trip_without_preview_and_other_bands(tmp_path):
    image = random_image(bands=("Y",), rgb=False)
    back = read_stokes_exr(write_stokes_exr(tmp_path / "sub" / "y.exr", image))
    assert back.bands == ["Y"] and back.rgb is None
    np.testing.assert_array_equal(back.stokes, image.stokes)
    assert exr_channel_names(tmp_path / "sub" / "y.exr") == ["S0.Y", "S1.Y", "S2.Y", "S3.Y"]


def test_reads_channels_by_name_not_position(tmp_path):
    """Each channel holds a constant identifying it; write them in a shuffled
    order (and let OpenEXR sort them), read back, find each where it belongs."""
    names = list(MITSUBA_ORDER)
    np.random.default_rng(1).shuffle(names)
    value = {name: float(k) for k, name in enumerate(MITSUBA_ORDER)}
    write_exr(tmp_path / "s.exr", {n: np.full((3, 4), value[n]) for n in names})
    image = read_stokes_exr(tmp_path / "s.exr")
    assert image.bands == ["R", "G", "B"]
    for i in range(4):
        for b, band in enumerate("RGB"):
            assert np.all(image.stokes[:, :, i, b] == value[f"S{i}.{band}"])
    for c, name in enumerate("RGB"):
        assert np.all(image.rgb[:, :, c] == value[name])


def test_from_mitsuba_uses_the_names_given():
    names = list(MITSUBA_ORDER)
    np.random.default_rng(2).shuffle(names)
    tensor = np.stack([np.full((2, 3), float(MITSUBA_ORDER.index(n))) for n in names], axis=-1)
    image = from_mitsuba(tensor, names)
    for i in range(4):
        for b, band in enumerate("RGB"):
            assert np.all(image.stokes[:, :, i, b] == MITSUBA_ORDER.index(f"S{i}.{band}"))
    with pytest.raises(ValueError, match="15 channel names"):
        from_mitsuba(tensor[:, :, :3], names)


def test_reads_mitsuba_written_files(tmp_path):
    """Files Mitsuba's own bitmap writer produces (half and full float,
    alphabetical channel order) and the nameless ones from a bare tensor."""
    image = random_image(h=4, w=6, seed=3)
    planes = np.concatenate([image.rgb, image.stokes.reshape(4, 6, 12)], axis=-1)
    bitmap = mi.Bitmap(planes, mi.Bitmap.PixelFormat.MultiChannel, MITSUBA_ORDER)

    bitmap.write(str(tmp_path / "full.exr"))
    full = read_stokes_exr(tmp_path / "full.exr")
    np.testing.assert_array_equal(full.stokes, image.stokes)
    np.testing.assert_array_equal(from_mitsuba(bitmap).stokes, image.stokes)

    half_bitmap = mi.Bitmap(planes.astype(np.float16), mi.Bitmap.PixelFormat.MultiChannel, MITSUBA_ORDER)
    half_bitmap.write(str(tmp_path / "half.exr"))
    with OpenEXR.File(str(tmp_path / "half.exr"), separate_channels=True) as f:
        assert f.channels()["S0.R"].pixels.dtype == np.float16
    half = read_stokes_exr(tmp_path / "half.exr")
    assert half.stokes.dtype == np.float32
    np.testing.assert_allclose(half.stokes, image.stokes, rtol=1e-3, atol=1e-3)

    mi.util.write_bitmap(str(tmp_path / "tensor.exr"), mi.TensorXf(planes), write_async=False)
    with pytest.warns(UserWarning, match="no names"):
        unnamed = read_stokes_exr(tmp_path / "tensor.exr")
    np.testing.assert_array_equal(unnamed.stokes, image.stokes)


# ---------------------------------------------------------------- errors


def test_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope.exr"):
        read_stokes_exr(tmp_path / "nope.exr")


def test_not_an_exr(tmp_path):
    (tmp_path / "x.exr").write_text("not an image")
    with pytest.raises(ValueError, match="x.exr.*not a readable OpenEXR"):
        read_stokes_exr(tmp_path / "x.exr")


def test_exr_without_stokes_channels_names_file_and_channels(tmp_path):
    write_exr(tmp_path / "rgb.exr", {c: np.zeros((2, 2)) for c in "RGB"})
    with pytest.raises(StokesChannelError) as e:
        read_stokes_exr(tmp_path / "rgb.exr")
    message = str(e.value)
    assert "rgb.exr" in message and "no Stokes channels" in message
    assert "channels found: B, G, R" in message


def test_incomplete_stokes_channels_are_listed(tmp_path):
    write_exr(tmp_path / "part.exr", {n: np.zeros((2, 2)) for n in ["S0.Y", "S1.Y", "S3.Y"]})
    with pytest.raises(StokesChannelError, match="missing S2.Y"):
        read_stokes_exr(tmp_path / "part.exr")


def test_stokes_image_validates_shapes():
    with pytest.raises(ValueError, match="shape"):
        StokesImage(np.zeros((2, 2, 3, 1)), ["Y"])
    with pytest.raises(ValueError, match="band names"):
        StokesImage(np.zeros((2, 2, 4, 3)), ["Y"])
    with pytest.raises(ValueError, match="rgb"):
        StokesImage(np.zeros((2, 2, 4, 1)), ["Y"], rgb=np.zeros((3, 3, 3)))


# ---------------------------------------------------------------- derived quantities

# Rows: S0, S1, S2, S3 -> expected DoLP, AoLP (radians), DoCP
KNOWN = [
    ([1, 1, 0, 0], 1.0, 0.0, 0.0),            # horizontal linear
    ([1, -1, 0, 0], 1.0, np.pi / 2, 0.0),     # vertical linear
    ([1, 0, 1, 0], 1.0, np.pi / 4, 0.0),      # +45 degrees
    ([1, 0, -1, 0], 1.0, -np.pi / 4, 0.0),    # -45 degrees
    ([2, 0.6, 0.8, 0], 0.5, 0.5 * np.arctan2(0.8, 0.6), 0.0),  # partial
    ([2, 0, 0, -2], 0.0, 0.0, 1.0),           # circular
    ([1, 0, 0, 0], 0.0, 0.0, 0.0),            # unpolarized
    ([0, 0, 0, 0], 0.0, 0.0, 0.0),            # black: 0, no NaN
]


def test_dolp_aolp_docp_of_known_vectors():
    s = np.array([k[0] for k in KNOWN], dtype=np.float32)  # (N, 4)
    np.testing.assert_allclose(dolp(s, axis=-1), [k[1] for k in KNOWN], atol=1e-6)
    np.testing.assert_allclose(aolp(s, axis=-1), [k[2] for k in KNOWN], atol=1e-6)
    np.testing.assert_allclose(docp(s, axis=-1), [k[3] for k in KNOWN], atol=1e-6)
    np.testing.assert_allclose(docp(s, axis=-1, signed=True)[5], -1.0)
    np.testing.assert_allclose(dop(s, axis=-1)[[0, 4, 5, 6]], [1.0, 0.5, 1.0, 0.0], atol=1e-6)
    np.testing.assert_array_equal(intensity(s, axis=-1), s[:, 0])


def test_derived_quantities_on_an_image():
    s = np.array([k[0] for k in KNOWN], dtype=np.float32)  # (N, 4)
    stokes = np.repeat(s[None, :, :, None], 2, axis=-1)  # (1, N, 4, 2 bands)
    image = StokesImage(stokes, ["a", "b"])
    d = dolp(image)
    assert d.shape == (1, len(KNOWN), 2)
    np.testing.assert_allclose(d[0, :, 1], [k[1] for k in KNOWN], atol=1e-6)
    np.testing.assert_allclose(aolp(image)[0, :, 0], [k[2] for k in KNOWN], atol=1e-6)
    assert np.all(np.isfinite(d))


def test_luminance_stokes_weights_rgb():
    stokes = np.zeros((1, 1, 4, 3), np.float32)
    stokes[0, 0, :, 1] = [1, 1, 0, 0]  # only G, fully polarized
    image = StokesImage(stokes, ["R", "G", "B"])
    lum = luminance_stokes(image)
    np.testing.assert_allclose(lum[0, 0], [0.7152, 0.7152, 0, 0], rtol=1e-6)
    assert dolp(lum, axis=-1)[0, 0] == pytest.approx(1.0)


def test_numpy_arrays_and_wavelength_bands_round_trip_in_order(tmp_path):
    """Per-wavelength bands (as assembled from mono renders) keep their order,
    although OpenEXR stores channels alphabetically ("1000nm" < "450nm")."""
    rng = np.random.default_rng(4)
    stokes = rng.normal(size=(3, 5, 4, 3)).astype(np.float32)
    bands = ["450nm", "550nm", "1000nm"]
    path = write_stokes_exr(tmp_path / "w.exr", stokes, bands=bands)
    assert exr_channel_names(path)[:3] == ["S0.1000nm", "S0.450nm", "S0.550nm"]
    back = read_stokes_exr(path)
    assert back.bands == bands
    np.testing.assert_array_equal(back.stokes, stokes)
    assert back.metadata == {}

    single = rng.normal(size=(3, 5, 4)).astype(np.float32)  # one band: "Y"
    back = read_stokes_exr(write_stokes_exr(tmp_path / "y.exr", single))
    assert back.bands == ["Y"]
    np.testing.assert_array_equal(back.stokes[..., 0], single)
    assert as_stokes_image(np.zeros((1, 1, 4, 3))).bands == ["R", "G", "B"]
    assert as_stokes_image(np.zeros((1, 1, 4, 2))).bands == ["B0", "B1"]


def test_bad_band_names_and_arguments(tmp_path):
    with pytest.raises(ValueError, match="commas"):
        write_stokes_exr(tmp_path / "c.exr", np.zeros((1, 1, 4, 1)), bands=["a,b"])
    with pytest.raises(ValueError, match="only for arrays"):
        write_stokes_exr(tmp_path / "d.exr", random_image(), bands=["X", "Y", "Z"])
