"""``polarized_normalmap`` and ``polarized_bumpmap`` (mitsuba_pbrdf/shading,
docs/normal-maps.md) against physically equivalent scenes and against
Mitsuba's ``normalmap``/``bumpmap``.

Oracles and tolerances:

* A plane tilted by θ towards φ is the same surface, for the light, as a flat
  plane whose constant normal map (or linear height ramp) encodes that normal.
  Orthographic camera, directional light, uniform plane: every pixel sees the
  same geometry, and both renders draw the same random numbers (pixel
  positions, wavelengths; the light is sampled deterministically and
  BSDF-sampled rays leave the scene), so the two images differ only by
  float32 rounding of different arithmetic (rotations, frames): ~1e-7
  relative. Asserted: DoLP within 1e-5 absolute, AoLP within 0.1° (the
  required bound; measured < 1e-4°, validation/normal_maps.md), S0 of the
  wrapper equal to Mitsuba's wrapper's to 1e-5 relative.
* Mitsuba's wrappers compute the same frames with the same float32 operations
  in C++: unpolarized variants compare bit for bit.
* Gradients: central finite differences of the same render (common random
  numbers), step 2e-3 in texel value; float32 sums over 256 samples give an
  FD noise of ~1e-6 / 2e-3 ~ 5e-4 of the functional's scale; asserted 0.5 % of
  the gradient's norm (measured 0.02-0.04 %; the truncation error O(h²) of a
  smooth bilinear map is far below).
"""

import functools
import math

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest


TILTS = (10.0, 30.0, 60.0)
AZIMUTHS = (20.0, 135.0, 250.0)
NESTED = {
    "pbrdf": {"type": "pbrdf", "material": "Au", "sigma": 0.2},
    "roughconductor": {"type": "roughconductor", "material": "Au", "alpha": 0.3},
}


def tp():
    from proof import tilted_plane

    return tilted_plane


@functools.lru_cache(maxsize=None)
def comparison(wrapper, nested, shadowing=True):
    """A :class:`~proof.tilted_plane.Comparison`, shared by the
    tests (loading and compiling its two scenes is most of their time)."""
    extra = {} if shadowing else {"use_shadowing_function": False}
    return tp().Comparison(wrapper, NESTED[nested], **extra)


def polarization(image):
    """S0, DoLP, AoLP (degrees) per pixel and band."""
    s = image.stokes.astype(np.float64)  # (h, w, 4, bands)
    s0, s1, s2 = s[:, :, 0], s[:, :, 1], s[:, :, 2]
    return s0, np.hypot(s1, s2) / s0, 0.5 * np.degrees(np.arctan2(s2, s1))


def aolp_error(a, b):
    """|a - b| in degrees, modulo 180°."""
    return np.abs((a - b + 90.0) % 180.0 - 90.0)


# ------------------------------------------------------------- tilted plane


@pytest.mark.parametrize("nested", sorted(NESTED))
@pytest.mark.parametrize("wrapper", ["normalmap", "bumpmap"])
@pytest.mark.slow
def test_constant_map_equals_tilted_plane(nested, wrapper):
    """DoLP and AoLP of the polarized wrapper equal the tilted plane's, for
    every tilt and azimuth; S0 equals Mitsuba's wrapper's; Mitsuba's wrapper
    fails the same comparison (the test can see the error)."""
    ours = comparison("polarized_" + wrapper, nested)
    theirs = comparison(wrapper, nested)
    worst_mitsuba = 0.0
    for tilt in TILTS:
        for azimuth in AZIMUTHS:
            where = f"{wrapper}({nested}) tilt {tilt}, azimuth {azimuth}"
            tilted, mapped = (polarization(i) for i in ours.render(tilt, azimuth))
            mitsuba = polarization(theirs.render(tilt, azimuth)[1])
            # AoLP is defined where DoLP > 1e-3 (gold's red band hardly polarizes)
            defined = tilted[1] > 1e-3
            assert np.all(defined[..., 1]), where
            np.testing.assert_allclose(mapped[1], tilted[1], atol=1e-5, err_msg=where)
            assert aolp_error(mapped[2], tilted[2])[defined].max() < 0.1, where
            np.testing.assert_allclose(mapped[0], mitsuba[0], rtol=1e-5, err_msg=where)
            worst_mitsuba = max(worst_mitsuba, aolp_error(mitsuba[2], tilted[2])[defined].max())
    # Mitsuba's wrapper on this grid: AoLP off by up to 18° (measured).
    assert worst_mitsuba > 10.0


@pytest.mark.parametrize("wrapper", ["polarized_normalmap", "polarized_bumpmap"])
def test_s0_factor_is_the_shadowing_function(wrapper):
    """The S0 ratio to the tilted plane is Estevez's shadowing term (what
    ``normalmap`` multiplies by), and without it S0 is the tilted plane's."""
    shadowed = comparison(wrapper, "roughconductor")
    plain = comparison(wrapper, "roughconductor", shadowing=False)
    for tilt, azimuth in ((30.0, 20.0), (60.0, 135.0)):
        tilted, mapped = (polarization(i)[0] for i in shadowed.render(tilt, azimuth))
        towards = tp().light_towards(tilt, azimuth)
        tan2_n = math.tan(math.radians(tilt)) ** 2
        tan2_o = (1.0 - towards[2] ** 2) / towards[2] ** 2
        expected = 2.0 / (1.0 + math.sqrt(1.0 + min(tan2_n / 8.0, 1.0) * tan2_o))
        np.testing.assert_allclose(mapped / tilted, expected, rtol=1e-5)
        tilted, mapped = (polarization(i)[0] for i in plain.render(tilt, azimuth))
        np.testing.assert_allclose(mapped, tilted, rtol=1e-5)


def test_flat_normal_map_changes_nothing():
    """``roughconductor`` in ``polarized_normalmap`` with a flat map (and in
    ``polarized_bumpmap`` with a constant height) equals ``roughconductor``,
    every Mueller element, at float32 level."""
    bsdf = mi.load_dict(NESTED["roughconductor"])
    flat = mi.load_dict({"type": "polarized_normalmap", "bsdf": NESTED["roughconductor"],
                         "normalmap": tp().normalmap_bitmap((0.0, 0.0, 1.0))})
    level = mi.load_dict({"type": "polarized_bumpmap", "bsdf": NESTED["roughconductor"],
                          "height": {"type": "bitmap", "raw": True,
                                     "bitmap": mi.Bitmap(np.full((2, 2, 1), 0.3, np.float32))}})
    si, wo = _interactions(512, seed=3)
    ctx = mi.BSDFContext()
    expected = _mueller(bsdf.eval(ctx, si, wo))
    for wrapper in (flat, level):
        value = _mueller(wrapper.eval(ctx, si, wo))
        assert np.all(np.isfinite(value))
        # float32: a product of a few unit-scale factors, ~1e-7 relative
        np.testing.assert_allclose(value, expected, rtol=1e-5, atol=1e-6)
        np.testing.assert_allclose(np.array(wrapper.pdf(ctx, si, wo)),
                                   np.array(bsdf.pdf(ctx, si, wo)), rtol=1e-5, atol=1e-6)


def _interactions(n, seed):
    """Local directions wi, wo above the horizon and uv in [0, 1]^2, on a
    surface whose frames are the world axes (dp_du = x, dp_dv = y)."""
    rng = np.random.default_rng(seed)

    def hemisphere(k):
        v = rng.normal(size=(k, 3))
        v[:, 2] = np.abs(v[:, 2]) + 0.05
        return (v / np.linalg.norm(v, axis=1, keepdims=True)).astype(np.float32)

    wi, wo = hemisphere(n), hemisphere(n)
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.wi = mi.Vector3f(*wi.T)
    si.uv = mi.Point2f(*rng.uniform(size=(2, n)).astype(np.float32))
    si.n = mi.Normal3f(0.0, 0.0, 1.0)
    si.sh_frame = mi.Frame3f(mi.Vector3f(0.0, 0.0, 1.0))
    si.dp_du = mi.Vector3f(1.0, 0.0, 0.0)
    si.dp_dv = mi.Vector3f(0.0, 1.0, 0.0)
    if mi.is_spectral:
        si.wavelengths = mi.UnpolarizedSpectrum(450.0, 520.0, 600.0, 690.0)
    return si, mi.Vector3f(*wo.T)


def _mueller(value):
    """A BSDF value as a NumPy array (16 Mueller elements or the spectrum)."""
    dr.eval(value)  # one kernel, not one per element
    if mi.is_polarized:
        return np.stack([np.array(value[i, j]) for i in range(4) for j in range(4)])
    return np.array(value)


# ------------------------------------------------- frames, transport modes


def _random_frames(n, rng):
    """Random orthonormal shading frames (s, t, n) as NumPy arrays."""
    q, _ = np.linalg.qr(rng.normal(size=(n, 3, 3)))
    return q[:, :, 0], q[:, :, 1], q[:, :, 2]


def _frame(s, t, n):
    f = dr.zeros(mi.Frame3f, len(s))
    f.s, f.t, f.n = (mi.Vector3f(*np.asarray(v, dtype=np.float32).T) for v in (s, t, n))
    return f


@pytest.mark.parametrize("mode", ["Radiance", "Importance"])
def test_world_mueller_matrix_does_not_depend_on_the_frame(mode):
    """In world-space Stokes bases, the wrapper's Mueller matrix in the
    unperturbed frame S equals the nested BSDF's evaluated directly in the
    perturbed frame P (a random S, a random constant normal), in both
    transport modes: the rotation puts the bases where the integrator reads
    them. Mitsuba's ``normalmap`` does not (checked too)."""
    rng = np.random.default_rng(7)
    n = 256
    normal = tp().tilted_normal(35.0, 70.0)
    nested = NESTED["roughconductor"]
    ours = mi.load_dict({"type": "polarized_normalmap", "bsdf": nested,
                         "use_shadowing_function": False,
                         "normalmap": tp().normalmap_bitmap(normal)})
    theirs = mi.load_dict({"type": "normalmap", "bsdf": nested, "use_shadowing_function": False,
                           "normalmap": tp().normalmap_bitmap(normal)})
    bare = mi.load_dict(nested)

    s, t, nn = _random_frames(n, rng)
    p_n = s * normal[0] + t * normal[1] + nn * normal[2]
    p_s = s - p_n * (p_n * s).sum(1, keepdims=True)  # normalmap's tangent: S's x projected
    p_s /= np.linalg.norm(p_s, axis=1, keepdims=True)
    p_t = np.cross(p_n, p_s)

    def above(axis):  # world directions above both S and P
        v = rng.normal(size=(n, 3))
        v += (2.5 + rng.uniform(size=(n, 1))) * (axis / np.linalg.norm(axis, axis=1,
                                                                          keepdims=True))
        return v / np.linalg.norm(v, axis=1, keepdims=True)

    bisector = nn + p_n
    wi_world, wo_world = above(bisector), above(bisector)
    ctx = mi.BSDFContext(getattr(mi.TransportMode, mode))

    def in_frame(frame):
        si = dr.zeros(mi.SurfaceInteraction3f, n)
        si.sh_frame = frame
        si.n = frame.n
        si.wi = frame.to_local(mi.Vector3f(*wi_world.astype(np.float32).T))
        si.wavelengths = mi.UnpolarizedSpectrum(450.0, 520.0, 600.0, 690.0)
        return si, frame.to_local(mi.Vector3f(*wo_world.astype(np.float32).T))

    def world(bsdf, si, wo):
        value = bsdf.eval(ctx, si, wo)
        # light arrives along -wo_hat and leaves along wi_hat (MODEL: Mitsuba's convention)
        wo_hat, wi_hat = (wo, si.wi) if mode == "Radiance" else (si.wi, wo)
        return _mueller(si.to_world_mueller(value, -wo_hat, wi_hat))

    # lanes with both directions above both horizons (elsewhere the wrappers
    # cut the lobe, or flip the normal, by design)
    keep = np.ones(n, bool)
    for w in (wi_world, wo_world):
        for axis in (nn, p_n):
            keep &= (w * axis).sum(1) > 1e-2
    assert keep.sum() > n // 2
    si_s, wo_s = in_frame(_frame(s, t, nn))
    si_p, wo_p = in_frame(_frame(p_s, p_t, p_n))
    expected = world(bare, si_p, wo_p)[..., keep]
    got = world(ours, si_s, wo_s)[..., keep]
    assert np.abs(expected).max() > 0.05
    # float32 frames and rotations: ~1e-6 of the largest element
    np.testing.assert_allclose(got, expected, atol=1e-5 * np.abs(expected).max())
    mitsuba = world(theirs, si_s, wo_s)[..., keep]
    assert np.abs(mitsuba - expected).max() > 1e-2 * np.abs(expected).max()


def test_sample_agrees_with_eval_and_pdf():
    """``sample``'s weight is ``eval / pdf`` at the sampled direction, Mueller
    element by element (the same rotation on both paths), for a random
    bilinear normal map."""
    rng = np.random.default_rng(11)
    colours = (rng.normal(size=(4, 4, 3)) * [0.3, 0.3, 0.1] + [0.0, 0.0, 1.0])
    colours = (colours / np.linalg.norm(colours, axis=2, keepdims=True) + 1.0) / 2.0
    bsdf = mi.load_dict({"type": "polarized_normalmap", "bsdf": NESTED["pbrdf"],
                         "normalmap": {"type": "bitmap", "raw": True,
                                       "bitmap": mi.Bitmap(colours.astype(np.float32))}})
    si, _ = _interactions(1024, seed=5)
    ctx = mi.BSDFContext()
    sampler = np.random.default_rng(2).uniform(size=(3, 1024)).astype(np.float32)
    bs, weight = bsdf.sample(ctx, si, mi.Float(sampler[0]), mi.Point2f(sampler[1], sampler[2]))
    value, pdf = bsdf.eval_pdf(ctx, si, bs.wo)
    ok = (np.array(bs.pdf) > 1e-3) & (np.array(pdf) > 1e-3)
    assert ok.sum() > 500
    np.testing.assert_allclose(np.array(bs.pdf)[ok], np.array(pdf)[ok], rtol=1e-4)
    expected = _mueller(value)[:, ..., ok] / np.array(pdf)[ok]
    got = _mueller(weight)[:, ..., ok]
    # float32; the mixture weight's division: 1e-4 of the largest element
    np.testing.assert_allclose(got, expected, atol=1e-4 * np.abs(expected).max())


# ------------------------------------------------------ unpolarized variants


def _random_normal_map(rng, size=4):
    colours = rng.normal(size=(size, size, 3)) * [0.4, 0.4, 0.1] + [0.0, 0.0, 1.0]
    colours = (colours / np.linalg.norm(colours, axis=2, keepdims=True) + 1.0) / 2.0
    return {"type": "bitmap", "raw": True, "bitmap": mi.Bitmap(colours.astype(np.float32))}


def _random_heights(rng, size=4):
    return {"type": "bitmap", "raw": True,
            "bitmap": mi.Bitmap(rng.uniform(size=(size, size, 1)).astype(np.float32))}


@pytest.mark.parametrize("variant", ["llvm_ad_rgb", "llvm_ad_spectral"], indirect=True)
@pytest.mark.parametrize("wrapper", ["normalmap", "bumpmap"])
def test_unpolarized_variants_give_what_mitsuba_gives(variant, wrapper):
    """eval, pdf, eval_pdf and sample of the wrapper and of Mitsuba's, on a
    random map, random directions, random shading frames: the same float32
    operations in the same order, traced into the same LLVM kernels, so equal
    bit for bit (measured; a difference would mean a changed operation)."""
    rng = np.random.default_rng(3)
    texture = _random_normal_map(rng) if wrapper == "normalmap" else _random_heights(rng)
    key = "normalmap" if wrapper == "normalmap" else "height"
    nested = {"type": "roughconductor", "alpha": 0.25, "material": "Cu"}
    extra = {} if wrapper == "normalmap" else {"scale": 0.3}
    theirs = mi.load_dict({"type": wrapper, key: texture, "bsdf": nested, **extra})
    ours = mi.load_dict({"type": "polarized_" + wrapper, key: texture, "bsdf": nested, **extra})
    assert ours.flags() == theirs.flags()
    assert sorted(mi.traverse(ours).keys()) == sorted(mi.traverse(theirs).keys())

    n = 2048
    si, wo = _interactions(n, seed=9)
    s, t, nn = _random_frames(n, rng)
    si.sh_frame = _frame(s, t, nn)
    si.n = si.sh_frame.n
    si.dp_du = si.sh_frame.s * 1.3
    si.dp_dv = si.sh_frame.t * 0.7 + si.sh_frame.s * 0.1
    ctx = mi.BSDFContext()
    samples = rng.uniform(size=(3, n)).astype(np.float32)
    results = []
    for bsdf in (ours, theirs):
        bs, weight = bsdf.sample(ctx, si, mi.Float(samples[0]),
                                 mi.Point2f(samples[1], samples[2]))
        value, pdf = bsdf.eval_pdf(ctx, si, wo)
        results.append([np.array(x) for x in (bsdf.eval(ctx, si, wo), bsdf.pdf(ctx, si, wo),
                                              value, pdf, bs.wo, bs.pdf, weight)])
    for name, a, b in zip(("eval", "pdf", "eval_pdf value", "eval_pdf pdf", "sample wo",
                           "sample pdf", "sample weight"), *results):
        assert np.all(np.isfinite(a)), name
        assert np.count_nonzero(b) > n // 4, name  # the comparison sees values
        assert np.array_equal(a, b), f"{name}: max |diff| {np.abs(a - b).max():.3g}"


# ---------------------------------------------------------------- gradients


@pytest.mark.parametrize("wrapper", ["polarized_normalmap", "polarized_bumpmap"])
@pytest.mark.slow
def test_stokes_prb_texel_gradients_match_finite_differences(wrapper):
    """``stokes_prb`` renders a scene with the wrapper, and its reverse-mode
    gradient of a random Stokes functional with respect to every texel equals
    central finite differences of the same renders (common random numbers):
    what shape from polarization will optimize."""
    from proof.render_gradients import functional_gradient, random_functional

    rng = np.random.default_rng(4)
    if wrapper == "polarized_normalmap":
        texture, key = _random_normal_map(rng, size=2), "plate.bsdf.normalmap.data"
        bsdf = {"type": wrapper, "normalmap": texture, "bsdf": NESTED["pbrdf"]}
    else:
        texture, key = _random_heights(rng, size=3), "plate.bsdf.nested_texture.data"
        bsdf = {"type": wrapper, "height": texture, "scale": 0.2, "bsdf": NESTED["pbrdf"]}
    scene = mi.load_dict(tp().scene(tp().plane(bsdf, extent=1.2),
                                    light=tp().tilted_normal(50.0, 25.0)))
    integrator = mi.load_dict({"type": "stokes_prb", "max_depth": 2})
    weights = random_functional(8, 8, seed=2)

    def functional():
        # the adjoint pass uses seed_grad's samples: the same ones here
        image = mi.render(scene, integrator=integrator, spp=4, seed=4)
        return float(np.sum(np.array(image, dtype=np.float64) * np.array(weights)))

    ad = functional_gradient(scene, [key], weights, spp=4, seed=3, seed_grad=4,
                             integrator=integrator)
    params = mi.traverse(scene)
    base = np.array(params[key], dtype=np.float32)
    h = 2e-3
    fd = np.zeros(base.size)
    for j in range(base.size):
        values = []
        for sign in (1.0, -1.0):
            data = base.copy().ravel()
            data[j] += sign * h
            params[key] = mi.TensorXf(data.reshape(base.shape))
            params.update()
            values.append(functional())
        fd[j] = (values[0] - values[1]) / (2 * h)
    params[key] = mi.TensorXf(base)
    params.update()
    assert np.linalg.norm(fd) > 1e-2  # the functional sees the texels
    # measured: 1.6e-4 (normal map), 4.4e-4 (bump map) of the norm
    np.testing.assert_allclose(ad, fd, atol=5e-3 * np.linalg.norm(fd))
