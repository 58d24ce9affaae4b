"""The white-furnace study's table: the albedo of every lobe by the reference's
quadrature and by the plugin's own sampling (:mod:`mitsuba_pbrdf.diagnostics.furnace`),
their comparison, and the flat-surface Fresnel reflectance the metal rows are
judged against. Used by validation/furnace.py and tests/diagnostics/test_physics.py."""

import numpy as np

from mitsuba_pbrdf import reference
from mitsuba_pbrdf.diagnostics.furnace import (SYSTEMATIC, WAVELENGTH, plugin_albedo,
                                               reference_albedo_with_error)


def fresnel_reflectance(metal, theta_i_deg):
    """Unpolarized flat-surface Fresnel reflectance (R_s + R_p) / 2 at WAVELENGTH."""
    n, k = reference.conductor_ior(metal, WAVELENGTH)
    r_s, r_p = reference.fresnel_amplitudes(np.cos(np.radians(theta_i_deg)), n, k)
    return float(0.5 * (abs(r_s) ** 2 + abs(r_p) ** 2))


ANGLES = (0.0, 20.0, 40.0, 60.0, 70.0, 80.0, 85.0, 88.0, 89.5)
SIGMAS = (0.05, 0.2, 0.5, 1.0)
SHADOWING = ("vgroove", "smith")


def study(samples=1 << 20, angles=ANGLES, sigmas=SIGMAS, plugin=True, quadrature=256):
    """List of dict rows: lobe, sigma, shadowing, angle, reference, quadrature
    error, plugin, plugin standard error."""
    rows = []
    cases = [(lobe, s) for lobe in ("beckmann", "ggx") for s in sigmas]
    cases += [(metal, 0.2) for metal in ("Al", "Cu")]
    for lobe, sigma in cases:
        for shadowing in SHADOWING + (("none",) if lobe == "beckmann" else ()):
            for angle in angles:
                ref, err = reference_albedo_with_error(lobe, angle, sigma, shadowing, quadrature)
                mc, se = (plugin_albedo(lobe, angle, sigma, shadowing, samples)
                          if plugin and shadowing != "none" else (np.nan, np.nan))
                rows.append(dict(lobe=lobe, sigma=sigma, shadowing=shadowing, angle=angle,
                                 reference=ref, quadrature_error=err, plugin=mc, stderr=se))
    if plugin:
        for angle in angles:
            mc, se = plugin_albedo("lambert", angle, 1.0, "vgroove", samples)
            rows.append(dict(lobe="lambert", sigma=np.nan, shadowing="–", angle=angle,
                             reference=1.0, quadrature_error=0.0, plugin=mc, stderr=se))
    return rows


def compare(r):
    """|plugin - reference| / uncertainty, uncertainty = sqrt(stderr^2 +
    quadrature error^2) + SYSTEMATIC x reference. NaN for Smith shadowing on
    Beckmann lobes: the plugin evaluates G with Mitsuba's approximate G1 (as
    roughconductor), the reference with the exact one."""
    if np.isnan(r["plugin"]) or (r["shadowing"] == "smith" and r["lobe"] != "ggx"):
        return np.nan
    uncertainty = np.hypot(r["stderr"], r["quadrature_error"]) + SYSTEMATIC * r["reference"]
    return abs(r["plugin"] - r["reference"]) / uncertainty
