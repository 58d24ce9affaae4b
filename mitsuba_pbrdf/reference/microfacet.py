"""Facet distributions and shadowing (paper Eq. 3-5): the Gaussian slope
density, Beckmann and GGX normal distributions, Smith's G1 and the
shadowing-masking G. Angles in radians, densities per steradian.
"""

import math

import numpy as np

from ..schema import DD_DISTRIBUTIONS as DISTRIBUTIONS
from ..schema import REFERENCE_SHADOWING as SHADOWING_KINDS


def gaussian_slope_pdf(alpha_angle, sigma):
    """Paper Eq. 3: density of facet tilt angles alpha, per unit solid angle of
    the facet normal, ``exp(-tan^2 a / 2 s^2) / (2 pi s^2 cos^3 a)``.
    It equals ``beckmann_D(cos a, sqrt(2) * sigma) * cos a``."""
    a = np.asarray(alpha_angle, dtype=np.float64)
    sigma = np.asarray(sigma, dtype=np.float64)
    c = np.cos(a)
    return np.exp(-np.tan(a) ** 2 / (2 * sigma**2)) / (2 * np.pi * sigma**2 * c**3)


def _tan2(cos_t):
    cos2 = cos_t * cos_t
    return np.clip(1.0 - cos2, 0.0, None) / np.where(cos2 > 0, cos2, 1.0)


def beckmann_D(cos_theta_h, alpha):
    """Beckmann normal distribution ``exp(-tan^2/alpha^2) / (pi alpha^2 cos^4)``
    (1/sr per unit projected area; ``int D cos dw = 1``); 0 for cos <= 0.
    With ``alpha = sqrt(2) sigma`` it is paper Eq. 3 divided by ``cos theta_h``."""
    c = np.asarray(cos_theta_h, dtype=np.float64)
    alpha = np.asarray(alpha, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        D = np.exp(-_tan2(c) / alpha**2) / (np.pi * alpha**2 * c**4)
    return np.where(c > 0, D, 0.0)


def ggx_D(cos_theta_h, alpha):
    """GGX / Trowbridge-Reitz ``alpha^2 / (pi (cos^2 (alpha^2 - 1) + 1)^2)``; 0 for cos <= 0."""
    c = np.asarray(cos_theta_h, dtype=np.float64)
    alpha = np.asarray(alpha, dtype=np.float64)
    a2 = alpha * alpha
    D = a2 / (np.pi * (c * c * (a2 - 1.0) + 1.0) ** 2)
    return np.where(c > 0, D, 0.0)


_erfc = np.frompyfunc(math.erfc, 1, 1)


def smith_G1(cos_theta, alpha, distribution="beckmann"):
    """Smith's masking function of one direction, ``1 / (1 + Lambda)``.

    Beckmann (exact form): ``a = 1 / (alpha tan theta)``,
    ``Lambda = (erf(a) - 1)/2 + exp(-a^2) / (2 a sqrt(pi))``.
    GGX: ``2 / (1 + sqrt(1 + alpha^2 tan^2 theta))``. 1 at normal incidence.
    """
    c = np.asarray(cos_theta, dtype=np.float64)
    alpha = np.asarray(alpha, dtype=np.float64)
    c, alpha = np.broadcast_arrays(c, alpha)
    tan2 = _tan2(c)
    if distribution == "beckmann":
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            a = 1.0 / (alpha * np.sqrt(tan2))
            a_safe = np.where(np.isfinite(a) & (a > 0), a, 1.0)
            erfc = np.asarray(_erfc(a_safe), dtype=np.float64)
            lam = 0.5 * (np.exp(-a_safe * a_safe) / (a_safe * np.sqrt(np.pi)) - erfc)
            G1 = 1.0 / (1.0 + lam)
        G1 = np.where(tan2 == 0, 1.0, G1)
    elif distribution == "ggx":
        G1 = 2.0 / (1.0 + np.sqrt(1.0 + alpha * alpha * tan2))
    else:
        raise ValueError(f"unknown distribution {distribution!r}; expected one of {DISTRIBUTIONS}")
    return np.where(c > 0, G1, 0.0)


def shadowing_G(theta_i, theta_r, cos_theta_h, cos_beta, alpha, kind="vgroove",
                distribution="beckmann"):
    """Geometric attenuation G of paper Eq. 4-5.

    * ``"vgroove"`` (Torrance-Sparrow / Blinn, the paper's choice):
      ``min(1, 2 cos th cos tr / cos b, 2 cos th cos ti / cos b)``;
    * ``"smith"``: separable Smith ``G1(wi) G1(wr)`` of ``distribution`` with
      roughness ``alpha`` (Mitsuba's ``roughconductor`` form);
    * ``"none"``: 1 (the original Priest-Germer model, unbounded at grazing).
    """
    cos_i = np.cos(np.asarray(theta_i, dtype=np.float64))
    cos_r = np.cos(np.asarray(theta_r, dtype=np.float64))
    cos_h = np.asarray(cos_theta_h, dtype=np.float64)
    cos_b = np.asarray(cos_beta, dtype=np.float64)
    if kind == "vgroove":
        with np.errstate(divide="ignore", invalid="ignore"):
            G = np.minimum(1.0, np.minimum(2 * cos_h * cos_r / cos_b, 2 * cos_h * cos_i / cos_b))
        G = np.where(cos_b > 0, G, 0.0)
    elif kind == "smith":
        G = smith_G1(cos_i, alpha, distribution) * smith_G1(cos_r, alpha, distribution)
        G = np.where(cos_b > 0, G, 0.0)               # facet seen from the front by both
    elif kind == "none":
        G = np.ones(np.broadcast_shapes(cos_i.shape, cos_r.shape, cos_h.shape, cos_b.shape))
    else:
        raise ValueError(f"unknown shadowing {kind!r}; expected one of {SHADOWING_KINDS}")
    return np.where((cos_i > 0) & (cos_r > 0), G, 0.0)
