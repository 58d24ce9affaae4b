"""White furnace: the directional-hemispherical albedo of each lobe.

The albedo of a lobe for unpolarized light arriving from wi (the M00 element) is

    a(wi) = int f(wi, wo) cos(theta_o) dwo        (dimensionless; f in 1/sr)

With a Fresnel factor of 1 it measures how much energy the microfacet lobe's
D and G keep: a > 1 creates energy, a < 1 loses it. Two estimates, independent
of each other:

* :func:`reference_albedo`: deterministic quadrature of the float64 reference
  over the half vector h (the lobe's natural variable; dwo = 4 (wi.h) dwh),
  Gauss-Legendre in v = (2/pi) arctan(tan(theta_h) / alpha) and the trapezoid
  rule in phi_h; its error estimated by halving the number of points
  (:func:`reference_albedo_with_error`);
* :func:`sampled_albedo`: Monte Carlo with a Mitsuba BSDF's own importance
  sampling, a = E[weight_00] over ``bsdf.sample`` (weight = eval / pdf, cosine
  included), with its standard error. Any BSDF of a polarized spectral variant;
  :func:`plugin_albedo` loads the ``pbrdf`` lobe that matches the reference's.

Lobes (``lobe`` argument): "beckmann" (the specular lobe's geometry D G /
(4 cos cos) without Fresnel, Beckmann width alpha = sqrt(2) sigma; plugin: the
specular lobe of a perfect conductor n = 1, k = 1e4, R >= 0.9999), "ggx" (the
GGX directional diffuse lobe, kdd = 1), a metal name (its specular lobe at
:data:`WAVELENGTH`), "lambert" (the ideal diffuse lobe, kid = 1, exactly 1).
Angles in degrees, wavelengths in nm, directions in the surface's local frame
(z = normal; the light in the x-z plane).
"""

import numpy as np

from .. import reference

PERFECT_CONDUCTOR = dict(eta=1.0, k=1e4)
WAVELENGTH = 550.0
#: Systematic allowance of the plugin-vs-reference comparison, relative: the
#: perfect conductor's R >= 0.9999 (1e-4) and float32 weights (~1e-6).
SYSTEMATIC = 1e-4


# ---------------------------------------------------------------------------
# Reference: quadrature over the half vector
# ---------------------------------------------------------------------------

def _half_vector_nodes(alpha, n_theta, n_phi):
    """Nodes (theta_h, phi_h) and weights of dwh over the upper hemisphere."""
    x, w = np.polynomial.legendre.leggauss(n_theta)
    v = 0.5 * (x + 1.0)                               # (0, 1)
    w = 0.5 * w
    t = np.tan(0.5 * np.pi * v)
    theta = np.arctan(alpha * t)
    dtheta = alpha * 0.5 * np.pi / np.cos(0.5 * np.pi * v) ** 2 / (1 + (alpha * t) ** 2)
    phi = (np.arange(n_phi) + 0.5) * 2 * np.pi / n_phi
    th, ph = np.meshgrid(theta, phi, indexing="ij")
    weight = (w * dtheta * np.sin(theta))[:, None] * (2 * np.pi / n_phi) * np.ones_like(ph)
    return th.ravel(), ph.ravel(), weight.ravel()


def reference_albedo(lobe, theta_i_deg, sigma, shadowing, n_theta=256, n_phi=256):
    """Albedo of one lobe at incidence theta_i by half-vector quadrature.

    ``lobe``: "beckmann" or "ggx" (microfacet lobe without Fresnel) or a
    metal name (its specular lobe at WAVELENGTH)."""
    ti = np.radians(theta_i_deg)
    alpha = np.sqrt(2.0) * sigma
    th, ph, weight = _half_vector_nodes(alpha, n_theta, n_phi)
    wi = np.array([np.sin(ti), 0.0, np.cos(ti)])
    h = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], axis=-1)
    cos_b = h @ wi
    wo = 2 * cos_b[:, None] * h - wi
    keep = (cos_b > 0) & (wo[:, 2] > 0)
    h, cos_b, wo, weight = h[keep], cos_b[keep], wo[keep], weight[keep]
    theta_o = np.arccos(np.clip(wo[:, 2], -1, 1))
    phi_o = np.arctan2(wo[:, 1], wo[:, 0])
    if lobe in ("beckmann", "ggx"):
        f = reference.directional_diffuse(ti, 0.0, theta_o, phi_o, sigma, shadowing, lobe)
    else:
        n, k = reference.conductor_ior(lobe, WAVELENGTH)
        f = reference.specular(ti, 0.0, theta_o, phi_o, n, k, sigma, shadowing)[..., 0, 0]
    return float(np.sum(f * wo[:, 2] * 4 * cos_b * weight))


def reference_albedo_with_error(lobe, theta_i_deg, sigma, shadowing, n=256):
    """(albedo, |albedo(n) - albedo(n/2)|: an upper estimate of the quadrature error)."""
    a = reference_albedo(lobe, theta_i_deg, sigma, shadowing, n, n)
    b = reference_albedo(lobe, theta_i_deg, sigma, shadowing, n // 2, n // 2)
    return a, abs(a - b)


# ---------------------------------------------------------------------------
# Monte Carlo with a BSDF's own sampling
# ---------------------------------------------------------------------------

def sampled_albedo(bsdf, theta_i_deg, samples=1 << 20, seed=0, wavelength=WAVELENGTH):
    """(albedo, standard error) of any Mitsuba BSDF (polarized spectral
    variant) for unpolarized light from ``theta_i_deg``: the mean M00 of
    ``bsdf.sample``'s weight at ``wavelength`` over ``samples`` draws."""
    import drjit as dr
    import mitsuba as mi

    ti = np.radians(theta_i_deg)
    rng = np.random.default_rng(seed)
    si = dr.zeros(mi.SurfaceInteraction3f, samples)
    si.wi = mi.Vector3f(float(np.sin(ti)), 0.0, float(np.cos(ti)))
    si.wavelengths = mi.UnpolarizedSpectrum(wavelength)
    _, weight = bsdf.sample(mi.BSDFContext(), si,
                            mi.Float(rng.random(samples, dtype=np.float32)),
                            mi.Point2f(*rng.random((2, samples), dtype=np.float32)))
    w = np.asarray(weight[0, 0], dtype=np.float64)      # (4 wavelengths, samples)
    w = w[0] if w.ndim == 2 else w
    return float(w.mean()), float(w.std(ddof=1) / np.sqrt(samples))


def plugin_params(lobe, sigma, shadowing):
    """``pbrdf`` parameters of one lobe (see the module docstring)."""
    if lobe == "beckmann":                       # the specular lobe of a perfect conductor
        return dict(PERFECT_CONDUCTOR, sigma=sigma, shadowing=shadowing)
    if lobe == "ggx":
        return dict(ks=0.0, kdd=1.0, sigma_dd=sigma, dd_distribution="ggx", shadowing=shadowing)
    if lobe == "beckmann-dd":
        return dict(ks=0.0, kdd=1.0, sigma_dd=sigma, shadowing=shadowing)
    if lobe == "lambert":
        return dict(ks=0.0, kid=1.0)
    return dict(material=lobe, sigma=sigma, shadowing=shadowing)


def plugin_albedo(lobe, theta_i_deg, sigma, shadowing, samples=1 << 20, seed=0):
    """(albedo, standard error) of the plugin's lobe by sampling, M00 of the weight."""
    import mitsuba as mi

    bsdf = mi.load_dict(dict({"type": "pbrdf"}, **plugin_params(lobe, sigma, shadowing)))
    return sampled_albedo(bsdf, theta_i_deg, samples, seed)
