"""Sampling is unbiased: a white-furnace integral of each microfacet lobe by
the plugin's own importance sampling against quadrature of its own eval.

For wi fixed, I = int eval_00(wo) dwo (eval includes cos_o) by quadrature, and
two Monte Carlo estimates over the plugin's samples wo ~ q:

* E_w = mean(weight_00): the sample weight (single-lobe code path, closed
  form G / G1(wi) for a microfacet lobe);
* E_p = mean(eval_00(wo) / pdf(wo)): the density `pdf()` claims (the code
  path every mixture uses, `MicrofacetLobe.eval_pdf`).

Both equal I only if q is the density the plugin claims. A pdf biased by a
factor (1 + e) biases E_p by -e: the mutant to detect is a pdf that uses
Mitsuba's rational approximation of the Beckmann Smith G1 (Mitsuba's
visible-normal sampler draws the exact distribution), off by up to 0.31 % at
a = 1 / (alpha tan theta_i) = 1.34: theta_i = 69.3 deg for sigma = 0.2 and
46.6 deg for sigma = 0.5, the angles used here. The anisotropic case
(sigma_u = 0.5, sigma_v = 0.05) looks from azimuth 67.1 deg, where the
projected RMS slope is 0.2: a = 1.34 again at 69.3 deg.

Samples: 16 independent replicates of a jittered 128 x 128 grid of the
direction sample (randomized stratification: the replicates' means are
independent and unbiased, and their spread gives an honest standard error,
30-50 x smaller than that of as many iid samples; measured values printed).
Significance: t = (|E - I| - 2e-5 I) / sqrt(se^2 + q^2), q the quadrature's
error (estimated by halving its nodes), 2e-5 for float32 weights, against
Student's t with 15 degrees of freedom at a family-wise 1e-3 over the 16
estimates (Sidak). Power: each case asserts that a 0.3 % bias would exceed
the critical value by the 99 % quantile of t (99 % power); measured se are
2e-5-6e-5 of I, over 7 x below the 4.4e-4 I that needs.
"""

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest
from scipy import stats

from bsdf_harness import as_numpy, make_si

SAMPLES = 1 << 18          # 16 independent replicates of a jittered 128 x 128 grid
REPLICATES = 16
BIAS = 3e-3                # the pdf bias the test must see
FAMILY = 16
T_CRIT = stats.t.ppf(1 - 0.5 * (1 - (1 - 1e-3) ** (1 / FAMILY)), df=REPLICATES - 1)
T_POWER = stats.t.ppf(0.99, df=REPLICATES - 1)
FLOAT32 = 2e-5

CASES = {
    "specular-beckmann": (dict(eta=1.0, k=1e4, sigma=0.2), 69.3),
    "specular-anisotropic": (dict(eta=1.0, k=1e4, sigma_u=0.5, sigma_v=0.05), 69.3, 67.1),
    "dd-beckmann": (dict(ks=0.0, kdd=1.0, sigma_dd=0.5), 46.6),
    "dd-ggx": (dict(ks=0.0, kdd=1.0, sigma_dd=0.5, dd_distribution="ggx"), 46.6),
}


def quadrature(bsdf, wi, n_mu, n_phi):
    """int eval_00 dwo over the upper hemisphere: Gauss-Legendre in mu = cos
    theta_o, the (spectrally accurate, periodic) trapezoid rule in phi_o."""
    x, w = np.polynomial.legendre.leggauss(n_mu)
    mu, w_mu = 0.5 * (x + 1), 0.5 * w
    phi = (np.arange(n_phi) + 0.5) * 2 * np.pi / n_phi
    M, P = np.meshgrid(mu, phi, indexing="ij")
    s = np.sqrt(1 - M**2)
    wo = np.stack([s * np.cos(P), s * np.sin(P), M], -1).reshape(-1, 3)
    si = make_si(np.tile(wi, (len(wo), 1)))
    value = as_numpy(bsdf.eval(mi.BSDFContext(), si, mi.Vector3f(*wo.T.astype(np.float32))))
    f = value[:, 0, 0, 0].reshape(n_mu, n_phi)
    return float(np.sum(f * w_mu[:, None]) * 2 * np.pi / n_phi)


@pytest.mark.parametrize("shadowing", ["vgroove", "smith"])
@pytest.mark.parametrize("case", sorted(CASES))
@pytest.mark.slow
def test_sampling_is_unbiased_for_each_microfacet_lobe(case, shadowing):
    params, theta_deg, *phi_deg = CASES[case]
    bsdf = mi.load_dict(dict({"type": "pbrdf", "shadowing": shadowing}, **params))
    theta, phi = np.radians(theta_deg), np.radians(phi_deg[0] if phi_deg else 0.0)
    wi = np.array([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)])
    fine = quadrature(bsdf, wi, 768, 1024)
    coarse = quadrature(bsdf, wi, 384, 512)
    q = abs(fine - coarse)
    rng = np.random.default_rng(zlib_seed(case, shadowing))
    side = int(np.sqrt(SAMPLES // REPLICATES))
    n = REPLICATES * side * side
    cells = (np.indices((side, side)).reshape(2, -1).T + 0.5) / side
    jitter = (rng.random((REPLICATES, side * side, 2)) - 0.5) / side
    sample2 = (cells[None] + jitter).reshape(-1, 2).astype(np.float32)
    si, ctx = make_si(np.tile(wi, (n, 1))), mi.BSDFContext()
    bs, weight = bsdf.sample(ctx, si, mi.Float(rng.random(n, dtype=np.float32)),
                             mi.Point2f(*sample2.T))
    w = as_numpy(weight)[:, 0, 0, 0]
    value, pdf = (as_numpy(x) for x in bsdf.eval_pdf(ctx, si, bs.wo))
    ratio = np.where(pdf > 0, value[:, 0, 0, 0] / np.where(pdf > 0, pdf, 1.0), 0.0)
    for name, x in (("weight", w), ("eval/pdf", ratio)):
        means = x.reshape(REPLICATES, -1).mean(axis=1)
        estimate, se = means.mean(), means.std(ddof=1) / np.sqrt(REPLICATES)
        sigma = np.hypot(se, q)
        t = (abs(estimate - fine) - FLOAT32 * fine) / sigma
        print(f"\n{case} {shadowing} {name}: quadrature {fine:.6f} (+- {q:.1e}), MC "
              f"{estimate:.6f} +- {se:.1e} (iid: {x.std() / np.sqrt(n):.1e}), t = {t:.2f}")
        assert t <= T_CRIT, (estimate, fine, se, q)
        assert (BIAS - FLOAT32) * fine >= (T_CRIT + T_POWER) * sigma, "too little power"


def zlib_seed(*names):
    import zlib

    return zlib.crc32("/".join(names).encode())
