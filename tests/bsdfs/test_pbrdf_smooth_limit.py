"""The smooth limit (issue 36): ``sigma = 0`` (``alpha = 0``) makes the specular
lobe a delta, Mitsuba's ``conductor``: the same Fresnel Mueller matrix, the
same sampling (``DeltaReflection``, pdf 1, the mirror direction), ``eval`` and
``pdf`` 0. Beside diffuse lobes it is one choice of the mixture sampler.

Tolerances: the Mueller matrices differ from conductor's by the Fresnel
arithmetic alone (closed form vs dr::Complex, float32): 1e-5 of M00 per
element, as tests/bsdfs/test_pbrdf_roughconductor.py; renders at matched seed consume the
same random numbers, so they agree to float32 rounding (1e-4 of the mean S0
per 4x4 tile, MODEL.md's figure; measured 6.8e-8 polarized, 3.7e-8 RGB, against a
seed-to-seed 0.33).
"""

import math

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest

from bsdf_harness import as_numpy, hemisphere_pairs, make_si, tile_means, to_vector
from mitsuba_pbrdf import schema

TOL = 1e-5
MATCHED = 1e-4
MODES = [mi.TransportMode.Radiance, mi.TransportMode.Importance]
IOR = {"eta": 1.2, "k": 3.0}


def random_numbers(n, seed):
    rng = np.random.default_rng(seed)
    if mi.variant().startswith("scalar"):
        return mi.Float(rng.random()), mi.Point2f(*rng.random(2))
    return (mi.Float(rng.random(n).astype(np.float32)),
            mi.Point2f(*rng.random((2, n)).astype(np.float32)))


def assert_close_mueller(expected, actual):
    m00 = np.abs(expected[..., :1, :1]) if mi.is_polarized else np.abs(expected)
    assert np.all(np.isfinite(actual))
    assert np.all(np.abs(actual - expected) <= TOL * m00 + 1e-30), \
        f"max error / M00 = {np.max(np.abs(actual - expected) / np.maximum(m00, 1e-30)):.3g}"


@pytest.mark.parametrize("variant", ["llvm_ad_spectral_polarized", "llvm_ad_rgb",
                                     "llvm_ad_mono_polarized", "scalar_spectral_polarized"],
                         indirect=True)
def test_sample_eval_pdf_are_conductors(variant):
    scalar = variant.startswith("scalar")
    wi, wo = hemisphere_pairs(4 if scalar else 2000, seed=7)
    rows = [(a, b) for a, b in zip(wi, wo)] if scalar else [(wi, wo)]
    for given in ({"sigma": 0.0}, {"alpha": 0.0}, {"sigma_u": 0.0, "sigma_v": 0.0}):
        conductor = mi.load_dict({"type": "conductor", "material": "Au"})
        pbrdf = mi.load_dict({"type": "pbrdf", "material": "Au", **given})
        assert pbrdf.flags() == conductor.flags()
        assert pbrdf.component_count() == 1
        for a, b in rows:
            si, w = make_si(a), to_vector(b)
            s1, s2 = random_numbers(len(np.atleast_2d(a)), seed=8)
            for mode in MODES:
                ctx = mi.BSDFContext(mode)
                bs_c, w_c = conductor.sample(ctx, si, s1, s2)
                bs_p, w_p = pbrdf.sample(ctx, si, s1, s2)
                assert_close_mueller(as_numpy(w_c), as_numpy(w_p))
                np.testing.assert_array_equal(np.array(bs_p.wo), np.array(bs_c.wo))
                pdf_p, pdf_c = np.array(bs_p.pdf), np.array(bs_c.pdf)   # conductor's: a literal 1
                np.testing.assert_array_equal(pdf_p, np.broadcast_to(pdf_c, pdf_p.shape))
                assert np.all(np.array(bs_p.sampled_type) & int(mi.BSDFFlags.DeltaReflection))
                np.testing.assert_array_equal(np.array(bs_p.sampled_component), 0)
                for got in (pbrdf.eval(ctx, si, w), pbrdf.pdf(ctx, si, w),
                            *pbrdf.eval_pdf(ctx, si, w)):
                    assert not np.any(as_numpy(got))


def test_a_mirror_beside_diffuse_lobes_is_one_choice_of_the_mixture():
    """sigma = 0 with kdd and kid: each sample is the mirror direction (type
    DeltaReflection, pdf = its selection probability P, weight = ks F / P, F
    conductor's matrix) or a diffuse one (weight = eval / pdf, and pdf =
    the non-delta lobes' mixture density, summing with P to 1). The delta is
    chosen with probability P (binomial, 5 sigma), and the mean weight M00 is
    ks F + kdd a_dd + kid, the albedo (a_dd: the dd lobe alone's mean weight)."""
    n = 50_000
    cos_i = 0.6
    wi = np.tile([math.sqrt(1 - cos_i ** 2), 0.0, cos_i], (n, 1))
    si, ctx = make_si(wi), mi.BSDFContext()
    s1, s2 = random_numbers(n, seed=9)
    mixed = mi.load_dict({"type": "pbrdf", **IOR, "sigma": 0.0, "ks": 0.7, "kdd": 0.2,
                          "sigma_dd": 0.3, "kid": 0.1})
    mirror = mi.load_dict({"type": "conductor", **IOR})
    bs, w = mixed.sample(ctx, si, s1, s2)
    w = as_numpy(w)
    delta = (np.array(bs.sampled_type) & int(mi.BSDFFlags.DeltaReflection)) != 0
    P = float(np.array(bs.pdf)[delta][0])
    np.testing.assert_allclose(np.array(bs.pdf)[delta], P, rtol=1e-6)
    assert abs(delta.mean() - P) < 5 * math.sqrt(P * (1 - P) / n)
    fresnel = as_numpy(mirror.sample(ctx, make_si(wi[:1]), *random_numbers(1, 0))[1])[0]
    assert_close_mueller(np.broadcast_to(0.7 * fresnel / P, w[delta].shape), w[delta])

    wo = to_vector(np.array(bs.wo).T[~delta])
    si_rest = make_si(wi[~delta])
    value, pdf = (as_numpy(x) for x in mixed.eval_pdf(ctx, si_rest, wo))
    np.testing.assert_allclose(np.array(bs.pdf)[~delta], pdf, rtol=1e-5)
    found = pdf > 0   # a dd sample below the horizon has neither
    assert found.mean() > 0.9 and not np.any(w[~delta][~found])
    assert_close_mueller(value[found] / pdf[found, None, None, None], w[~delta][found])
    # the non-delta density integrates to 1 - P: pdf / P_rest is the rough lobes' own mixture
    rough = mi.load_dict({"type": "pbrdf", **IOR, "ks": 0.0, "kdd": 0.2, "sigma_dd": 0.3,
                          "kid": 0.1})
    np.testing.assert_allclose(pdf, (1 - P) * as_numpy(rough.pdf(ctx, si_rest, wo)), rtol=1e-5)

    dd_alone = mi.load_dict({"type": "pbrdf", **IOR, "ks": 0.0, "kdd": 1.0, "sigma_dd": 0.3})
    a_dd = as_numpy(dd_alone.sample(ctx, si, s1, s2)[1])[:, :, 0, 0].mean(axis=0)
    expected = 0.7 * fresnel[:, 0, 0] + 0.2 * a_dd + 0.1
    m00 = w[:, :, 0, 0]
    error = m00.std(axis=0) / math.sqrt(n)
    assert np.all(np.abs(m00.mean(axis=0) - expected) < 5 * error + 1e-6), \
        (m00.mean(axis=0), expected, error)


def scene(bsdf):
    """A mirror sphere over a checkered diffuse floor, under a constant sky and
    a point light, seen by a 32x24 camera (4 spp)."""
    path = {"type": "path", "max_depth": 4}
    return {"type": "scene",
            "integrator": {"type": "stokes", "nested": path} if mi.is_polarized else path,
            "sensor": {"type": "perspective", "fov": 45,
                       "to_world": mi.ScalarTransform4f().look_at(origin=[0, -4, 1.5],
                                                                  target=[0, 0, 0.3],
                                                                  up=[0, 0, 1]),
                       "film": {"type": "hdrfilm", "width": 32, "height": 24,
                                "pixel_format": "rgb"},
                       "sampler": {"type": "independent", "sample_count": 4}},
            "sphere": {"type": "sphere", "center": [0, 0, 1], "radius": 1.0, "bsdf": bsdf},
            "floor": {"type": "rectangle", "to_world": mi.ScalarTransform4f().scale([5, 5, 1]),
                      "bsdf": {"type": "diffuse", "reflectance": {
                          "type": "checkerboard", "color0": 0.1, "color1": 0.7,
                          "to_uv": mi.ScalarTransform4f().scale([6, 6, 1])}}},
            "sky": {"type": "constant", "radiance": 0.5},
            "light": {"type": "point", "position": [3, -3, 4], "intensity": 40.0}}


def render_tiles(bsdf, seed=1):
    return tile_means(mi.render(mi.load_dict(scene(bsdf)), seed=seed))


@pytest.mark.parametrize("variant", ["llvm_ad_spectral_polarized", "llvm_ad_rgb"], indirect=True)
def test_mirror_sphere_renders_as_conductor(variant):
    """All channels (R, G, B and S0..S3 in polarized variants) at matched seed."""
    expected = render_tiles({"type": "conductor", **IOR})
    got = render_tiles({"type": "pbrdf", **IOR, "alpha": 0.0})
    scale = expected[..., slice(3, 6) if mi.is_polarized else slice(0, 3)].mean()
    if mi.is_polarized:   # the sphere polarizes: S1, S2 are well above rounding
        assert np.abs(expected[..., 6:12]).max() > 0.01 * scale
    assert np.abs(got - expected).max() <= MATCHED * scale


def test_gradients_by_eta_and_k_match_finite_differences():
    """d/d eta and d/d k of the mirror's sample weight (every Mueller element,
    every wavelength): forward-mode AD against central differences in float64
    of the float32 weight (step 1e-2: the weight is smooth in n and k; the
    truncation error, O(h^2) of the third derivative, stays below 1e-4 of
    the largest derivative here, measured)."""
    wi, _ = hemisphere_pairs(64, seed=11)
    si, ctx = make_si(wi), mi.BSDFContext()
    s1, s2 = random_numbers(len(wi), seed=12)
    for name in ("eta", "k"):
        bsdf = mi.load_dict({"type": "pbrdf", **IOR, "sigma": 0.0})
        params = mi.traverse(bsdf)
        key = f"{name}.value"
        dr.enable_grad(params[key])
        params.update()
        weight = bsdf.sample(ctx, si, s1, s2)[1]
        dr.forward(params[key])
        grad = as_numpy(dr.grad(weight))
        h = 1e-2

        def at(value):
            b = mi.load_dict({"type": "pbrdf", **dict(IOR, **{name: value}), "sigma": 0.0})
            return as_numpy(b.sample(ctx, si, s1, s2)[1])

        fd = (at(IOR[name] + h) - at(IOR[name] - h)) / (2 * h)
        assert np.abs(grad).max() > 0.01
        np.testing.assert_allclose(grad, fd, atol=2e-3 * np.abs(fd).max())


def test_the_smooth_lobe_exposes_no_width_and_is_refused_where_it_cannot_be():
    names = {k.split(".")[0] for k in mi.traverse(mi.load_dict(
        {"type": "pbrdf", "sigma": 0.0, "kid": 0.1})).keys()}
    assert names == {"eta", "k", "ks", "kid"}
    # zero along one axis only is no lobe; a cosine sampler would never find the delta
    for bad, message in (({"sigma_u": 0.0, "sigma_v": 0.1}, "'sigma_u' is 0 .* 'sigma_v' is not"),
                         ({"alpha_v": 0.0, "alpha_u": 0.1}, "'alpha_v' is 0 .* 'alpha_u' is not"),
                         ({"sigma": 0.0, "sampling": "cosine"}, "'sampling' is 'cosine'")):
        with pytest.raises(RuntimeError, match=message):
            mi.load_dict({"type": "pbrdf", **bad})
    assert schema.parameter("sigma").bound_doc.startswith("0 (smooth")


@pytest.mark.slow
@pytest.mark.parametrize("variant", ["llvm_ad_rgb"], indirect=True)
def test_rendered_gradient_by_eta_is_conductors(variant):
    """Reverse-mode d/d eta of the mirror-sphere render's sum, through ``path``:
    the same as Mitsuba's conductor to float32 rounding (measured 1.4e-6
    relative). Both are 1.7 % below central differences of the render (-63.36
    against -64.46): ``path``'s own AD, not the BSDF's (MODEL.md: ``path`` is no
    safe gradient oracle), hence the comparison with conductor."""
    def gradient(bsdf):
        scene_ = mi.load_dict(scene(bsdf))
        params = mi.traverse(scene_)
        key = "sphere.bsdf.eta.value"
        dr.enable_grad(params[key])
        params.update()
        image = mi.render(scene_, params, seed=1)
        dr.backward(dr.sum(image, axis=None))
        return float(np.array(dr.grad(params[key]))[0])

    expected = gradient({"type": "conductor", **IOR})
    got = gradient({"type": "pbrdf", **IOR, "sigma": 0.0})
    assert abs(expected) > 1.0
    assert got == pytest.approx(expected, rel=1e-4)
