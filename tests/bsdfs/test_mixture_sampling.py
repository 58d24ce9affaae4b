"""Mixture sampling checked against quantities the test computes itself.

The plugin's docstring (mitsuba_pbrdf/bsdfs/pbrdf.py) documents the rule:
lobe l is picked with probability p_l proportional to its albedo estimate for
wi (ks times the unpolarized Fresnel reflectance at theta_i, kdd, kid; averaged
over the wavelengths), the specular and directional diffuse lobes are sampled
through their visible normals (density D(h) G1(wi) / (4 cos_i) of wo, exact
Smith G1), the ideal diffuse lobe by cosine sampling (cos_o / pi), and the
returned pdf is sum_l p_l pdf_l. Here p_l comes from the reference's Fresnel
amplitudes, pdf_l from the reference's D and exact G1, the value from the
float64 reference evaluator: none of them from the plugin's own code.
"""

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest
from scipy import stats

from bsdf_harness import WAVELENGTHS, as_numpy, hemisphere_pairs, make_si
from mitsuba_pbrdf import frames, use_variant
from mitsuba_pbrdf import reference as ref
from proof.conditioning import lane_parameters, reference_brdf, sensitivity
from mitsuba_pbrdf.diagnostics.realizability import U32

BASE = dict(ks=1.0, kdd=0.0, sigma=0.1, sigma_dd=0.5, kid=0.0, shadowing="vgroove",
            dd_distribution="beckmann")
CONFIGS = {
    "full-vgroove-Cu": dict(BASE, material="Cu", sigma=0.15, kdd=0.3, sigma_dd=0.6, kid=0.2),
    "full-smith-ggx-Au": dict(BASE, material="Au", sigma=0.15, kdd=0.3, sigma_dd=0.6, kid=0.2,
                              shadowing="smith", dd_distribution="ggx"),
    "specular-kid-smith-Al": dict(BASE, material="Al", sigma=0.3, kid=0.4, shadowing="smith"),
    "specular-dd-dielectric": dict(BASE, eta=1.5, k=0.0, sigma=0.08, kdd=0.05, sigma_dd=0.3),
    "specular-only-Al": dict(BASE, material="Al", sigma=0.2),
    "dd-only-ggx": dict(BASE, material="Al", ks=0.0, kdd=1.0, sigma_dd=0.3, dd_distribution="ggx"),
    "near-mirror": dict(BASE, material="Cu", sigma=0.003, kdd=0.3, sigma_dd=0.05, kid=0.2),
    "very-rough": dict(BASE, material="Cu", sigma=2.0, kdd=0.3, sigma_dd=5.0, kid=0.2),
}
#: Mitsuba's microfacet distributions return D = 0 where D cos(theta_h) < 1e-20
#: (microfacet.h: "prevent potential numerical issues"): the absolute floor
#: of every comparison with a microfacet lobe's value or pdf.
D_CUTOFF = 1e-20
LOBES = (("specular", "ks", "sigma"), ("directional_diffuse", "kdd", "sigma_dd"),
         ("ideal_diffuse", "kid", None))


def load(config):
    return mi.load_dict(dict({"type": "pbrdf"}, **config))


def ior(config):
    """(n, k) at the test wavelengths, shape (4,) each."""
    if "material" in config:
        return ref.conductor_ior(config["material"], WAVELENGTHS)
    return np.full(4, float(config["eta"])), np.full(4, float(config["k"]))


def present_lobes(config):
    return [lobe for lobe in LOBES if config[lobe[1]] != 0]


def documented_probabilities(config, cos_i):
    """p_l (m, number of lobes present): the albedo estimate of each lobe for
    wi, normalized; ks times the unpolarized Fresnel reflectance (|r_s|^2 +
    |r_p|^2) / 2 at theta_i averaged over the wavelengths, kdd, kid."""
    n, k = ior(config)
    r_s, r_p = ref.fresnel_amplitudes(cos_i[:, None], n, k)
    fresnel = np.mean((abs(r_s) ** 2 + abs(r_p) ** 2) / 2, axis=1)
    estimates = [config["ks"] * fresnel if name == "specular" else np.full(len(cos_i), config[w])
                 for name, w, _ in present_lobes(config)]
    estimates = np.stack(estimates, axis=1)
    return estimates / estimates.sum(axis=1, keepdims=True)


def lobe_pdfs(config, wi, wo):
    """pdf_l (m, number of lobes present) of sampling wo from si.wi = wi, per
    unit solid angle: D(h) G1(wi) / (4 cos_i) (visible normals, exact Smith G1,
    reflection Jacobian 1 / (4 wi.h)) or cos_o / pi; 0 below the horizon."""
    wi, wo = wi / np.linalg.norm(wi, axis=1)[:, None], wo / np.linalg.norm(wo, axis=1)[:, None]
    h = wi + wo
    h /= np.linalg.norm(h, axis=1)[:, None]
    cos_i, cos_o, cos_h = wi[:, 2], wo[:, 2], h[:, 2]
    out = []
    for name, _, width in present_lobes(config):
        if name == "ideal_diffuse":
            out.append(np.maximum(cos_o, 0) / np.pi)
            continue
        distribution = "beckmann" if name == "specular" else config["dd_distribution"]
        alpha = np.sqrt(2) * np.float32(config[width])
        D = (ref.beckmann_D if distribution == "beckmann" else ref.ggx_D)(cos_h, alpha)
        out.append(D * ref.smith_G1(cos_i, alpha, distribution) / (4 * cos_i))
    return np.where(((cos_i > 0) & (cos_o > 0))[:, None], np.stack(out, axis=1), 0.0)


def pdf_rtol(config, wi, wo):
    """Relative tolerance (m,) of the plugin's float32 pdf against the float64
    one at the same float32 directions: 1e-5 (float32 arithmetic) plus, per
    microfacet lobe, 4 x the change of D when h = normalize(wi + wo) tilts by
    its float32 rounding 2u / cos(beta) (the sum's cancellation for nearly
    opposite directions): dD / D = 2 sqrt(x) tilt / alpha, x = tan^2(theta_h) /
    alpha^2 (the Beckmann exponent; GGX's is smaller)."""
    h = wi / np.linalg.norm(wi, axis=1)[:, None] + wo / np.linalg.norm(wo, axis=1)[:, None]
    cos_beta = np.linalg.norm(h, axis=1) / 2
    cos_h = h[:, 2] / (2 * cos_beta)
    tan = np.sqrt(np.maximum(1 - cos_h**2, 0)) / cos_h
    rtol = np.full(len(wi), 1e-5)
    for _, _, width in present_lobes(config):
        if width:
            alpha = np.sqrt(2) * config[width]
            rtol += 4 * 2 * (1 + tan / alpha) * (2 * U32 / cos_beta) / alpha
    return rtol


def cutoff_pdf(config, wi, cos_h):
    """Largest pdf the microfacet lobes can lose to Mitsuba's cut-off: D =
    D_CUTOFF / cos_h, G1 <= 1, p_l <= 1, summed over the lobes present."""
    cos_i = wi[:, 2] / np.linalg.norm(wi, axis=1)
    count = sum(1 for _, _, width in present_lobes(config) if width)
    return count * D_CUTOFF / np.maximum(cos_h, 1e-30) / (4 * cos_i)


def mixture_pdf(config, wi, wo):
    return np.sum(documented_probabilities(config, wi[:, 2] / np.linalg.norm(wi, axis=1))
                  * lobe_pdfs(config, wi, wo), axis=1)


def reference_value(config, to_viewer, to_light):
    """Reference BRDF (m, 4, 4, 4) in the global s/p frames and its float32
    conditioning kappa (m, 4) (proof/conditioning.py)."""
    p = lane_parameters(config, WAVELENGTHS, {}, len(to_viewer))
    R = reference_brdf(config, p, to_viewer, to_light)
    return R, sensitivity(config, p, to_viewer, to_light, R, np.random.default_rng(0))


def to_global(value, si_wi, wo, mode):
    """A Mueller matrix of the plugin (Mitsuba's implicit Stokes bases) in the
    reference's global s/p frames (as mitsuba_pbrdf.frames does for eval)."""
    to_viewer, to_light = (si_wi, wo) if mode == mi.TransportMode.Radiance else (wo, si_wi)

    def basis(d):
        s = dr.cross(mi.Vector3f(0, 0, 1), d)
        return dr.select(dr.squared_norm(s) == 0, mi.Vector3f(1, 0, 0), dr.normalize(s))

    return mi.mueller.rotate_mueller_basis(
        value, -to_light, mi.mueller.stokes_basis(-to_light), basis(-to_light),
        to_viewer, mi.mueller.stokes_basis(to_viewer), basis(to_viewer))


def draw(bsdf, wi, mode, seed):
    si, ctx = make_si(wi), mi.BSDFContext(mode)
    rng = np.random.default_rng(seed)
    n = len(wi)
    bs, weight = bsdf.sample(ctx, si, mi.Float(rng.random(n).astype(np.float32)),
                             mi.Point2f(*rng.random((2, n)).astype(np.float32)))
    return si, ctx, bs, weight


# ---------------------------------------------------------------- the mixture pdf

@pytest.mark.parametrize("name", sorted(CONFIGS))
def test_pdf_is_the_documented_mixture_of_lobe_pdfs(name):
    """pdf(wo) = sum_l p_l pdf_l(wo), with each single-component pdf (ctx.component
    = l) equal to pdf_l and p_l from the documented albedo estimate.

    Tolerance: :func:`pdf_rtol` relative, plus the pdf the lobes would have at
    Mitsuba's cut-off D cos(theta_h) = 1e-20 (:data:`D_CUTOFF`), below which D
    is 0 (measured errors: see the printout)."""
    config = CONFIGS[name]
    bsdf = load(config)
    wi, wo = hemisphere_pairs(20000, seed=21)
    si, w = make_si(wi), mi.Vector3f(*wo.T.astype(np.float32))
    wi32, wo32 = wi.astype(np.float32).astype(float), wo.astype(np.float32).astype(float)
    ctx = mi.BSDFContext()
    pdf = as_numpy(bsdf.pdf(ctx, si, w))
    parts = lobe_pdfs(config, wi32, wo32)
    probs = documented_probabilities(config, wi32[:, 2] / np.linalg.norm(wi32, axis=1))
    h = wi32 + wo32
    cos_h = h[:, 2] / np.linalg.norm(h, axis=1)
    rtol = pdf_rtol(config, wi32, wo32)
    floor = cutoff_pdf(config, wi32, cos_h)
    for index, lobe in enumerate(present_lobes(config)):
        ctx.component = index
        single = as_numpy(bsdf.pdf(ctx, si, w))
        err = np.abs(single - parts[:, index])
        assert np.all(err <= rtol * parts[:, index] + floor), (lobe[0], np.max(err / parts[:, index]))
    expected = np.sum(probs * parts, axis=1)
    err = np.abs(pdf - expected)
    resolved = expected > 1e3 * floor
    print(f"\n{name}: max relative pdf error {np.max(err[resolved] / expected[resolved]):.2e}")
    assert np.all(err <= rtol * expected + floor)
    assert np.mean(expected > 1e3 * floor) > 0.5


@pytest.mark.parametrize("theta_deg", [0.0, 45.0, 80.0])
@pytest.mark.parametrize("name", ["full-vgroove-Cu", "full-smith-ggx-Au", "specular-kid-smith-Al",
                                  "specular-dd-dielectric"])
def test_sampled_component_frequencies_follow_the_documented_probabilities(name, theta_deg):
    """Counts of `sampled_component` over N = 40,000 samples at a fixed wi
    against N p_l: Pearson's chi-square test, family-wise significance 1e-3
    over the 12 cases (Sidak: 8.3e-5 each). Power: the mutants "specular lobe
    picked without its Fresnel factor" and "uniform probabilities" shift p_l by
    >= 0.02 in every case (a chi-square of >= 40 N 0.02^2 / 1 = 16 per degree
    of freedom at least, far above the 1e-4 critical value ~19-21 for 1-2
    degrees of freedom only when summed; the printed statistic shows the margin).
    Every sample of component l has that lobe's type flags."""
    config = CONFIGS[name]
    bsdf = load(config)
    n = 40_000
    theta = np.radians(theta_deg)
    wi = np.tile([np.sin(theta), 0.0, np.cos(theta)], (n, 1))
    si, ctx, bs, weight = draw(bsdf, wi, mi.TransportMode.Radiance, seed=int(theta_deg) + 31)
    component = as_numpy(bs.sampled_component).astype(int)
    valid = as_numpy(bs.pdf) > 0
    # Every drawn sample counts, also those whose direction fell below the
    # horizon (weight 0): the lobe was picked before the direction was drawn.
    probs = documented_probabilities(config, np.array([np.float32(np.cos(theta))]))[0]
    counts = np.bincount(component, minlength=len(probs))
    assert len(counts) == len(probs)
    statistic, p_value = stats.chisquare(counts, n * probs)
    alpha = 1 - (1 - 1e-3) ** (1 / 12)
    print(f"\n{name} {theta_deg}: counts {counts}, expected {np.round(n * probs)}, "
          f"chi2 {statistic:.1f}, p {p_value:.3g}")
    assert p_value > alpha, (counts, n * probs)
    sampled_type = as_numpy(bs.sampled_type).astype(int)
    for index in range(len(probs)):
        assert np.all(sampled_type[component == index] == int(bsdf.flags(index)))
    assert valid.mean() > 0.5


# ---------------------------------------------------------------- the sample weight

@pytest.mark.parametrize("mode", [mi.TransportMode.Radiance, mi.TransportMode.Importance])
@pytest.mark.parametrize("name", sorted(CONFIGS))
@pytest.mark.slow
def test_sample_weight_is_reference_value_over_mixture_pdf(name, mode):
    """sample()'s weight equals R(wo) cos_o / pdf(wo), element by element, with R
    the float64 reference (global s/p frames) and pdf the documented mixture
    computed here; sample()'s pdf equals that pdf.

    Tolerance per lane: 128 u (1 + kappa) of M00 (the fuzz test's bound,
    proof/stress.py), kappa the reference's own float32
    conditioning at the sampled pair, plus the pdf's 4 u x (see above); lanes
    whose bound exceeds 1e-2 (ill-conditioned, e.g. the narrowest lobe's far
    tail) are not compared, and at least 80 % of the valid lanes must be (50 %
    for sigma = 0.003)."""
    config = CONFIGS[name]
    bsdf = load(config)
    wi, _ = hemisphere_pairs(6000, seed=5)
    si, ctx, bs, weight = draw(bsdf, wi, mode, seed=6)
    pdf = as_numpy(bs.pdf)
    valid = pdf > 0
    assert valid.mean() > 0.4                         # very rough lobes reflect ~half below
    assert np.all(as_numpy(weight)[~valid] == 0)
    si_wi = np.asarray(si.wi, dtype=np.float64).T[valid]
    wo = as_numpy(bs.wo)[valid]
    expected_pdf = mixture_pdf(config, si_wi, wo)
    radiance = mode == mi.TransportMode.Radiance
    to_viewer, to_light = (si_wi, wo) if radiance else (wo, si_wi)
    R, kappa = reference_value(config, to_viewer, to_light)
    cos_o = wo[:, 2] / np.linalg.norm(wo, axis=1)
    expected = R * (cos_o / expected_pdf)[:, None, None, None]
    got = as_numpy(to_global(weight, si.wi, bs.wo, mode))[valid]
    h = si_wi + wo
    cos_h = h[:, 2] / np.linalg.norm(h, axis=1)
    pdf_bound = pdf_rtol(config, si_wi, wo)
    bound = 128 * U32 * (1 + kappa) + pdf_bound[:, None]
    compared = bound < 1e-2
    # sigma = 0.003: D changes by e^-1 over 4e-3 rad; about half the lanes
    # stay below the bound (measured 54 %).
    assert compared.mean() > (0.5 if config["sigma"] < 0.01 else 0.8), compared.mean()
    m00 = expected[..., 0, 0]
    err = np.max(np.abs(got - expected), axis=(-1, -2)) / m00
    print(f"\n{name} {mode}: {compared.mean():.0%} compared, max |dW|/W00 {err[compared].max():.2e}"
          f", median bound {np.median(bound[compared]):.1e}")
    assert np.all(err[compared] <= bound[compared]), (err[compared].max(), bound[compared].min())
    pdf_err = np.abs(pdf[valid] - expected_pdf)
    assert np.all(pdf_err <= pdf_bound * expected_pdf + cutoff_pdf(config, si_wi, cos_h)), np.max(pdf_err / expected_pdf)
