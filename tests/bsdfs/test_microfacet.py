"""The plugin's anisotropic and GGX lobes: against the float64 reference
(written from the slope densities, not from Mitsuba's code), against
Mitsuba's ``roughconductor`` with ``alpha_u``/``alpha_v``, Mitsuba's
chi-square test of sampling, the parameters' traverse behaviour and checks,
and finite values at extreme anisotropy and roughness."""

import math
import zlib

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest

from bsdf_harness import WAVELENGTHS, as_numpy, chi2_sampling_test, hemisphere_pairs, make_si, sample_both, to_vector
from mitsuba_pbrdf import frames as mf
from mitsuba_pbrdf import reference as ref
from proof.bad_input import NAN, bitmap
from proof.mitsuba_g1 import mitsuba_beckmann_G1

SQRT2 = math.sqrt(2.0)
MODES = [mi.TransportMode.Radiance, mi.TransportMode.Importance]

# ---------------------------------------------------------------- reference

CONFIGS = {
    "Al-beckmann-vgroove-10x": dict(material="Al", sigma_u=0.5, sigma_v=0.05),
    "Cu-beckmann-smith": dict(material="Cu", sigma_u=0.08, sigma_v=0.3, shadowing="smith",
                              kdd=0.2, sigma_dd_u=0.7, sigma_dd_v=0.3, kid=0.05),
    "Au-ggx-vgroove": dict(material="Au", sigma=0.2, sigma_v=0.02, distribution="ggx",
                           kdd=0.3, sigma_dd=0.5, dd_distribution="ggx"),
    "Ag-ggx-smith-tenth": dict(material="Ag", sigma_u=0.04, sigma_v=0.4, distribution="ggx",
                               shadowing="smith"),
}


def reference_matrix(c, wi_hat, wo_hat):
    """The reference's BRDF (n, 4 wavelengths, 4, 4) at Mitsuba's directions
    (wo_hat: to the light), with the plugin's float32 widths. For Smith G of
    a Beckmann lobe the plugin, like roughconductor, evaluates Mitsuba's
    rational approximation of G1 (< 0.35 % off), so the reference's exact G1
    is swapped for it, with the width projected on each direction's azimuth."""
    c = dict(dict(sigma=0.1, ks=1.0, kdd=0.0, sigma_dd=0.5, kid=0.0, shadowing="vgroove",
                  dd_distribution="beckmann", distribution="beckmann"), **c)
    n, k = ref.conductor_ior(c["material"], WAVELENGTHS)
    ti, pi_ = mf.to_angles(wo_hat)
    tr, pr = mf.to_angles(wi_hat)
    angles = tuple(a[:, None] for a in (ti, pi_, tr, pr))
    f32 = lambda name, base: np.float32(c.get(name, c[base]))

    def smith_correction(u, v, distribution):
        if c["shadowing"] != "smith" or distribution != "beckmann":
            return np.ones((len(ti), 1))
        ratio = 1.0
        for theta, phi in ((ti, pi_), (tr, pr)):
            alpha = ref.projected_alpha(phi, SQRT2 * u, SQRT2 * v)
            ratio = ratio * mitsuba_beckmann_G1(np.cos(theta), alpha) / ref.smith_G1(
                np.cos(theta), alpha)
        return ratio[:, None]

    u, v = f32("sigma_u", "sigma"), f32("sigma_v", "sigma")
    F = c["ks"] * ref.specular(*angles, n, k, 0.1, c["shadowing"], c["distribution"], u, v) \
        * smith_correction(u, v, c["distribution"])[..., None, None]
    du, dv = f32("sigma_dd_u", "sigma_dd"), f32("sigma_dd_v", "sigma_dd")
    fdd = ref.directional_diffuse(*angles, 0.5, c["shadowing"], c["dd_distribution"], du, dv) \
        * smith_correction(du, dv, c["dd_distribution"])
    F[..., 0, 0] += c["kdd"] * fdd + c["kid"] * ref.ideal_diffuse(*angles[0::2])
    return F


@pytest.mark.parametrize("mode", ["radiance", "importance"])
@pytest.mark.parametrize("name", sorted(CONFIGS))
def test_anisotropic_plugin_matches_reference(name, mode):
    """Tolerance as tests/bsdfs/test_pbrdf_vs_reference.py: 1e-4 M00 per element plus
    the lane's underflow floor (Mitsuba's D cos(theta_h) < 1e-20 cut-off);
    measured worst: 3.5e-5 M00."""
    config = CONFIGS[name]
    bsdf = mi.load_dict(dict({"type": "pbrdf"}, **config))
    rng = np.random.default_rng(zlib.crc32(f"{name}/{mode}".encode()))
    wi_hat, wo_hat = mf.random_directions(10_000, rng)
    M = mf.eval_global(bsdf, wi_hat, wo_hat, WAVELENGTHS, mode)
    R = reference_matrix(config, wi_hat, wo_hat)
    assert np.all(np.isfinite(M))
    h = wi_hat + wo_hat
    cos_h = h[:, 2] / np.linalg.norm(h, axis=1)
    weight = config.get("ks", 1.0) + config.get("kdd", 0.0)
    floor = weight * 1e-20 / (4 * np.maximum(cos_h, 1e-30) * wi_hat[:, 2] * wo_hat[:, 2])
    m00 = R[..., :1, :1]
    bad = np.abs(M - R) > 1e-4 * m00 + floor[:, None, None, None]
    assert not bad.any(), f"{bad.sum()} elements off, first at {np.argwhere(bad)[0]}"
    # the lobe is exercised: a good share of the pairs reflect something
    assert np.mean(R[..., 0, 0] > 1e-2) > 0.2


# ------------------------------------------------------------ roughconductor


def pair(material, alpha_u, alpha_v, distribution):
    rc = mi.load_dict({"type": "roughconductor", "material": material, "alpha_u": alpha_u,
                       "alpha_v": alpha_v, "distribution": distribution})
    pb = mi.load_dict({"type": "pbrdf", "material": material, "sigma_u": alpha_u / SQRT2,
                       "sigma_v": alpha_v / SQRT2, "distribution": distribution,
                       "shadowing": "smith"})
    return rc, pb


def g1_correction(wi, alpha_u, alpha_v):
    """Exact over Mitsuba's rational Beckmann G1 at wi, with the projected width."""
    wi = np.asarray(wi, dtype=np.float64)
    alpha = ref.projected_alpha(np.arctan2(wi[:, 1], wi[:, 0]), alpha_u, alpha_v)
    return ref.smith_G1(wi[:, 2], alpha) / mitsuba_beckmann_G1(wi[:, 2], alpha)


@pytest.mark.parametrize("distribution", ["beckmann", "ggx"])
@pytest.mark.parametrize("alphas", [(0.05, 0.5), (0.6, 0.06), (0.3, 0.2)])
def test_eval_and_pdf_match_roughconductor(distribution, alphas):
    """No diffuse lobes and Smith G: pbrdf is roughconductor with alpha_u,
    alpha_v. Mueller matrices within 1e-5 M00 (tests/bsdfs/test_pbrdf_roughconductor.py:
    float32 level); pdfs equal within 1e-5 for GGX, and for Beckmann after
    the exact/approximate G1 ratio of roughconductor's pdf."""
    wi, wo = hemisphere_pairs(12000, seed=21)
    si, w = make_si(wi), to_vector(wo)
    rc, pb = pair("Cu", *alphas, distribution)
    a_u, a_v = (np.float32(a) for a in alphas)
    for mode in MODES:
        ctx = mi.BSDFContext(mode)
        expected = as_numpy(rc.eval(ctx, si, w))
        value, pdf = (as_numpy(x) for x in pb.eval_pdf(ctx, si, w))
        m00 = np.abs(expected[..., :1, :1])
        assert np.all(np.abs(value - expected) <= 1e-5 * m00 + 1e-30)
        assert np.mean(m00[..., 0, 0] > 1e-2) > 0.2
        expected_pdf = as_numpy(rc.pdf(ctx, si, w))
        if distribution == "beckmann":
            expected_pdf = expected_pdf * g1_correction(wi, a_u, a_v)
        np.testing.assert_allclose(pdf, expected_pdf, rtol=1e-5, atol=0)


@pytest.mark.parametrize("distribution", ["beckmann", "ggx"])
def test_sample_matches_roughconductor(distribution):
    """Same visible-normal sampler: same directions, same pdf (through the G1
    ratio for Beckmann), same Mueller weight (roughconductor's F G1(wo) and our
    eval/pdf agree to float32, with 1e-6/cos_o near the horizon as in
    tests/bsdfs/test_pbrdf_roughconductor.py)."""
    rc, pb = pair("Al", 0.6, 0.06, distribution)
    wi, _ = hemisphere_pairs(5000, seed=22)
    rng = np.random.default_rng(23)
    bs_rc, w_rc, bs_pb, w_pb = sample_both(rc, pb, wi, rng)
    valid = as_numpy(bs_rc.wo)[:, 2] > 1e-4
    assert valid.mean() > 0.7
    np.testing.assert_allclose(as_numpy(bs_pb.wo)[valid], as_numpy(bs_rc.wo)[valid], atol=2e-6)
    correction = (g1_correction(wi, np.float32(0.6), np.float32(0.06))
                  if distribution == "beckmann" else np.ones(len(wi)))
    np.testing.assert_allclose(as_numpy(bs_pb.pdf)[valid],
                               (as_numpy(bs_rc.pdf) * correction)[valid], rtol=1e-4)
    w_rc, w_pb = as_numpy(w_rc) / correction[:, None, None, None], as_numpy(w_pb)
    m00 = np.abs(w_rc[..., 0, 0, None, None])
    cos_o = as_numpy(bs_rc.wo)[:, 2, None, None, None]
    tol = (1e-5 + 1e-6 / np.maximum(cos_o, 1e-30)) * m00 + 1e-7
    assert np.all((np.abs(w_pb - w_rc) <= tol)[valid])


# --------------------------------------------------------------- chi-square

CHI2 = {
    "beckmann-10x": ({"type": "pbrdf", "material": "Al", "sigma_u": 0.5, "sigma_v": 0.05},
                     (0.55, 0.25, 0.79686887)),
    "ggx-tenth-smith": ({"type": "pbrdf", "material": "Cu", "sigma_u": 0.03, "sigma_v": 0.3,
                         "distribution": "ggx", "shadowing": "smith"}, (-0.3, 0.6, 0.74161985)),
    "mixture-anisotropic-dd": ({"type": "pbrdf", "material": "Au", "sigma_u": 0.3,
                                "sigma_v": 0.03, "kdd": 0.4, "sigma_dd_u": 0.2,
                                "sigma_dd_v": 0.8, "kid": 0.1}, (0.2, -0.5, 0.84261498)),
}


@pytest.mark.parametrize("name", sorted(CHI2))
def test_anisotropic_sampling_passes_chi_square(name):
    """Mitsuba's chi-square test through the project's polarized adapter
    (bsdf_harness.chi2_sampling_test), in the suite's family of chi-square tests
    (bsdf_harness.CHI2_TESTS). Oblique wi off both axes (anisotropy seen
    obliquely), 300,000 samples."""
    config, wi = CHI2[name]
    test = chi2_sampling_test(config, wi, 300_000)
    assert test.passed, test.messages


# ------------------------------------------------------- traverse and checks


def test_isotropic_scenes_expose_sigma_and_anisotropic_ones_its_refinements():
    iso = {key.split(".")[0] for key in mi.traverse(mi.load_dict({"type": "pbrdf"})).keys()}
    assert "sigma" in iso and not iso & {"sigma_u", "sigma_v"}
    bsdf = mi.load_dict({"type": "pbrdf", "sigma": 0.2, "sigma_u": 0.4, "kdd": 0.1})
    names = {key.split(".")[0] for key in mi.traverse(bsdf).keys()}
    assert {"sigma_u", "sigma_v", "sigma_dd"} <= names and not names & {"sigma", "sigma_dd_u"}
    assert bsdf.sigma_v.texture is bsdf.sigma.texture  # sigma gives the width not given


@pytest.mark.parametrize("props, anisotropic", [
    ({}, (False, False)),
    ({"sigma_u": 0.3}, (True, False)),
    ({"sigma_dd_v": 0.2}, (False, True)),
    ({"sigma_u": 0.1, "sigma_v": 0.1, "sigma_dd_u": 0.4}, (True, True)),
])
def test_anisotropic_flag_marks_the_anisotropic_lobes(props, anisotropic):
    """BSDFFlags.Anisotropic is set on each lobe given refined widths and on
    the BSDF where any is (roughconductor sets it where alpha_u != alpha_v;
    here the lobe is anisotropic as declared, even with equal widths), never
    on the Lambertian lobe."""
    bsdf = mi.load_dict({"type": "pbrdf", "kdd": 0.1, "kid": 0.1, **props})
    flag = mi.BSDFFlags.Anisotropic
    got = tuple(bool(bsdf.flags(i) & flag) for i in range(3))
    assert got == anisotropic + (False,)
    assert bool(bsdf.flags() & flag) == any(anisotropic)


def test_updating_sigma_u_changes_the_lobe_as_loading_it_does():
    """An update through traverse gives the BSDF loaded with that value."""
    wi, wo = hemisphere_pairs(2000, seed=24)
    si, w, ctx = make_si(wi), to_vector(wo), mi.BSDFContext()
    bsdf = mi.load_dict({"type": "pbrdf", "sigma_u": 0.1, "sigma_v": 0.3})
    params = mi.traverse(bsdf)
    params["sigma_u.value"] = 0.45
    params.update()
    loaded = mi.load_dict({"type": "pbrdf", "sigma_u": 0.45, "sigma_v": 0.3})
    np.testing.assert_array_equal(as_numpy(bsdf.eval(ctx, si, w)), as_numpy(loaded.eval(ctx, si, w)))
    for bad in (-0.1, NAN, 0.0):
        params["sigma_v.value"] = bad
        with pytest.raises(ValueError, match="'sigma_v'"):
            params.update()
        params["sigma_v.value"] = 0.3


@pytest.mark.parametrize("name", ["sigma_u", "sigma_v", "sigma_dd_u", "sigma_dd_v"])
def test_bad_texels_of_a_width_texture_are_rejected(name):
    for value in (NAN, -0.2, 0.0):
        with pytest.raises(RuntimeError, match=f"parameter '{name}'"):
            mi.load_dict({"type": "pbrdf", "kdd": 0.1, name: bitmap(value)})
    mi.load_dict({"type": "pbrdf", "kdd": 0.1, name: bitmap(0.3)})


def test_equal_widths_are_the_isotropic_lobe():
    """sigma_u = sigma_v = sigma goes through the anisotropic code path and
    gives the isotropic values to float32 rounding (1e-5 M00)."""
    wi, wo = hemisphere_pairs(5000, seed=25)
    si, w, ctx = make_si(wi), to_vector(wo), mi.BSDFContext()
    for extra in ({}, {"shadowing": "smith"}, {"distribution": "ggx", "shadowing": "smith"}):
        iso = mi.load_dict(dict({"type": "pbrdf", "sigma": 0.2, "kdd": 0.2, "sigma_dd": 0.4},
                                **extra))
        aniso = mi.load_dict(dict({"type": "pbrdf", "sigma_u": 0.2, "sigma_v": 0.2, "kdd": 0.2,
                                   "sigma_dd_u": 0.4, "sigma_dd_v": 0.4}, **extra))
        a, pa = (as_numpy(x) for x in iso.eval_pdf(ctx, si, w))
        b, pb = (as_numpy(x) for x in aniso.eval_pdf(ctx, si, w))
        assert np.all(np.abs(b - a) <= 1e-5 * np.abs(a[..., :1, :1]) + 1e-30)
        np.testing.assert_allclose(pb, pa, rtol=1e-5)


# ------------------------------------------------------------- robustness


@pytest.mark.parametrize("widths", [(1e-4, 1e-3), (0.5, 0.05), (50.0, 5.0), (1e-4, 1.0)])
@pytest.mark.parametrize("distribution", ["beckmann", "ggx"])
@pytest.mark.slow
def test_extreme_anisotropy_and_roughness_give_finite_values(widths, distribution):
    """eval, pdf and sample at grazing, normal and random directions: finite,
    M00 >= 0, pdf >= 0, and DoP <= 1 (+1e-5 float32)."""
    wi, wo = hemisphere_pairs(4000, seed=26, min_cos=1e-6)
    grazing = np.array([[np.sqrt(1 - 1e-12), 0.0, 1e-6], [0.0, np.sqrt(1 - 1e-12), 1e-6],
                        [0.0, 0.0, 1.0]])
    wi, wo = np.concatenate([wi, grazing, grazing]), np.concatenate([wo, grazing[::-1], grazing])
    bsdf = mi.load_dict({"type": "pbrdf", "sigma_u": widths[0], "sigma_v": widths[1],
                         "distribution": distribution, "shadowing": "smith", "kdd": 0.1,
                         "sigma_dd_u": widths[1], "sigma_dd_v": widths[0]})
    si, ctx = make_si(wi), mi.BSDFContext()
    value, pdf = (as_numpy(x) for x in bsdf.eval_pdf(ctx, si, to_vector(wo)))
    rng = np.random.default_rng(27)
    bs, weight = bsdf.sample(ctx, si, mi.Float(rng.random(len(wi)).astype(np.float32)),
                             mi.Point2f(*rng.random((2, len(wi))).astype(np.float32)))
    for x in (value, pdf, as_numpy(weight), as_numpy(bs.pdf)):
        assert np.all(np.isfinite(x))
    assert np.all(pdf >= 0) and np.all(value[..., 0, 0] >= 0)
    m00 = value[..., 0, 0]
    dop = np.linalg.norm(value[..., 1:, 0], axis=-1)
    assert np.all(dop <= (1 + 1e-5) * m00 + 1e-30)


@pytest.mark.parametrize("extra", [{}, {"distribution": "ggx", "shadowing": "smith"}])
def test_forward_derivatives_by_sigma_u_and_sigma_v_match_the_reference(extra):
    """d M00 / d sigma_u and d sigma_v by Dr.Jit's forward mode through
    traverse, against central differences of the float64 reference (step
    1e-5: truncation ~1e-10, rounding ~1e-11 relative). Tolerance 2e-4 of the
    largest derivative plus 1e-3 relative: float32 evaluation of the
    exponent, amplified as in the value comparison (1e-4 M00)."""
    config = dict({"material": "Cu", "sigma_u": 0.25, "sigma_v": 0.08}, **extra)
    bsdf = mi.load_dict(dict({"type": "pbrdf"}, **config))
    params = mi.traverse(bsdf)
    wi, wo = hemisphere_pairs(3000, seed=28)
    n, k = ref.conductor_ior("Cu", WAVELENGTHS)
    ti, pi_ = mf.to_angles(wo)
    tr, pr = mf.to_angles(wi)
    angles = tuple(a[:, None] for a in (ti, pi_, tr, pr))
    shadowing = config.get("shadowing", "vgroove")
    distribution = config.get("distribution", "beckmann")

    def reference_m00(u, v):
        return ref.specular(*angles, n, k, 0.1, shadowing, distribution, u, v)[..., 0, 0]

    for name in ("sigma_u", "sigma_v"):
        key = name + ".value"
        dr.enable_grad(params[key])
        params.update()
        si = make_si(wi)
        value = bsdf.eval(mi.BSDFContext(), si, to_vector(wo))
        dr.forward(params[key])
        grad = as_numpy(dr.grad(value))[..., 0, 0] / wo[:, 2:3]     # eval includes cos_o
        dr.disable_grad(params[key])
        params.update()
        u, v, h = np.float32(0.25), np.float32(0.08), 1e-5
        step = (h, 0.0) if name == "sigma_u" else (0.0, h)
        expected = (reference_m00(u + step[0], v + step[1])
                    - reference_m00(u - step[0], v - step[1])) / (2 * h)
        scale = np.abs(expected).max()
        assert scale > 1.0
        assert np.all(np.abs(grad - expected) <= 2e-4 * scale + 1e-3 * np.abs(expected)), name
