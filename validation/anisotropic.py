"""Anisotropic and GGX lobes: the plugin against Mitsuba's roughconductor with
alpha_u/alpha_v (Mueller matrices, pdfs) and Mitsuba's chi-square test of
its sampling.

    python validation/anisotropic.py [--pairs 20000] [--out validation/anisotropic.md]

Roughconductor rows: kdd = kid = 0, shadowing="smith", sigma_u = alpha_u /
sqrt(2), sigma_v = alpha_v / sqrt(2); random direction pairs (half near the
specular direction) x 4 wavelengths x both transport modes. Worst element
error relative to the same sample's M00 (where M00 > 1e-7 max M00), the
range of pdf_pbrdf / pdf_roughconductor, and after multiplying
roughconductor's Beckmann pdf by G1_exact / G1_mitsuba (with the projected
width) the worst relative pdf difference. Chi-square rows: Mitsuba's
ChiSquareTest through the suite's polarized adapter (tests/conftest.py), 1e6
samples, the pdf integrated with 32 x 32 sub-samples per cell (IRES), the
p-value for several incident directions.
"""

import argparse
import math
import os
import sys
import time

import drjit as dr
import mitsuba as mi
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:          # python validation/anisotropic.py from anywhere
    sys.path.insert(0, ROOT)

import mitsuba_pbrdf  # noqa: E402
from mitsuba_pbrdf import frames, reference  # noqa: E402
from proof.mitsuba_g1 import mitsuba_beckmann_G1  # noqa: E402

mitsuba_pbrdf.use_variant("llvm_ad_spectral_polarized")

WAVELENGTHS = (450.0, 520.0, 600.0, 690.0)
#: Family-wise significance as the test suite's chi-square tests.
SIGNIFICANCE, TEST_COUNT = 0.01, 19


def make_si(wi):
    si = dr.zeros(mi.SurfaceInteraction3f, len(wi))
    si.wi = mi.Vector3f(*np.asarray(wi, np.float32).T)
    si.wavelengths = mi.UnpolarizedSpectrum(*WAVELENGTHS)
    return si


def to_vector(w):
    return mi.Vector3f(*np.asarray(w, np.float32).T)


def as_numpy(value):
    """Lanes first; Mueller matrices as (n, wavelengths, 4, 4)."""
    a = np.array(value, dtype=np.float64)
    return a.transpose(3, 2, 0, 1) if a.ndim == 4 else np.moveaxis(a, -1, 0)


def chi2_sampling_test(config, wi, sample_count, res=101, ires=8):
    """Mitsuba's ChiSquareTest of ``sample`` against ``pdf`` through the
    polarized adapter of :mod:`proof.polarized_chi2` (the suite's too)."""
    from proof.polarized_chi2 import chi2_sampling_test as test

    return test(config, wi, sample_count, WAVELENGTHS, SIGNIFICANCE, TEST_COUNT, res, ires)
ALPHAS = ((0.05, 0.5), (0.6, 0.06), (0.3, 0.2), (0.02, 0.2), (1.0, 0.1))
CHI2 = {
    "Al, Beckmann, sigma_u/sigma_v = 10 (0.5, 0.05), vgroove":
        {"type": "pbrdf", "material": "Al", "sigma_u": 0.5, "sigma_v": 0.05},
    "Cu, GGX, sigma_u/sigma_v = 1/10 (0.03, 0.3), smith":
        {"type": "pbrdf", "material": "Cu", "sigma_u": 0.03, "sigma_v": 0.3,
         "distribution": "ggx", "shadowing": "smith"},
    "Au, Beckmann 0.3/0.03 + anisotropic dd (0.2/0.8) + kid":
        {"type": "pbrdf", "material": "Au", "sigma_u": 0.3, "sigma_v": 0.03, "kdd": 0.4,
         "sigma_dd_u": 0.2, "sigma_dd_v": 0.8, "kid": 0.1},
}
DIRECTIONS = ((30.0, 20.0), (60.0, 70.0), (80.0, 135.0))
#: Sub-samples per cell side when the test integrates the pdf: Mitsuba's
#: default 8 is too coarse for lobes 0.07 wide seen at 80 degrees (the
#: isotropic sigma = 0.05 lobe fails there too, p = 0 at 1e6 samples, and
#: passes at 32: the pdf table's integration error, not the sampler).
IRES = 32


def g1_ratio(wi, alpha_u, alpha_v):
    alpha = reference.projected_alpha(np.arctan2(wi[:, 1], wi[:, 0]), alpha_u, alpha_v)
    return reference.smith_G1(wi[:, 2], alpha) / mitsuba_beckmann_G1(wi[:, 2], alpha)


def roughconductor_rows(pairs):
    rng = np.random.default_rng(0)
    rows = []
    for distribution in ("beckmann", "ggx"):
        for a_u, a_v in ALPHAS:
            rc = mi.load_dict({"type": "roughconductor", "material": "Cu", "alpha_u": a_u,
                               "alpha_v": a_v, "distribution": distribution})
            pb = mi.load_dict({"type": "pbrdf", "material": "Cu", "sigma_u": a_u / math.sqrt(2),
                               "sigma_v": a_v / math.sqrt(2), "distribution": distribution,
                               "shadowing": "smith"})
            worst, ratio_lo, ratio_hi, pdf_err = 0.0, np.inf, 0.0, 0.0
            for mode in (mi.TransportMode.Radiance, mi.TransportMode.Importance):
                wi, wo = frames.random_directions(pairs, rng)
                si, w, ctx = make_si(wi), to_vector(wo), mi.BSDFContext(mode)
                M, R = as_numpy(pb.eval(ctx, si, w)), as_numpy(rc.eval(ctx, si, w))
                m00 = np.abs(R[..., :1, :1])
                resolved = m00 > 1e-7 * m00.max()
                worst = max(worst, float(np.max(np.where(resolved, np.abs(M - R) / np.maximum(
                    m00, 1e-300), 0.0))))
                p_pb, p_rc = as_numpy(pb.pdf(ctx, si, w)), as_numpy(rc.pdf(ctx, si, w))
                ok = p_rc > 1e-6 * p_rc.max()
                ratio = p_pb[ok] / p_rc[ok]
                ratio_lo, ratio_hi = min(ratio_lo, ratio.min()), max(ratio_hi, ratio.max())
                corrected = p_rc * (g1_ratio(wi, np.float32(a_u), np.float32(a_v))
                                    if distribution == "beckmann" else 1.0)
                pdf_err = max(pdf_err, float(np.max(np.abs(p_pb[ok] / corrected[ok] - 1))))
            rows.append((distribution, a_u, a_v, worst, ratio_lo, ratio_hi, pdf_err))
    return rows


def chi2_rows(samples):
    rows = []
    for name, config in CHI2.items():
        for theta, phi in DIRECTIONS:
            t, p = math.radians(theta), math.radians(phi)
            wi = (math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t))
            test = chi2_sampling_test(config, wi, samples, ires=IRES)
            rows.append((name, theta, phi, test.p_value, test.passed))
    return rows


def markdown(rc_rows, chi_rows, pairs, samples, seconds):
    lines = ["# Anisotropic and GGX lobes", "",
             f"`python validation/anisotropic.py --pairs {pairs} --samples {samples}` "
             f"({seconds:.0f} s).", "",
             "## pbrdf against roughconductor (alpha_u, alpha_v), Cu, both transport modes", "",
             f"{pairs} pairs per mode. `pdf ratio`: pdf_pbrdf / pdf_roughconductor where the "
             "latter is > 1e-6 of its maximum; `pdf vs corrected`: worst |ratio - 1| after "
             "multiplying roughconductor's Beckmann pdf by G1_exact / G1_mitsuba.", "",
             "| distribution | alpha_u | alpha_v | worst max dM / M00 | pdf ratio range | "
             "pdf vs corrected |", "|---|---|---|---|---|---|"]
    lines += [f"| {d} | {u:g} | {v:g} | {w:.1e} | {lo:.5f} – {hi:.5f} | {e:.1e} |"
              for d, u, v, w, lo, hi, e in rc_rows]
    lines += ["", "## Chi-square test of sampling (Mitsuba's ChiSquareTest, polarized adapter)",
              "", f"{samples} samples, pdf integrated with {IRES} x {IRES} points per cell; "
              "significance 1 % over the suite's family (tests/conftest.py). With Mitsuba's "
              "default 8 x 8 the 80-degree rows fail, as does the isotropic sigma = 0.05 lobe "
              "there (p = 0; p = 0.03 at 32 x 32): the integration of narrow grazing lobes, "
              "not the sampler (the pdf integrates to the share of samples kept, 0.98262 "
              "against 0.98262, at 80 degrees).", "",
              "| configuration | theta_i | phi_i | p-value | passed |", "|---|---|---|---|---|"]
    lines += [f"| {n} | {t:g} | {p:g} | {pv:.3g} | {ok} |" for n, t, p, pv, ok in chi_rows]
    return "\n".join(lines) + "\n"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pairs", type=int, default=20_000)
    parser.add_argument("--samples", type=int, default=1_000_000)
    parser.add_argument("--out", default=os.path.join(os.path.dirname(__file__), "anisotropic.md"))
    args = parser.parse_args(argv)
    start = time.perf_counter()
    rc_rows = roughconductor_rows(args.pairs)
    chi_rows = chi2_rows(args.samples)
    text = markdown(rc_rows, chi_rows, args.pairs, args.samples, time.perf_counter() - start)
    with open(args.out, "w") as f:
        f.write(text)
    sys.stdout.write(text)


if __name__ == "__main__":
    main()
