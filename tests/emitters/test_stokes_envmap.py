"""``stokes_envmap``: a lat-long Stokes EXR as an environment emitter.

The round trip: the Rayleigh sky of ``polarized_sky`` written per texel (in
the documented lat-long basis) to a Stokes EXR, loaded as ``stokes_envmap``,
lights a smooth metal as the sky itself does. Two comparisons per pixel:

* against the same physics computed from the map's texels, interpolated in
  NumPy float64 as the emitter documents (bilinear on Mitsuba's envmap grid,
  as Stokes vectors): ``TOL = 1e-5``, the float32 bound of
  tests/emitters/test_polarized_light.py (measured: ~1e-6);
* against ``polarized_sky`` itself: within the map's interpolation error,
  which NumPy measures on the same pixels (1 degree texels: about 2e-4), plus
  ``TOL``.
"""

import numpy as np
import pytest

import drjit as dr
import mitsuba as mi

from mitsuba_pbrdf.stokes import write_stokes_exr
from proof import polarized_light as pl

TOL = 1e-5
SUN = pl.sun_vector(30.0, 40.0)
DOLP_MAX = 0.8
ETA, K = 0.27, 2.8
WIDTH, HEIGHT = 360, 181
VIEW = dict(origin=[0, -3, 1.2], target=[0, 0, 0], up=[0, 0, 1], fov=40)


def to_world():
    m = np.eye(4)
    m[:3, :3] = pl.Y_TO_Z
    return mi.ScalarTransform4f(m)


@pytest.fixture(scope="module")
def sky_map(tmp_path_factory):
    """(path, (H, W, 4) map): the Rayleigh sky, S0 = 1 in every band."""
    stokes = pl.rayleigh_latlong(WIDTH, HEIGHT, SUN, DOLP_MAX)
    path = tmp_path_factory.mktemp("envmap") / "sky.exr"
    write_stokes_exr(path, np.repeat(stokes[..., None], 3, -1).astype(np.float32),
                     bands=["R", "G", "B"])
    return str(path), stokes


def envmap(path, **extra):
    return dict({"type": "stokes_envmap", "filename": path, "to_world": to_world()}, **extra)


def plane_scene(emitter):
    plane = {"plane": {"type": "rectangle", "to_world": mi.ScalarTransform4f().scale(100),
                       "bsdf": {"type": "conductor", "eta": ETA, "k": K}}}
    return pl.scene(emitter, pl.camera(**VIEW), plane)


def test_the_map_lights_a_metal_as_the_sky_does(sky_map):
    path, stokes = sky_map
    image, loaded = pl.render_stokes(plane_scene(envmap(path)))
    sky, _ = pl.render_stokes(plane_scene({"type": "polarized_sky", "sun_direction": SUN.tolist(),
                                           "dolp_max": DOLP_MAX, "radiance": 1.0}))
    _, d = pl.pixel_rays(loaded)
    up = pl.camera_up(loaded)
    q, u, v, s0 = pl.normalized(image)
    want = pl.reflected(d, up, pl.latlong_incident(stokes), ETA, K)[:3]
    exact = pl.reflected(d, up, pl.rayleigh_incident(SUN, DOLP_MAX), ETA, K)[:3]
    assert np.all(s0 > 0) and np.abs(want[2]).max() > 0.3
    for got, w in zip((q, u, v), want):
        assert np.abs(got - w).max() < TOL
    interpolation = max(np.abs(a - b).max() for a, b in zip(want, exact))
    assert 1e-5 < interpolation < 1e-3, interpolation     # 1 degree texels
    sq, su, sv, _ = pl.normalized(sky)
    for got, w in zip((q, u, v), (sq, su, sv)):
        assert np.abs(got - w).max() < interpolation + TOL


def test_seen_directly_the_map_is_its_texels_in_the_lat_long_basis(sky_map):
    path, stokes = sky_map
    emitter = mi.load_dict(envmap(path))
    rng = np.random.default_rng(5)
    d = pl.unit(rng.normal(size=(4000, 3)))
    si = dr.zeros(mi.SurfaceInteraction3f, len(d))
    si.wi = mi.Vector3f(*(-d.T))
    si.wavelengths = mi.UnpolarizedSpectrum(450.0, 520.0, 600.0, 690.0)
    value = emitter.eval(si)
    s = [np.array(value[i, 0], np.float64) for i in range(4)]
    x = np.stack([np.array(c, np.float64) for c in mi.mueller.stokes_basis(si.wi)], -1)
    values, east = pl.latlong_incident(stokes)(d)
    want = pl.rotate_stokes(values, east, x, -d)
    for i in (1, 2, 3):
        assert np.abs(s[i] / s[0] - (want[:, i] / want[:, 0])[None]).max() < TOL
    # the intensity is envmap's for the same S0 image
    plain = mi.load_dict({"type": "envmap", "bitmap": mi.Bitmap(np.ones((HEIGHT, WIDTH, 3),
                                                                       np.float32)),
                          "to_world": to_world()})
    assert np.array_equal(np.array(plain.eval(si)[0, 0]), s[0].astype(np.float32))


def test_sampling_follows_s0(sky_map, tmp_path):
    """A map bright in one corner: envmap's importance sampling of S0, the
    same directions and pdfs, and the polarization of eval in the weight."""
    stokes = pl.rayleigh_latlong(64, 33, SUN, DOLP_MAX)
    stokes[:8, :8] *= 50.0
    path = tmp_path / "bright.exr"
    write_stokes_exr(path, np.repeat(stokes[..., None], 3, -1).astype(np.float32),
                     bands=["R", "G", "B"])
    scene = mi.load_dict({"type": "scene", "env": envmap(str(path))})
    emitter = scene.emitters()[0]
    plain = mi.load_dict({"type": "envmap", "to_world": to_world(),
                          "bitmap": mi.Bitmap(np.ascontiguousarray(
                              np.repeat(stokes[..., :1], 3, -1).astype(np.float32)))})
    plain.set_scene(scene)
    n = 4096
    it = dr.zeros(mi.Interaction3f, n)
    it.wavelengths = mi.UnpolarizedSpectrum(450.0, 520.0, 600.0, 690.0)
    sample = mi.Point2f(*np.random.default_rng(6).random((2, n)).astype(np.float32))
    ds, weight = emitter.sample_direction(it, sample)
    ds_plain, weight_plain = plain.sample_direction(it, sample)
    assert np.array_equal(np.array(ds.d), np.array(ds_plain.d))
    assert np.array_equal(np.array(ds.pdf), np.array(ds_plain.pdf))
    assert np.array_equal(np.array(weight[0, 0]), np.array(weight_plain[0, 0]))
    assert dr.all(ds.emitter == mi.EmitterPtr(emitter))
    d = np.stack([np.array(c, np.float64) for c in ds.d], -1)
    assert np.mean(d[:, 2] > 0.85) > 0.3          # the bright corner, near the zenith
    value = emitter.eval_direction(it, ds)
    for i in (1, 2, 3):
        a = np.array(weight[i, 0]) / np.array(weight[0, 0])
        b = np.array(value[i, 0]) / np.array(value[0, 0])
        assert np.abs(a - b).max() < TOL


def test_the_unpolarized_variant_is_envmap(sky_map, variant_switch):
    path, _ = sky_map
    variant_switch("llvm_ad_spectral")
    cam = pl.camera(**VIEW)
    ours, _ = pl.render_stokes(plane_scene(envmap(path)))
    bitmap = mi.Bitmap(np.ones((HEIGHT, WIDTH, 3), np.float32))
    theirs, _ = pl.render_stokes(plane_scene({"type": "envmap", "bitmap": bitmap,
                                              "to_world": to_world()}))
    assert np.array_equal(ours.stokes, theirs.stokes)
    assert cam


@pytest.fixture
def variant_switch():
    from mitsuba_pbrdf import use_variant

    yield use_variant
    use_variant("llvm_ad_spectral_polarized")


# ---------------------------------------------------------------- hostile files

def write(tmp_path, name, stokes, bands=("R", "G", "B")):
    path = tmp_path / name
    write_stokes_exr(path, stokes.astype(np.float32), bands=list(bands))
    return str(path)


def good(h=9, w=16):
    s = np.zeros((h, w, 4, 3), np.float32)
    s[:, :, 0] = 1.0
    s[:, :, 1] = 0.5
    return s


def missing_channel(tmp_path):
    from mitsuba_pbrdf.stokes.exr import write_exr

    path = tmp_path / "missing.exr"
    s = good()
    channels = {f"S{i}.{b}": s[:, :, i, j] for i in range(3) for j, b in enumerate("RGB")}
    write_exr(path, channels)           # no S3
    return str(path)


def nan_texel(tmp_path):
    s = good()
    s[4, 7, 2, 1] = np.nan
    return write(tmp_path, "nan.exr", s)


def overpolarized(tmp_path):
    s = good()
    s[2, 3, 1] = 1.2                     # DoP 1.2 in every band
    return write(tmp_path, "dop.exr", s)


def negative(tmp_path):
    s = good()
    s[5, 5, 0] = -0.5
    s[5, 5, 1] = 0.0
    return write(tmp_path, "negative.exr", s)


def not_an_exr(tmp_path):
    path = tmp_path / "sky.exr"
    path.write_text("not an image")
    return str(path)


HOSTILE = [
    (missing_channel, "missing S3.R, S3.G, S3.B"),
    (nan_texel, "1 texel(s) with a NaN or infinite value (first at column 7, row 4)"),
    (overpolarized, "1 texel(s) with a degree of polarization above 1 (first at column 3, "
                    "row 2)"),
    (negative, "1 texel(s) with a negative luminance S0 (first at column 5, row 5)"),
    (not_an_exr, "'filename'"),
    (lambda tmp_path: str(tmp_path / "absent.exr"), "absent.exr: no such file"),
]


@pytest.mark.parametrize("make,text", HOSTILE, ids=[h[0].__name__ if hasattr(h[0], "__name__")
                                                    else "absent" for h in HOSTILE])
def test_a_bad_file_is_refused_at_load_time_in_one_line(tmp_path, make, text):
    path = make(tmp_path)
    with pytest.raises(Exception) as error:
        mi.load_dict({"type": "stokes_envmap", "filename": path})
    last = str(error.value).strip().splitlines()[-1]
    assert last.startswith("ValueError: stokes_envmap: parameter 'filename'"), last
    assert text in last, last


def test_bad_parameters_are_refused(tmp_path):
    path = write(tmp_path, "ok.exr", good())
    for params, text in (({}, "'filename' is required"),
                         ({"filename": path, "scale": -1.0}, "'scale' must be >= 0"),
                         ({"filename": path, "scale": float("nan")}, "'scale' must be finite")):
        with pytest.raises(Exception) as error:
            mi.load_dict(dict({"type": "stokes_envmap"}, **params))
        last = str(error.value).strip().splitlines()[-1]
        assert last.startswith("ValueError: stokes_envmap: ") and text in last, last
    assert mi.load_dict({"type": "stokes_envmap", "filename": path}).width == 16


def test_a_refused_map_leaves_later_renders_working(tmp_path):
    """The checks run before the emitter registers with Dr.Jit: a refused
    emitter, kept alive by the exception pytest holds, is not traced into
    the next render's calls."""
    errors = []
    for make, _ in HOSTILE:
        with pytest.raises(Exception) as error:
            mi.load_dict({"type": "stokes_envmap", "filename": make(tmp_path)})
        errors.append(error)
    image, _ = pl.render_stokes(pl.scene({"type": "constant"}, pl.camera(**VIEW)))
    assert len(errors) == len(HOSTILE) and np.all(image.stokes[:, :, 0] > 0)
