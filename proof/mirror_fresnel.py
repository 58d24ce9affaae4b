"""Fresnel checks of a pBRDF in the mirror direction, on the float64 reference
and on the ``pbrdf`` plugin.

1. Fresnel reflectance at normal incidence against ((n-1)^2 + k^2) / ((n+1)^2 + k^2)
   from the conductor's tabulated n, k.
2. Pseudo-Brewster angle (minimum of R_p) against the minimum of the
   closed-form (real-arithmetic, Born & Wolf) Fresnel R_p, and the Brewster angle
   arctan(n) of a dielectric.
3. Unpolarized light reflected into the mirror direction is s-polarized (S1 > 0 in
   the s/p frame) and its degree of polarization rises up to the pseudo-Brewster
   angle.

How a reflectance is read from a BRDF: in the mirror direction of a
flat-on-average surface the half vector is the normal, so D(h) = 1 / (pi alpha^2),
V-groove G = 1 and the specular lobe is D F(theta) / (4 cos^2 theta): the facet's
Fresnel Mueller matrix F at the incidence angle is 4 pi alpha^2 cos^2(theta) M,
M in 1/sr in the global s/p frames (:mod:`mitsuba_pbrdf.frames`; S1 = I_s − I_p).
Angles in degrees where named ``*_deg``, else radians; wavelengths in nm.
"""

import numpy as np

from mitsuba_pbrdf import reference
from mitsuba_pbrdf.diagnostics.physics import load_plugin, mueller_global

METALS = ("Al", "Cu", "Au", "Ag")
WAVELENGTHS = (400.0, 450.0, 500.0, 550.0, 600.0, 650.0, 700.0, 800.0)
SIGMA = 0.1                         # RMS slope of the specular lobe in these checks
ALPHA = np.sqrt(2.0) * SIGMA


# ---------------------------------------------------------------------------
# 1. Fresnel reflectance at normal incidence
# ---------------------------------------------------------------------------


def in_plane_pair(theta):
    """(to_viewer, to_light) unit vectors (n, 3) in the x-z plane: light at +x
    at ``theta`` (rad) from the normal, viewer in the mirror direction."""
    theta = np.atleast_1d(np.asarray(theta, dtype=np.float64))
    to_light = np.stack([np.sin(theta), np.zeros_like(theta), np.cos(theta)], axis=1)
    return to_light * [-1.0, 1.0, 1.0], to_light

def normal_incidence(metals=METALS, wavelengths=WAVELENGTHS, plugin=True):
    """Rows (metal, wavelength, n, k, R closed form, R reference, R plugin)."""
    rows = []
    up = np.array([[0.0, 0.0, 1.0]])
    for metal in metals:
        n, k = reference.conductor_ior(metal, wavelengths)
        closed = ((n - 1) ** 2 + k**2) / ((n + 1) ** 2 + k**2)
        # normal incidence and exit: h = z, D = 1/(pi alpha^2), G = 1, f = D R / 4
        f_ref = reference.pbrdf(0.0, 0.0, 0.0, 0.0, n, k, SIGMA)[..., 0, 0]
        r_ref = 4 * np.pi * ALPHA**2 * f_ref
        r_plugin = np.full(len(wavelengths), np.nan)
        if plugin:
            M = mueller_global(load_plugin(material=metal, sigma=SIGMA), up, up, wavelengths)
            r_plugin = 4 * np.pi * ALPHA**2 * M[0, :, 0, 0]
        for i, wl in enumerate(wavelengths):
            rows.append((metal, wl, n[i], k[i], closed[i], r_ref[i], r_plugin[i]))
    return rows


# ---------------------------------------------------------------------------
# 2. Pseudo-Brewster angle
# ---------------------------------------------------------------------------

def closed_form_reflectances(theta, n, k):
    """R_s, R_p in real arithmetic (Born & Wolf 14.4; the form of Mitsuba's
    fresnel_conductor): an implementation independent of the complex one."""
    c = np.cos(theta)
    c2, s2 = c * c, 1 - c * c
    t1 = n * n - k * k - s2
    a2pb2 = np.sqrt(t1 * t1 + 4 * n * n * k * k)
    a = np.sqrt(np.maximum(0.5 * (a2pb2 + t1), 0.0))
    term1, term2 = a2pb2 + c2, 2 * c * a
    rs = (term1 - term2) / (term1 + term2)
    term3, term4 = a2pb2 * c2 + s2 * s2, term2 * s2
    return rs, rs * (term3 - term4) / (term3 + term4)


def closed_form_pseudo_brewster(n, k):
    """The angle (rad) minimizing the closed-form R_p: bisection on the sign of
    its central-difference slope (step 1e-6 rad) down to 1e-12 rad. For k = 0 it
    is Brewster's arctan(n)."""
    def slope(t, h=1e-6):
        return (closed_form_reflectances(t + h, n, k)[1]
                - closed_form_reflectances(t - h, n, k)[1])

    lo, hi = 1e-3, 0.5 * np.pi - 1e-5
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if slope(mid) < 0 else (lo, mid)
    return 0.5 * (lo + hi)


def _golden_min(f, lo, hi, tol=1e-10):
    g = (np.sqrt(5) - 1) / 2
    a, b = lo, hi
    c, d = b - g * (b - a), a + g * (b - a)
    while b - a > tol:
        if f(c) < f(d):
            b, d = d, c
            c = b - g * (b - a)
        else:
            a, c = c, d
            d = a + g * (b - a)
    return 0.5 * (a + b)


def rp_reference(theta, n, k):
    """R_p from the reference BRDF in the mirror direction: a p-polarized input
    (S = [1, -1, 0, 0]) gives S0 = M00 - M01 = D R_p / (4 cos^2)."""
    M = reference.pbrdf(theta, 0.0, theta, np.pi, n, k, SIGMA)
    return (M[..., 0, 0] - M[..., 0, 1]) * 4 * np.pi * ALPHA**2 * np.cos(theta) ** 2


def rp_plugin(bsdf, theta, wavelength):
    """R_p of a Mitsuba BSDF with a specular lobe of width :data:`SIGMA`, read as
    :func:`rp_reference` reads the reference's."""
    to_viewer, to_light = in_plane_pair(theta)
    M = mueller_global(bsdf, to_viewer, to_light, [wavelength])[:, 0]
    return (M[:, 0, 0] - M[:, 0, 1]) * 4 * np.pi * ALPHA**2 * np.cos(theta) ** 2


def plugin_argmin(values, theta):
    """Minimum of sampled values: the vertex of the parabola through the
    lowest grid point and its two neighbours."""
    i = int(np.argmin(values))
    i = min(max(i, 1), len(values) - 2)
    y0, y1, y2 = values[i - 1:i + 2]
    step = theta[1] - theta[0]
    return theta[i] + 0.5 * step * (y0 - y2) / (y0 - 2 * y1 + y2)


PSEUDO_BREWSTER_CASES = [("Al", 450.0), ("Al", 632.8), ("Cu", 450.0), ("Cu", 632.8),
                         ("Au", 550.0), ("Ag", 550.0), ("dielectric n 1.5", 550.0)]


def pseudo_brewster(cases=PSEUDO_BREWSTER_CASES, plugin=True, step_deg=0.01):
    """Rows: (case, wavelength, n, k, closed form deg, reference deg, plugin deg,
    plugin resolution deg, min R_p). The plugin's minimum is found on a grid of
    ``step_deg`` with a parabola through the three lowest points; its
    resolution is the angle over which float32 rounding can move the minimum:
    R_p = (M00 - M01) x scale carries an error of ~2e-6 (2^-24 relative per
    operation, ~30 operations) of M00 ~ (R_s + R_p) / 2, which moves the
    minimum of R_p,min + R_p'' d^2 / 2 by up to sqrt(2 x 2e-6 (R_s + R_p) / 2 / R_p'')
    (R_p'' from the closed form)."""
    rows = []
    for name, wl in cases:
        if name.startswith("dielectric"):
            n, k = 1.5, 0.0
            params = dict(eta=1.5, k=0.0, sigma=SIGMA)
        else:
            n, k = (float(x) for x in reference.conductor_ior(name, wl))
            params = dict(material=name, sigma=SIGMA)
        closed = closed_form_pseudo_brewster(n, k)
        ref_min = _golden_min(lambda t: float(rp_reference(t, n, k)), closed - 0.05, closed + 0.05)
        rs_pb, rp_min = (float(x) for x in closed_form_reflectances(closed, n, k))
        h = 1e-3
        curvature = float((closed_form_reflectances(closed + h, n, k)[1] - 2 * rp_min
                           + closed_form_reflectances(closed - h, n, k)[1]) / h**2)
        # R_p = (M00 - M01) x scale: its float32 error is ~2e-6 of M00 ~ (R_s + R_p) / 2
        resolution = np.sqrt(2 * 2e-6 * 0.5 * (rs_pb + rp_min) / curvature)
        plugin_min = np.nan
        if plugin:
            theta = np.radians(np.arange(30.0, 89.9, step_deg))
            plugin_min = plugin_argmin(rp_plugin(load_plugin(**params), theta, wl), theta)
        rows.append((name, wl, n, k, np.degrees(closed), np.degrees(ref_min),
                     np.degrees(plugin_min), np.degrees(resolution), rp_min))
    return rows


# ---------------------------------------------------------------------------
# 3. s-polarization and degree of polarization in the mirror direction
# ---------------------------------------------------------------------------

def mirror_polarization(metal, wavelength, theta_deg, plugin=True, three_lobes=False):
    """Stokes vector (normalized by S0) of unpolarized light reflected into the
    mirror direction, reference and plugin: ({"reference": (m, 4), "plugin": (m, 4)})."""
    theta = np.radians(np.asarray(theta_deg, dtype=np.float64))
    lobes = dict(kdd=0.2, sigma_dd=0.5, kid=0.05) if three_lobes else {}
    n, k = reference.conductor_ior(metal, wavelength)
    M = reference.pbrdf(theta, 0.0, theta, np.pi, n, k, SIGMA, **lobes)
    out = {"reference": M[:, :, 0] / M[:, :1, 0]}
    if plugin:
        to_viewer, to_light = in_plane_pair(theta)
        P = mueller_global(load_plugin(material=metal, sigma=SIGMA, **lobes), to_viewer,
                           to_light, [wavelength])[:, 0]
        out["plugin"] = P[:, :, 0] / P[:, :1, 0]
    return out


def dop(stokes):
    """Degree of polarization |S1..S3| / S0 of Stokes vectors (..., 4)."""
    return np.sqrt(np.sum(stokes[..., 1:] ** 2, axis=-1)) / stokes[..., 0]


def s_polarization(metals=("Al", "Cu"), wavelengths=(450.0, 632.8), plugin=True):
    """Rows: (metal, wavelength, lobes, engine, min S1/S0 over 1..89.5 deg,
    max |S2|, |S3| / S0, DOP rises monotonically up to theta_pB, theta_pB,
    DOP at theta_pB, angle of max DOP, max DOP)."""
    theta_deg = np.arange(1.0, 89.51, 0.25)
    rows = []
    for metal in metals:
        for wl in wavelengths:
            n, k = (float(x) for x in reference.conductor_ior(metal, wl))
            pb = np.degrees(closed_form_pseudo_brewster(n, k))
            for three in (False, True):
                result = mirror_polarization(metal, wl, theta_deg, plugin, three)
                for engine, S in result.items():
                    d = dop(S)
                    rising = bool(np.all(np.diff(d[theta_deg <= pb]) > 0))
                    i = int(np.argmax(d))
                    rows.append((metal, wl, "3 lobes" if three else "specular", engine,
                                 float(S[:, 1].min()), float(np.abs(S[:, 2:]).max()), rising,
                                 pb, float(np.interp(pb, theta_deg, d)), theta_deg[i], d[i]))
    return rows
