"""Sampling strategies: the cosine-only baseline that benchmarks compare
against, and a context that selects no lobe."""

import mitsuba as mi
import numpy as np
import pytest

from bsdf_harness import WAVELENGTHS, as_numpy, chi2_sampling_test, hemisphere_pairs, make_si
from proof.conditioning import lane_parameters, reference_brdf
from mitsuba_pbrdf.diagnostics.realizability import U32
from tests.bsdfs.test_mixture_sampling import to_global

COSINE = {"type": "pbrdf", "material": "Cu", "sigma": 0.15, "kdd": 0.3, "kid": 0.2,
          "sampling": "cosine"}


def test_cosine_sampling_distribution_matches_pdf():
    """Chi-square goodness of fit, 200,000 samples; significance 1 % for the
    family of the suite's chi-square tests (bsdf_harness.CHI2_TESTS)."""
    test = chi2_sampling_test(COSINE, (0.5, 0.0, 0.8660254), 200_000)
    assert test.passed, test.messages


def test_the_chi_square_family_counts_every_chi_square_test():
    """bsdf_harness.CHI2_TESTS, the family size of the Sidak correction, is the
    number of chi-square tests the parametrizations make: test_pbrdf's configs
    x angles, this file's one, test_microfacet's cases."""
    from bsdf_harness import CHI2_TESTS
    from tests.bsdfs import test_microfacet, test_pbrdf

    made = len(test_pbrdf.CONFIGS) * len(test_pbrdf.CHI2_ANGLES) + 1 + len(test_microfacet.CHI2)
    assert CHI2_TESTS == made


@pytest.mark.parametrize("mode", [mi.TransportMode.Radiance, mi.TransportMode.Importance])
def test_cosine_sampling_weight_and_pdf(mode):
    """pdf = cos(theta_o)/pi and weight = R cos(theta_o) / pdf = pi R, element
    by element, R the float64 reference in the global s/p frames (not the
    plugin's own eval). Tolerance 1e-4 of W00: the accuracy test's float32
    bound (tests/bsdfs/test_pbrdf_vs_reference.py), lanes where the float32 Beckmann
    D is cut off (R00 < 1e-18 /sr, Mitsuba's D cos < 1e-20) excepted."""
    bsdf = mi.load_dict(COSINE)
    wi, _ = hemisphere_pairs(5000, seed=12)
    si, ctx = make_si(wi), mi.BSDFContext(mode)
    rng = np.random.default_rng(13)
    bs, weight = bsdf.sample(ctx, si, mi.Float(rng.random(len(wi)).astype(np.float32)),
                             mi.Point2f(*rng.random((2, len(wi))).astype(np.float32)))
    wo = as_numpy(bs.wo)
    pdf = as_numpy(bs.pdf)
    valid = pdf > 0
    np.testing.assert_allclose(pdf[valid], wo[valid, 2] / np.pi, rtol=1e-6)
    np.testing.assert_allclose(as_numpy(bsdf.pdf(ctx, si, bs.wo))[valid], pdf[valid], rtol=1e-6)
    config = dict(COSINE, ks=1.0, sigma_dd=0.5, shadowing="vgroove", dd_distribution="beckmann")
    si_wi = np.asarray(si.wi, dtype=np.float64).T[valid]
    to_viewer, to_light = ((si_wi, wo[valid]) if mode == mi.TransportMode.Radiance
                           else (wo[valid], si_wi))
    R = reference_brdf(config, lane_parameters(config, WAVELENGTHS, {}, len(si_wi)),
                       to_viewer, to_light)
    expected = np.pi * R
    got = as_numpy(to_global(weight, si.wi, bs.wo, mode))[valid]
    m00 = expected[..., :1, :1]
    assert np.all(np.abs(got - expected) <= 1e-4 * m00 + 1e-18 * np.pi)
    assert np.mean(m00 > 1e-3) > 0.5


def test_a_context_selecting_no_lobe_gives_zero():
    bsdf = mi.load_dict({"type": "pbrdf", "kid": 0.3})
    ctx = mi.BSDFContext()
    ctx.type_mask = int(mi.BSDFFlags.DeltaReflection)  # pbrdf has no delta lobe
    wi, wo = hemisphere_pairs(100, seed=14)
    si = make_si(wi)
    bs, weight = bsdf.sample(ctx, si, mi.Float(np.full(len(wi), 0.5)),
                             mi.Point2f(np.full(len(wi), 0.3), np.full(len(wi), 0.7)))
    assert np.all(as_numpy(weight) == 0) and np.all(as_numpy(bs.pdf) == 0)
    value, pdf = bsdf.eval_pdf(ctx, si, mi.Vector3f(*wo.T.astype(np.float32)))
    assert np.all(as_numpy(value) == 0) and np.all(as_numpy(pdf) == 0)


SINGLE_LOBES = {
    "ideal diffuse only": {"type": "pbrdf", "ks": 0.0, "kid": 0.7},
    "directional diffuse only": {"type": "pbrdf", "ks": 0.0, "kdd": 0.6, "sigma_dd": 0.4},
    "specular only, vgroove": {"type": "pbrdf", "material": "Au", "sigma": 0.3},
    "specular only, smith": {"type": "pbrdf", "material": "Au", "sigma": 0.3, "shadowing": "smith"},
}


@pytest.mark.parametrize("name", sorted(SINGLE_LOBES))
def test_single_lobe_closed_form_weight_is_eval_over_pdf(name):
    """With one lobe, sample() returns a closed-form weight (D cancels); it
    must equal eval(wo)/pdf(wo). The sampled facet normal m and the recomputed
    half vector differ by float32 ulps (amplified by the Beckmann exponent,
    2e-5), and near the horizon G depends on cos(theta_o) (+1e-6/cos_o)."""
    bsdf = mi.load_dict(SINGLE_LOBES[name])
    wi, _ = hemisphere_pairs(20000, seed=15)
    si, ctx = make_si(wi), mi.BSDFContext()
    rng = np.random.default_rng(16)
    bs, weight = bsdf.sample(ctx, si, mi.Float(rng.random(len(wi)).astype(np.float32)),
                             mi.Point2f(*rng.random((2, len(wi))).astype(np.float32)))
    value, pdf = (as_numpy(x) for x in bsdf.eval_pdf(ctx, si, bs.wo))
    bs_pdf, weight = as_numpy(bs.pdf), as_numpy(weight)
    valid = bs_pdf > 0
    assert valid.mean() > 0.5
    np.testing.assert_allclose(bs_pdf[valid], pdf[valid], rtol=2e-5)
    expected = value[valid] / pdf[valid, None, None, None]
    m00 = np.abs(expected[..., :1, :1])
    cos_o = as_numpy(bs.wo)[valid, 2, None, None, None]
    assert np.all(np.abs(weight[valid] - expected) <= (2e-5 + 1e-6 / cos_o) * m00 + 1e-12)


def test_ideal_diffuse_alone_has_constant_weight_kid():
    """Cosine sampling of a cosine lobe: every weight is exactly kid (white
    furnace of the Lambertian lobe, no noise)."""
    bsdf = mi.load_dict({"type": "pbrdf", "ks": 0.0, "kid": 0.7})
    wi, _ = hemisphere_pairs(2000, seed=17)
    rng = np.random.default_rng(18)
    _, weight = bsdf.sample(mi.BSDFContext(), make_si(wi), mi.Float(rng.random(len(wi)).astype(np.float32)),
                            mi.Point2f(*rng.random((2, len(wi))).astype(np.float32)))
    weight = as_numpy(weight)
    np.testing.assert_allclose(weight[..., 0, 0], 0.7, rtol=1e-6)
    assert np.all(weight[..., 1:, :] == 0) and np.all(weight[..., :, 1:] == 0)
