"""Accuracy of the Dr.Jit plugin (float32) against the NumPy float64 reference
and against Mitsuba's roughconductor in the reduced case.

    python validation/accuracy.py [--pairs 100000] [--out validation/accuracy.md]

Prints, and writes as Markdown, the worst error per Mueller element over random
direction pairs (half near the specular direction) x 4 wavelengths x both
transport modes: absolute, and relative to the same sample's M00 (|M_ij| <= M00,
so M00 is each element's natural scale; an element's error relative to itself is
meaningless where it crosses zero).
"""

import argparse
import math
import os
import sys
import time

import mitsuba as mi
import numpy as np

import mitsuba_pbrdf  # noqa: E402
from mitsuba_pbrdf import frames, reference  # noqa: E402

mitsuba_pbrdf.use_variant("llvm_ad_spectral_polarized")

WAVELENGTHS = (450.0, 520.0, 600.0, 690.0)
CONFIGS = {
    "Al, sigma 0.1, vgroove, dd beckmann": dict(material="Al", sigma=0.1, kdd=0.2, sigma_dd=0.5, kid=0.05),
    "Cu, sigma 0.3, vgroove, dd ggx": dict(material="Cu", sigma=0.3, kdd=0.3, sigma_dd=0.8, kid=0.1,
                                           dd_distribution="ggx"),
    "Au, sigma 0.05, vgroove, dd beckmann": dict(material="Au", sigma=0.05, kdd=0.5, sigma_dd=0.3),
    "Ag, sigma 0.6, vgroove, dd ggx": dict(material="Ag", sigma=0.6, ks=0.7, kdd=0.1, sigma_dd=1.5,
                                           kid=0.2, dd_distribution="ggx"),
}
ELEMENTS = [f"m{i}{j}" for i in range(4) for j in range(4)]


def reference_matrix(config, wi_hat, wo_hat):
    n, k = reference.conductor_ior(config["material"], WAVELENGTHS)
    ti, pi_ = frames.to_angles(wo_hat)
    tr, pr = frames.to_angles(wi_hat)
    c = {key: v for key, v in config.items() if key != "material"}
    return reference.pbrdf(ti[:, None], pi_[:, None], tr[:, None], pr[:, None], n, k, **c)


def errors(M, R):
    """Worst absolute error per element, and worst error relative to M00 where
    M00 > 1e-7 max(M00) (below that float32 underflows: the plugin's D is 0
    where the reference's is e.g. 1e-27)."""
    m00 = R[..., :1, :1]
    err = np.abs(M - R)
    resolved = m00 > 1e-7 * m00.max()
    relative = np.where(resolved, err / np.maximum(m00, 1e-300), 0.0)
    return err.max(axis=(0, 1)).ravel(), relative.max(axis=(0, 1)).ravel()


def measure(pairs):
    rng = np.random.default_rng(0)
    rows = {}
    for name, config in CONFIGS.items():
        bsdf = mi.load_dict(dict({"type": "pbrdf"}, **config))
        worst_abs, worst_rel, scale = np.zeros(16), np.zeros(16), 0.0
        for mode in ("radiance", "importance"):
            wi_hat, wo_hat = frames.random_directions(pairs, rng)
            M = frames.eval_global(bsdf, wi_hat, wo_hat, WAVELENGTHS, mode)
            R = reference_matrix(config, wi_hat, wo_hat)
            a, r = errors(M, R)
            worst_abs, worst_rel = np.maximum(worst_abs, a), np.maximum(worst_rel, r)
            scale = max(scale, R[..., 0, 0].max())
        rows[name] = (worst_abs, worst_rel, scale)

    # Reduced case: kdd = kid = 0, smith, sigma = alpha / sqrt(2) vs roughconductor.
    for material, alpha in (("Al", 0.1), ("Cu", 0.4)):
        rc = mi.load_dict({"type": "roughconductor", "material": material, "alpha": alpha})
        pb = mi.load_dict({"type": "pbrdf", "material": material, "sigma": alpha / math.sqrt(2),
                           "shadowing": "smith"})
        worst_abs, worst_rel, scale = np.zeros(16), np.zeros(16), 0.0
        for mode in ("radiance", "importance"):
            wi_hat, wo_hat = frames.random_directions(pairs, rng)
            M = frames.eval_global(pb, wi_hat, wo_hat, WAVELENGTHS, mode)
            R = frames.eval_global(rc, wi_hat, wo_hat, WAVELENGTHS, mode)
            a, r = errors(M, R)
            worst_abs, worst_rel = np.maximum(worst_abs, a), np.maximum(worst_rel, r)
            scale = max(scale, R[..., 0, 0].max())
        rows[f"vs roughconductor: {material}, alpha {alpha}"] = (worst_abs, worst_rel, scale)
    return rows


def markdown(rows, pairs, seconds):
    lines = [
        "# Accuracy of the pbrdf plugin",
        "",
        f"`python validation/accuracy.py --pairs {pairs}` ({seconds:.0f} s). Each row: {pairs} random",
        "direction pairs per transport mode (half near the specular direction), 4 wavelengths",
        f"{WAVELENGTHS} nm, both modes. Upper rows: plugin (float32) vs the NumPy float64 reference;",
        "lower rows: plugin vs Mitsuba's `roughconductor` in the reduced case (kdd = kid = 0,",
        "`shadowing=\"smith\"`, sigma = alpha/sqrt(2)). Worst error per element relative to the",
        "same sample's M00 (max over samples with M00 > 1e-7 max M00, where float32 does not",
        "underflow, and all wavelengths), then the worst absolute error; the largest M00 seen gives",
        "the scale (narrow lobes peak at 1e4 1/sr).",
    ]
    for title, column in (("Worst error relative to M00", 1), ("Worst absolute error (1/sr)", 0)):
        lines += ["", f"**{title}**", "",
                  "| configuration | max M00 (1/sr) | " + " | ".join(ELEMENTS) + " |",
                  "|---|---|" + "---|" * 16]
        lines += [f"| {name} | {row[2]:.3g} | " + " | ".join(f"{v:.1e}" for v in row[column]) + " |"
                  for name, row in rows.items()]
    return "\n".join(lines) + "\n"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pairs", type=int, default=100_000)
    parser.add_argument("--out", default=os.path.join(os.path.dirname(__file__), "accuracy.md"))
    args = parser.parse_args(argv)
    start = time.perf_counter()
    rows = measure(args.pairs)
    text = markdown(rows, args.pairs, time.perf_counter() - start)
    with open(args.out, "w") as f:
        f.write(text)
    sys.stdout.write(text)


if __name__ == "__main__":
    main()
