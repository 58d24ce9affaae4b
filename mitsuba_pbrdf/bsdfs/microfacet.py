"""Microfacet helpers: Smith's masking G1 (exact for Beckmann) and the two
shadowing-masking functions a lobe is built with (:data:`SHADOWING`: Smith's,
the paper's V-groove), on Mitsuba's ``MicrofacetDistribution``. Directions in
the local shading frame (z = surface normal).
"""

import math

import drjit as dr
import mitsuba as mi


def smith_g1(distribution, v):
    """Mitsuba's Smith G1 of direction ``v`` (anisotropic: through the
    roughness projected on v's azimuth), without the facet-side test, which
    the callers apply symmetrically."""
    return distribution.smith_g1(v, mi.Vector3f(0.0, 0.0, 1.0))


def visible_g1(distribution, wi, projected):
    """Smith G1(wi) of the distribution that visible-normal sampling draws
    from, exactly: Mitsuba samples Beckmann's visible normals exactly but its
    ``smith_g1`` uses a rational approximation (< 0.35 % error), which would bias
    the pdf and so every sampling weight by G1_exact / G1_approx. GGX's G1 is
    exact in Mitsuba already. The facet-side test (cos beta > 0) is the caller's.

    Beckmann: G1 = 1 / (1 + Lambda(a)), Lambda = (erf(a) - 1) / 2 + exp(-a^2) / (2 a sqrt(pi)),
    a = 1 / (alpha tan(theta)). Anisotropic: alpha is the roughness projected on
    wi's azimuth phi, alpha(phi)^2 = cos^2(phi) alpha_u^2 + sin^2(phi) alpha_v^2,
    so a = cos(theta) / sqrt(x^2 alpha_u^2 + y^2 alpha_v^2) for wi = (x, y, cos),
    used where ``projected`` (a Python bool fixed when the lobe is built: the
    widths may be traced texture values, which cannot be compared while a
    kernel is recorded; the projected form is exact for equal widths too).
    """
    if distribution.type() != mi.MicrofacetType.Beckmann:
        return smith_g1(distribution, wi)
    cos = mi.Frame3f.cos_theta(wi)
    if projected:
        projected = dr.sqrt(dr.square(wi.x * distribution.alpha_u())
                            + dr.square(wi.y * distribution.alpha_v()))
        a = cos / projected
        normal = projected == 0
    else:
        tan = dr.safe_sqrt(1.0 - cos * cos) / cos
        a = dr.rcp(distribution.alpha() * tan)
        normal = tan == 0
    lam = 0.5 * (dr.erf(a) - 1.0) + dr.exp(-a * a) / (2.0 * a * math.sqrt(math.pi))
    return dr.select(cos > 0, dr.select(normal, 1.0, dr.rcp(1.0 + lam)), 0.0)


def smith_shadowing(distribution, wi, wo, cos_h, cos_beta):
    """Smith's shadowing-masking G1(wi) G1(wo) of ``distribution``, without
    Mitsuba's per-direction facet-side test dot(v, h) cos(v) > 0: for nearly
    opposite grazing directions float32 rounding of the inputs' lengths can
    flip one dot product (wi.h and wo.h differ by (|wi|^2 - |wo|^2) / |wi + wo|);
    the side test is the symmetric cos(beta) > 0 that the caller applies."""
    return smith_g1(distribution, wi) * smith_g1(distribution, wo)


def vgroove_shadowing(distribution, wi, wo, cos_h, cos_beta):
    """The V-groove shadowing-masking of Torrance-Sparrow / Blinn (the paper's),
    min(1, 2 cos_h cos_o / cos_b, 2 cos_h cos_i / cos_b) for facets with normal
    h (``cos_h`` = h.z, ``cos_beta`` = wi.h = wo.h). It depends on h alone, not
    on the distribution's widths, so it is the same for isotropic and
    anisotropic lobes (docs/model.md)."""
    two_cos_h = 2.0 * cos_h / cos_beta
    return dr.minimum(1.0, two_cos_h * dr.minimum(mi.Frame3f.cos_theta(wi),
                                                   mi.Frame3f.cos_theta(wo)))


#: The plugin's ``shadowing`` choices: functions ``(distribution, wi, wo,
#: cos_h, cos_beta) -> G``, chosen once when the BSDF is loaded.
SHADOWING = {"smith": smith_shadowing, "vgroove": vgroove_shadowing}
