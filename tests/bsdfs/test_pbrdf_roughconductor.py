"""Reduced case: with kdd = kid = 0, shadowing="smith" and sigma = alpha/sqrt(2),
`pbrdf` is Mitsuba's `roughconductor` (distribution="beckmann").

Both plugins evaluate the same Beckmann D and Smith G (Mitsuba's
MicrofacetDistribution) and the same Mueller rotation; they differ only in how
the complex Fresnel amplitudes are computed (ours: a closed form vectorized over
wavelengths; Mitsuba's: dr::Complex arithmetic). Measured difference: at most
7.6e-7 * M00 per element (float32 ulp level). Tolerance: 1e-5 * M00 per element
(|M_ij| <= M00 for a physical Mueller matrix, so M00 sets the float32 scale),
i.e. about 80 ulps of headroom for a dozen float32 operations.

Sampling densities differ on purpose: Mitsuba samples Beckmann's visible normals
exactly, but its pdf uses a rational approximation of Smith's G1 (< 0.35 %
error), which biases roughconductor's sampling weights; pbrdf's pdf uses the
exact G1. pdf and weights are therefore compared after multiplying Mitsuba's by
G1_exact(wi) / G1_approx(wi) (resp. its inverse), evaluated in float64.
"""

import math

import mitsuba as mi
import numpy as np
import pytest

from bsdf_harness import as_numpy, hemisphere_pairs, make_si, sample_both, to_vector
from mitsuba_pbrdf import reference
from proof.mitsuba_g1 import mitsuba_beckmann_G1


def g1_correction(wi, alpha):
    """G1_exact / G1_approx of Mitsuba's Beckmann distribution at directions wi."""
    cos = np.asarray(wi, dtype=np.float64)[..., 2]
    return reference.smith_G1(cos, alpha) / mitsuba_beckmann_G1(cos, alpha)

VECTOR_VARIANTS = ["llvm_ad_spectral_polarized", "llvm_ad_mono_polarized",
                   "llvm_ad_rgb", "llvm_ad_spectral"]
MODES = [mi.TransportMode.Radiance, mi.TransportMode.Importance]
TOL = 1e-5


def pair(material, alpha):
    rc = mi.load_dict({"type": "roughconductor", "material": material, "alpha": alpha,
                       "distribution": "beckmann"})
    pb = mi.load_dict({"type": "pbrdf", "material": material, "sigma": alpha / math.sqrt(2),
                       "shadowing": "smith"})
    return rc, pb


def assert_close_mueller(expected, actual):
    expected, actual = np.asarray(expected), np.asarray(actual)
    assert np.all(np.isfinite(actual))
    m00 = expected[..., 0, 0, None, None] if mi.is_polarized else expected
    err = np.abs(actual - expected)
    assert np.all(err <= TOL * np.abs(m00) + 1e-30), \
        f"max error / M00 = {np.max(err / np.maximum(np.abs(m00), 1e-30)):.3g}"


@pytest.mark.parametrize("variant", VECTOR_VARIANTS, indirect=True)
@pytest.mark.parametrize("material", ["Al", "Cu", "Au"])
def test_eval_and_pdf_match_roughconductor(variant, material):
    wi, wo = hemisphere_pairs(12000, seed=1)
    si, w = make_si(wi), to_vector(wo)
    for alpha in (0.02, 0.2, 0.8):
        rc, pb = pair(material, alpha)
        for mode in MODES:
            ctx = mi.BSDFContext(mode)
            assert_close_mueller(as_numpy(rc.eval(ctx, si, w)), as_numpy(pb.eval(ctx, si, w)))
            value, pdf = pb.eval_pdf(ctx, si, w)
            assert_close_mueller(as_numpy(rc.eval(ctx, si, w)), as_numpy(value))
            expected_pdf = as_numpy(rc.pdf(ctx, si, w)) * g1_correction(wi, np.float32(alpha))
            for got in (as_numpy(pb.pdf(ctx, si, w)), as_numpy(pdf)):
                np.testing.assert_allclose(got, expected_pdf, rtol=1e-5, atol=0)


@pytest.mark.parametrize("variant", ["scalar_spectral_polarized"], indirect=True)
def test_scalar_variant_matches_roughconductor(variant):
    rc, pb = pair("Cu", 0.3)
    wi, wo = hemisphere_pairs(40, seed=2)
    for a, b in zip(wi, wo):
        si, w = make_si(a), to_vector(b)
        for mode in MODES:
            ctx = mi.BSDFContext(mode)
            assert_close_mueller(as_numpy(rc.eval(ctx, si, w)), as_numpy(pb.eval(ctx, si, w)))
            assert pb.pdf(ctx, si, w) == pytest.approx(
                rc.pdf(ctx, si, w) * g1_correction(a, np.float32(0.3)), rel=1e-5)


@pytest.mark.parametrize("variant", ["llvm_ad_spectral_polarized"], indirect=True)
def test_sample_matches_roughconductor(variant):
    """One lobe and the same visible-normal sampling: same directions, same
    pdf, same Mueller weight."""
    rc, pb = pair("Al", 0.25)
    n = 5000
    rng = np.random.default_rng(3)
    wi, _ = hemisphere_pairs(n, seed=4)
    bs_rc, w_rc, bs_pb, w_pb = sample_both(rc, pb, wi, rng)
    # roughconductor leaves bs.pdf set for directions below the horizon (its
    # weight is zero there); pbrdf zeroes both. Compare where the sample is valid.
    valid = as_numpy(bs_rc.wo)[:, 2] > 1e-4
    assert valid.mean() > 0.8
    assert np.all(as_numpy(bs_pb.pdf)[as_numpy(bs_pb.wo)[:, 2] <= 0] == 0)
    # reflect(wi, m) is rounded differently in C++ (fmsub) and Python: a few ulps.
    np.testing.assert_allclose(as_numpy(bs_pb.wo)[valid], as_numpy(bs_rc.wo)[valid], atol=2e-6)
    correction = g1_correction(wi, np.float32(0.25))
    np.testing.assert_allclose(as_numpy(bs_pb.pdf)[valid], (as_numpy(bs_rc.pdf) * correction)[valid],
                               rtol=1e-4)
    # roughconductor's weight is F * G1(wo); ours is eval/pdf: equal up to
    # float32 rounding, except within ~1e-2 of the horizon where G1(wo) depends
    # on cos(theta_o), whose float32 rounding (6e-8 absolute) the two sides
    # reach through different operations (relative error 6e-8/cos_o).
    w_rc, w_pb = as_numpy(w_rc) / correction[:, None, None, None], as_numpy(w_pb)
    m00 = np.abs(w_rc[..., 0, 0, None, None])
    cos_o = as_numpy(bs_rc.wo)[:, 2, None, None, None]
    tol = (1e-5 + 1e-6 / np.maximum(cos_o, 1e-30)) * m00 + 1e-7
    assert np.all((np.abs(w_pb - w_rc) <= tol)[valid])


def stokes_scene(bsdf):
    """A rough metal sphere in a uniform environment (one emitter: Mitsuba 3.9
    may order several emitters differently from one load to the next, which
    changes the noise of a same-seed render), rendered to Stokes channels."""
    return mi.load_dict({
        "type": "scene",
        "integrator": {"type": "stokes", "integrator": {"type": "path", "max_depth": 2}},
        "sensor": {
            "type": "perspective", "fov": 30,
            "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 4], target=[0, 0, 0], up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": 48, "height": 48, "pixel_format": "rgb"},
            "sampler": {"type": "independent"},
        },
        "sphere": {"type": "sphere", "bsdf": bsdf},
        "env": {"type": "constant", "radiance": 1.0},
    })


@pytest.mark.slow
def test_rendered_stokes_image_matches_roughconductor():
    """Same scene, same seed, one lobe with the same visible-normal sampling:
    the same paths. The weights differ only by roughconductor's approximate
    G1 in its pdf (<= 0.35 %, also through the MIS weights), so each Stokes
    component agrees within 4e-3 of the pixel's S0 (+1e-6 for float32)."""
    images = []
    for bsdf in ({"type": "roughconductor", "material": "Cu", "alpha": 0.2},
                 {"type": "pbrdf", "material": "Cu", "sigma": 0.2 / math.sqrt(2), "shadowing": "smith"}):
        images.append(np.array(mi.render(stokes_scene(bsdf), spp=16, seed=7)))
    expected, got = images
    s0 = expected[..., 3:6]
    assert np.all(np.isfinite(got))
    assert s0.mean() > 0.05  # the scene is lit
    dolp = np.hypot(expected[..., 6:9], expected[..., 9:12]) / np.maximum(s0, 1e-9)
    assert dolp.max() > 0.1  # and polarized
    scale = np.concatenate([s0] * 4, axis=-1)
    np.testing.assert_array_less(np.abs(got[..., 3:] - expected[..., 3:]), 4e-3 * scale + 1e-6)
