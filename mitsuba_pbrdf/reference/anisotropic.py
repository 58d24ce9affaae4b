"""Anisotropic facet distributions, written from their slope densities.

A facet with normal ``h = (hx, hy, hz)`` in the surface frame (x: the shading
frame's s axis, ``dp_du``; z: the normal) has slopes ``p = -hx / hz`` and
``q = -hy / hz``. Paper Eq. 3 generalizes to independent Gaussian slopes of
RMS ``sigma_u`` along x and ``sigma_v`` along y::

    P(p, q) = exp(-p^2 / (2 sigma_u^2) - q^2 / (2 sigma_v^2)) / (2 pi sigma_u sigma_v)

and the normal distribution per unit projected area is ``D(h) = P(p, q) /
cos^4 theta_h`` (``dp dq = dw_h / cos^3 theta_h``, so ``int D cos theta_h dw =
int P dp dq = 1``). With ``alpha = sqrt(2) sigma`` per axis this is
anisotropic Beckmann. GGX (Trowbridge-Reitz) has the slope density
``P = 1 / (pi alpha_u alpha_v (1 + p^2/alpha_u^2 + q^2/alpha_v^2)^2)``.

Smith's masking of a direction with azimuth phi needs the distribution of the
slope along phi, ``p cos phi + q sin phi``: for both densities (their
contours are ellipses) it is the isotropic one with the projected width
``alpha(phi)^2 = cos^2 phi alpha_u^2 + sin^2 phi alpha_v^2`` (for Gaussian
slopes: the variance of a sum of independent Gaussians). Angles in radians.
"""

import numpy as np

from .geometry import _canonical
from .microfacet import smith_G1


def _direction(theta, phi):
    theta, phi = _canonical(theta, phi)
    s = np.sin(theta)
    return s * np.cos(phi), s * np.sin(phi), np.cos(theta)


def half_vector_slopes(theta_i, phi_i, theta_r, phi_r):
    """Slopes ``(p, q)`` of the facet that mirrors one direction into the other
    (``h`` along ``wi + wr``, both pointing away from the surface); infinite
    where ``h`` lies in the surface plane."""
    xi, yi, zi = _direction(theta_i, phi_i)
    xr, yr, zr = _direction(theta_r, phi_r)
    z = zi + zr
    with np.errstate(divide="ignore", invalid="ignore"):
        return -(xi + xr) / z, -(yi + yr) / z


def slope_density(p, q, alpha_u, alpha_v, distribution="beckmann"):
    """Slope density ``P(p, q)`` (per unit slope area) with widths alpha_u, alpha_v."""
    with np.errstate(over="ignore", invalid="ignore"):
        r2 = (p / alpha_u) ** 2 + (q / alpha_v) ** 2
        if distribution == "beckmann":
            return np.exp(-r2) / (np.pi * alpha_u * alpha_v)
        if distribution == "ggx":
            return 1.0 / (np.pi * alpha_u * alpha_v * (1.0 + r2) ** 2)
    raise ValueError(f"unknown distribution {distribution!r}; expected beckmann or ggx")


def anisotropic_D(cos_theta_h, p, q, alpha_u, alpha_v, distribution="beckmann"):
    """``D(h) = P(p, q) / cos^4 theta_h`` (1/sr per unit projected area); 0
    where ``cos theta_h <= 0`` or the slopes are not finite."""
    c = np.asarray(cos_theta_h, dtype=np.float64)
    finite = np.isfinite(p) & np.isfinite(q) & (c > 0)
    P = slope_density(np.where(finite, p, 0.0), np.where(finite, q, 0.0), alpha_u, alpha_v,
                      distribution)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        D = P / c**4
    return np.where(finite, D, 0.0)


def projected_alpha(phi, alpha_u, alpha_v):
    """Width of the slopes along azimuth *phi*: ``sqrt(cos^2 alpha_u^2 + sin^2 alpha_v^2)``."""
    return np.sqrt((np.cos(phi) * alpha_u) ** 2 + (np.sin(phi) * alpha_v) ** 2)


def smith_G1_anisotropic(theta, phi, alpha_u, alpha_v, distribution="beckmann"):
    """Smith's masking of direction (theta, phi): the isotropic G1 with the
    projected width along phi."""
    theta, phi = _canonical(theta, phi)
    return smith_G1(np.cos(theta), projected_alpha(phi, alpha_u, alpha_v), distribution)
