"""The three components of the pBRDF and their sum (paper Eq. 2-6), float64
Mueller matrices in 1/sr in the global s/p frames (see the package
docstring for frames, units and signs).
"""

import numpy as np

from ..schema import DD_DISTRIBUTIONS as DISTRIBUTIONS
from ..schema import REFERENCE_SHADOWING as SHADOWING_KINDS
from .anisotropic import anisotropic_D, half_vector_slopes, smith_G1_anisotropic
from .fresnel import _jones_rotator, fresnel_amplitudes, fresnel_unpolarized, jones_to_mueller
from .geometry import _geometry, _rotation_angles, bistatic_geometry
from .microfacet import beckmann_D, ggx_D, shadowing_G


def _check_kinds(shadowing, distribution):
    if shadowing not in SHADOWING_KINDS:
        raise ValueError(f"unknown shadowing {shadowing!r}; expected one of {SHADOWING_KINDS}")
    if distribution not in DISTRIBUTIONS:
        raise ValueError(f"unknown distribution {distribution!r}; expected one of {DISTRIBUTIONS}")


def _above(g):
    return (g["cos_i"] > 0) & (g["cos_r"] > 0)


def _anisotropic_DG(angles, g, sigma_u, sigma_v, shadowing, distribution):
    """``(D, G)`` of an anisotropic lobe (:mod:`.anisotropic`): D from the
    slope density of the half vector, Smith G1 with the width projected on
    each direction's azimuth, V-groove G from theta_h alone (as isotropic)."""
    alpha_u = np.sqrt(2.0) * np.asarray(sigma_u, dtype=np.float64)
    alpha_v = np.sqrt(2.0) * np.asarray(sigma_v, dtype=np.float64)
    p, q = half_vector_slopes(*angles)
    D = anisotropic_D(g["cos_h"], p, q, alpha_u, alpha_v, distribution)
    theta_i, theta_r = np.arccos(g["cos_i"]), np.arccos(g["cos_r"])
    if shadowing == "smith":
        G = (smith_G1_anisotropic(angles[0], angles[1], alpha_u, alpha_v, distribution)
             * smith_G1_anisotropic(angles[2], angles[3], alpha_u, alpha_v, distribution))
        G = np.where((g["cos_b"] > 0) & _above(g), G, 0.0)
    else:
        G = shadowing_G(theta_i, theta_r, g["cos_h"], g["cos_b"], alpha_u, shadowing,
                        distribution)
    return D, G


def _widths(sigma, sigma_u, sigma_v):
    """``(sigma_u, sigma_v)`` where either is given (the other defaults to
    sigma), else None: the lobe is isotropic."""
    if sigma is None and (sigma_u is None or sigma_v is None):
        raise ValueError("give sigma, or both of its refinements (sigma_u and sigma_v)")
    if sigma_u is None and sigma_v is None:
        return None
    return (sigma if sigma_u is None else sigma_u), (sigma if sigma_v is None else sigma_v)


def _lobe_DG(angles, g, sigma, widths, shadowing, distribution):
    """``(D, G)`` of a microfacet lobe of slope width *sigma*, or of the
    anisotropic *widths* ``(sigma_u, sigma_v)`` where given."""
    if widths is not None:
        return _anisotropic_DG(angles, g, *widths, shadowing, distribution)
    alpha = np.sqrt(2.0) * np.asarray(sigma, dtype=np.float64)
    # Paper Eq. 3-4: p(alpha)/cos(alpha) is the Beckmann D of the half vector
    D = (beckmann_D if distribution == "beckmann" else ggx_D)(g["cos_h"], alpha)
    if shadowing == "smith":
        G = shadowing_G(np.arccos(g["cos_i"]), np.arccos(g["cos_r"]), g["cos_h"], g["cos_b"],
                        alpha, shadowing, distribution)
    else:
        # the V-groove G (and "none") is the geometry's alone: kept with it for
        # the next width on the same geometry (a fit's)
        key = f"G {shadowing}"
        if key not in g:
            g[key] = shadowing_G(np.arccos(g["cos_i"]), np.arccos(g["cos_r"]), g["cos_h"],
                                 g["cos_b"], alpha, shadowing, distribution)
        G = g[key]
    return D, G


def specular(theta_i, phi_i, theta_r, phi_r, n, k, sigma, shadowing="vgroove",
             distribution="beckmann", sigma_u=None, sigma_v=None, geometry=None):
    """Specular Mueller BRDF ``fs`` (..., 4, 4) in the global s/p frames (paper Eq. 4-5):

        f_jk = D(h) G M_jk / (4 cos ti cos tr),   D = Beckmann with alpha = sqrt(2) sigma

    ``M`` is the facet's Fresnel Mueller matrix rotated into the global frames.
    For ``shadowing="smith"`` G is the Smith G of the same distribution and
    alpha. ``distribution="ggx"``: GGX of the same alpha. ``sigma_u``/``sigma_v``
    (either; the other defaults to sigma): anisotropic slopes along the
    surface's x and y axes (azimuth 0 and pi/2). ``geometry``: the
    :func:`~.geometry.bistatic_geometry` of these angles, computed once by a
    caller that evaluates many parameters on the same measurements (a fit).
    """
    _check_kinds(shadowing, distribution)
    g = _geometry(theta_i, phi_i, theta_r, phi_r) if geometry is None else geometry
    widths = _widths(sigma, sigma_u, sigma_v)
    shape = np.broadcast_shapes(g["cos_i"].shape, np.shape(n), np.shape(k), np.shape(sigma),
                                *(np.shape(w) for w in widths or ()))
    above = np.broadcast_to(_above(g), shape)

    D, G = _lobe_DG((theta_i, phi_i, theta_r, phi_r), g, sigma, widths, shadowing, distribution)
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = D * G / (4.0 * g["cos_i"] * g["cos_r"])
    scale = np.where(above, np.broadcast_to(scale, shape), 0.0)

    # Jones matrix of the facet in its own s/p frames, rotated into the global
    # frames: E_out = R(-eta_r) diag(r_s, r_p) R(eta_i) E_in (P-G ref. [3] of the paper)
    r_s, r_p = fresnel_amplitudes(g["cos_b"], n, k)
    eta_i, eta_r = _rotation_angles(g)
    J_facet = np.zeros(np.broadcast_shapes(r_s.shape, r_p.shape) + (2, 2), dtype=np.complex128)
    J_facet[..., 0, 0] = r_s
    J_facet[..., 1, 1] = r_p
    J = _jones_rotator(-eta_r) @ J_facet @ _jones_rotator(eta_i)
    M = jones_to_mueller(J)                                    # paper Eq. 5: M_jk

    fs = np.broadcast_to(scale, shape)[..., None, None] * np.broadcast_to(M, shape + (4, 4))
    return np.where(above[..., None, None], fs, 0.0)


def specular_unpolarized(theta_i, phi_i, theta_r, phi_r, n, k, sigma, shadowing="vgroove",
                         distribution="beckmann", sigma_u=None, sigma_v=None, geometry=None):
    """Element 00 of :func:`specular` (1/sr), in the scalar form of paper Eq. 4:

        fs = D(h) G F(beta) / (4 cos ti cos tr),   F = (|r_s|^2 + |r_p|^2) / 2

    the reflectance of unpolarized light: :func:`microfacet_lobe` times
    :func:`~.fresnel.fresnel_unpolarized`. The frame rotations of the Mueller
    form leave element 00 unchanged (a rotator's first row and column are
    (1, 0, 0, 0)), so this is the same number for a fraction of the work:
    what fits of unpolarized measurements evaluate. Arguments as :func:`specular`.
    """
    g = _geometry(theta_i, phi_i, theta_r, phi_r) if geometry is None else geometry
    return (microfacet_lobe(theta_i, phi_i, theta_r, phi_r, sigma, shadowing, distribution,
                       sigma_u, sigma_v, g)
            * fresnel_unpolarized(g["cos_b"], n, k))


def microfacet_lobe(theta_i, phi_i, theta_r, phi_r, sigma, shadowing="vgroove",
               distribution="beckmann", sigma_u=None, sigma_v=None, geometry=None):
    """``D(h) G / (4 cos ti cos tr)`` (1/sr), 0 where either direction is below
    the surface: the directional diffuse lobe, and the specular lobe's scalar
    form without its Fresnel factor. Arguments as :func:`specular`."""
    _check_kinds(shadowing, distribution)
    g = _geometry(theta_i, phi_i, theta_r, phi_r) if geometry is None else geometry
    D, G = _lobe_DG((theta_i, phi_i, theta_r, phi_r), g, sigma,
                    _widths(sigma, sigma_u, sigma_v), shadowing, distribution)
    with np.errstate(divide="ignore", invalid="ignore"):
        f = D * G / (4.0 * g["cos_i"] * g["cos_r"])
    return np.where(_above(g), f, 0.0)


def directional_diffuse(theta_i, phi_i, theta_r, phi_r, sigma_dd, shadowing="vgroove",
                        distribution="beckmann", sigma_dd_u=None, sigma_dd_v=None,
                        geometry=None):
    """Directional diffuse BRDF ``fdd = Ddd(h) G / (4 cos ti cos tr)`` (1/sr, a
    scalar: this lobe is depolarized; :func:`microfacet_lobe`). ``Ddd`` has width
    ``alpha_dd = sqrt(2) sigma_dd`` and is Beckmann or GGX; for
    ``shadowing="smith"`` G uses that distribution and width.
    ``sigma_dd_u``/``sigma_dd_v``: anisotropic, as :func:`specular`."""
    return microfacet_lobe(theta_i, phi_i, theta_r, phi_r, sigma_dd, shadowing, distribution,
                      sigma_dd_u, sigma_dd_v, geometry)


def ideal_diffuse(theta_i, theta_r):
    """Lambertian ``fid = 1/pi`` (1/sr) where both directions are above the surface."""
    cos_i = np.cos(np.asarray(theta_i, dtype=np.float64))
    cos_r = np.cos(np.asarray(theta_r, dtype=np.float64))
    return np.where((cos_i > 0) & (cos_r > 0), 1.0 / np.pi, 0.0)


def pbrdf(theta_i, phi_i, theta_r, phi_r, n, k, sigma=None, ks=1.0, kdd=0.0, sigma_dd=0.5,
          kid=0.0, shadowing="vgroove", dd_distribution="beckmann", distribution="beckmann",
          sigma_u=None, sigma_v=None, sigma_dd_u=None, sigma_dd_v=None):
    """The full pBRDF (paper Eq. 2, 5, 6), a float64 array (..., 4, 4) in 1/sr::

        F = ks Fs + [kdd fdd + kid / pi] D0

    All arguments broadcast against each other (e.g. angles of shape (m, 1) and
    ``n, k, ks`` of shape (w,) for w wavelengths give (m, w, 4, 4)). Apply it to
    a Stokes vector of the incident light (frame ``s_in``) to get the reflected
    Stokes vector (frame ``s_out``) per unit irradiance, paper Eq. 6.
    ``distribution``: the specular lobe's (``dd_distribution``: the directional
    diffuse lobe's); ``sigma_u``... : anisotropic widths (:func:`specular`);
    ``sigma`` may be left out where ``sigma_u`` and ``sigma_v`` are given.
    """
    _check_kinds(shadowing, dd_distribution)
    _check_kinds(shadowing, distribution)
    Fs = specular(theta_i, phi_i, theta_r, phi_r, n, k, sigma, shadowing, distribution,
                  sigma_u, sigma_v)
    fdd = directional_diffuse(theta_i, phi_i, theta_r, phi_r, sigma_dd, shadowing, dd_distribution,
                              sigma_dd_u, sigma_dd_v)
    fid = ideal_diffuse(theta_i, theta_r)
    ks = np.asarray(ks, dtype=np.float64)
    depolarized = np.asarray(kdd, dtype=np.float64) * fdd + np.asarray(kid, dtype=np.float64) * fid
    shape = np.broadcast_shapes(Fs.shape[:-2], ks.shape, depolarized.shape)
    F = np.broadcast_to(ks, shape)[..., None, None] * Fs
    F[..., 0, 0] += np.broadcast_to(depolarized, shape)               # times D0
    return F
