"""``polarized_sky`` with a spatially varying ``radiance`` texture: looked up
by direction, sampled uniformly, checked at load time.

The lookup is compared with the texture itself evaluated at texture
coordinates computed here in NumPy (u = atan2(d_x, d_y) / 2 pi, v =
acos(d_z) / pi of the local viewing direction d): equal to float32 rounding
(``1e-5`` relative: the coordinates differ by a few float32 ulps, the
texture's bilinear slope is at most the texel contrast times the resolution,
32 here). The sampling is compared with BSDF sampling, which needs no
emitter pdf: ``direct`` with emitter samples only against ``direct`` with
BSDF samples only, image means within four standard errors of their
per-pixel differences, and a texture replaced by its mean is many standard
errors away (the check can fail).
"""

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest

from proof import polarized_light as pl

SUN = pl.sun_vector(35.0, 40.0)
DOLP_MAX = 0.8


def sky_map(width=32, height=16, seed=0):
    """A smooth random RGB sky with a bright patch, values in [0.05, 1]."""
    rng = np.random.default_rng(seed)
    v, u = np.meshgrid((np.arange(height) + 0.5) / height, (np.arange(width) + 0.5) / width,
                       indexing="ij")
    base = 0.05 + 0.25 * rng.uniform(size=(height, width, 3))
    patch = np.exp(-((u - 0.3) ** 2 + (v - 0.3) ** 2) / 0.01)[..., None]
    return np.clip(base + 0.7 * patch, 0.0, 1.0).astype(np.float32)


def texture(pixels, **extra):
    """A bitmap texture's dict, with a new ``mi.Bitmap`` each call: Mitsuba
    3.9.1's bitmap texture converts the Bitmap it is given in place in
    spectral variants (RGB to spectral coefficients), so a second texture
    loaded from the same Bitmap is garbage (measured: 0.3 grey reads 0)."""
    return dict({"type": "bitmap", "bitmap": mi.Bitmap(pixels)}, **extra)


def sky(pixels, **extra):
    return dict({"type": "polarized_sky", "sun_direction": SUN.tolist(), "dolp_max": DOLP_MAX,
                 "radiance": texture(pixels)}, **extra)


def uv_of(d):
    """Texture coordinates of local viewing directions d (N x 3)."""
    u = np.arctan2(d[:, 0], d[:, 1]) / (2 * np.pi)
    return np.stack([u - np.floor(u), np.arccos(np.clip(d[:, 2], -1, 1)) / np.pi], -1)


def evaluate(emitter_or_texture, d=None, uv=None, wavelengths=(450.0, 520.0, 600.0, 690.0)):
    n = len(d if d is not None else uv)
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    if mi.is_spectral:
        si.wavelengths = mi.UnpolarizedSpectrum(*wavelengths)
    if uv is not None:
        si.uv = mi.Point2f(*uv.T)
        return np.array(emitter_or_texture.eval(si), np.float64)
    si.wi = mi.Vector3f(*(-d.T))
    value = emitter_or_texture.eval(si)
    return [np.array(value[i, 0], np.float64) for i in range(3)]


@pytest.mark.parametrize("turn", [False, True])
def test_the_texture_is_looked_up_by_direction_and_polarized_by_the_pattern(turn):
    pixels = sky_map()
    extra = {}
    rotation = np.eye(3)
    if turn:      # to_world turns the sky by 30 degrees about +Z: the map turns with it
        extra["to_world"] = mi.ScalarTransform4f().rotate([0, 0, 1], 30.0)
        c, s = np.cos(np.radians(30.0)), np.sin(np.radians(30.0))
        rotation = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    emitter = mi.load_dict(sky(pixels, **extra))
    d = pl.unit(np.random.default_rng(1).normal(size=(200, 3)))
    s0, s1, s2 = evaluate(emitter, d)
    expected = evaluate(mi.load_dict(texture(pixels)), uv=uv_of(d @ rotation))
    assert np.abs(s0 - expected).max() < 1e-5 * np.abs(expected).max()
    x = mi.mueller.stokes_basis(mi.Vector3f(*(-d.T)))
    x = np.stack([np.array(c, np.float64) for c in x], -1)
    degree, e = pl.rayleigh(d, SUN, DOLP_MAX)
    eq, eu = pl.linear_stokes(degree, e, x, np.cross(-d, x))
    assert np.abs(s1 / s0 - eq[None]).max() < 1e-5 and np.abs(s2 / s0 - eu[None]).max() < 1e-5


def direct_render(emitter, emitter_samples, bsdf_samples, seed, spp=128):
    scene = {
        "type": "scene",
        "integrator": {"type": "stokes", "inner": {"type": "direct",
                                                   "emitter_samples": emitter_samples,
                                                   "bsdf_samples": bsdf_samples}},
        "sensor": dict(pl.camera([0, -3, 1.2], [0, 0, 0.3], [0, 0, 1], fov=40, width=32,
                                 height=24), sampler={"type": "independent"}),
        "sky": emitter,
        "sphere": {"type": "sphere", "center": [0, 0, 0.5], "radius": 0.5,
                   "bsdf": {"type": "pbrdf", "material": "Cu", "sigma": 0.2, "kdd": 0.1,
                            "kid": 0.05}},
        "ground": {"type": "rectangle", "to_world": mi.ScalarTransform4f().scale(10),
                   "bsdf": {"type": "diffuse", "reflectance": 0.5}}}
    image, _ = pl.render_stokes(scene, spp=spp, seed=seed)
    return image.stokes[..., :3, :].sum(-1).astype(np.float64)      # S0, S1, S2


def test_uniform_sampling_of_the_texture_is_unbiased():
    """Emitter samples alone (uniform on the sphere, weighted by the texture)
    against BSDF samples alone (no emitter pdf involved), S0 and S1 means."""
    by_light = direct_render(sky(sky_map()), 1, 0, seed=1)
    by_bsdf = direct_render(sky(sky_map()), 0, 1, seed=2)
    flat = direct_render(dict(sky(sky_map()), radiance=float(sky_map().mean())), 1, 0, seed=3)
    for c in (0, 1):
        diff = (by_light - by_bsdf)[..., c].ravel()
        error = diff.std() / np.sqrt(diff.size)
        assert abs(diff.mean()) < 4 * error, (c, diff.mean(), error)
        if c == 0:
            assert error < 0.01 * by_bsdf[..., 0].mean()          # a sharp check
            away = (flat - by_bsdf)[..., 0].ravel()
            assert abs(away.mean()) > 10 * away.std() / np.sqrt(away.size)


# ---------------------------------------------------------------- hostile texels

def grey(values):
    return np.asarray(values, np.float32)[..., None]


@pytest.mark.parametrize("bad,text", [
    (float("nan"), "1 texel(s) with NaN or infinite values (first at column 2, row 1)"),
    (float("inf"), "1 texel(s) with NaN or infinite values (first at column 2, row 1)"),
    (-0.5, "1 texel(s) with negative values (first at column 2, row 1)"),
])
def test_bad_texels_are_refused_naming_the_parameter_and_the_texel(bad, text):
    """A raw one-channel bitmap (a flat spectrum per texel, unbounded: how a
    spectral variant takes a grey HDR map)."""
    pixels = np.full((4, 8), 0.5, np.float32)
    pixels[1, 2] = bad
    with pytest.raises(Exception) as error:
        mi.load_dict(dict(sky(grey(pixels)), radiance=texture(grey(pixels), raw=True)))
    last = str(error.value).strip().splitlines()[-1]
    assert last.startswith("ValueError: polarized_sky: parameter 'radiance' has ") and text in last


@pytest.mark.parametrize("bad,text", [
    (-0.5, "'radiance' is negative at 65536 of 131072 texture coordinates (first at (u, v) = "
           "(0.0009766, 0.001953))"),
    (float("nan"), "'radiance' is NaN or infinite at 65536 of 131072 texture coordinates"),
])
def test_a_procedural_texture_is_checked_on_a_grid_of_texture_coordinates(bad, text):
    """A texture without texels (a checkerboard of a bad and a good colour):
    evaluated on a 512 x 256 grid of (u, v), half of it bad."""
    checkerboard = {"type": "checkerboard", "color0": {"type": "uniform", "value": bad}}
    with pytest.raises(Exception) as error:
        mi.load_dict(dict(sky(sky_map()), radiance=checkerboard))
    assert text in str(error.value).strip().splitlines()[-1]
    good = mi.load_dict(dict(sky(sky_map()), radiance={"type": "checkerboard"}))
    assert good.kind == "texture"


@pytest.fixture
def mono():
    from mitsuba_pbrdf import use_variant

    use_variant("llvm_ad_mono_polarized")
    yield
    use_variant("llvm_ad_spectral_polarized")


def test_an_rgb_bitmaps_bad_texels_are_refused_outside_spectral_variants(mono):
    """Outside spectral variants a bitmap stores its texels as they are, and
    they are checked themselves. (In spectral variants Mitsuba's bitmap
    stores spectral-upsampling coefficients: its own conversion has already
    turned a NaN texel into white and a negative one into a positive
    spectrum, docs/polarized-light.md.)"""
    pixels = sky_map(8, 4)
    pixels[3, 5] = [0.2, float("nan"), 0.2]
    with pytest.raises(Exception, match=r"'radiance' has 1 texel\(s\) with NaN or infinite "
                                        r"values \(first at column 5, row 3\)"):
        mi.load_dict(sky(pixels))
    emitter = mi.load_dict(sky(sky_map(8, 4)))       # the same sky, sane, loads
    s0, _, _ = evaluate(emitter, pl.unit(np.array([[0.2, 0.3, 0.9]])), wavelengths=(550.0,))
    assert np.all(s0 > 0)
