"""The polarization pattern of the clear sky: the normalized Stokes parameters
``(q, u) = (S1/S0, S2/S0)`` of skylight propagating along ``w`` (seen in
direction ``-w``), in Mitsuba's Stokes basis of ``w``
(:func:`mitsuba_pbrdf.mueller.basis`). Skylight is linearly polarized: ``S3 = 0``.

**Single scattering (Rayleigh).** A dipole scatterer lit by the sun radiates,
towards a viewer at scattering angle gamma (the angle between the viewing
direction ``v = -w`` and the direction ``s`` towards the sun), light whose
electric field is perpendicular to the scattering plane (the plane holding
``s`` and ``v``), to the degree ``sin² gamma / (1 + cos² gamma)``; multiple
scattering and aerosols lower the maximum, which ``dolp_max`` scales::

    DoLP = dolp_max sin² gamma / (1 + cos² gamma)

The scattering plane's trace in the basis is the projection ``(s.x, s.y)`` of
the sun direction; the field is perpendicular to it, so without trigonometry
``q + i u = -dolp_max (s.x + i s.y)² / (1 + (s.w)²)`` (``|s.x + i s.y|² =
sin² gamma``).

**Neutral points (Berry, Dennis and Lee 2004).** M. V. Berry, M. R. Dennis and
R. L. Lee Jr, "Polarization singularities in the clear sky", New J. Phys. 6
(2004) 162. Multiple scattering splits the Rayleigh pattern's zero at the sun
into two zeros of index 1/2 on the sun's vertical circle, the Babinet point
above the sun and the Brewster point below it, ``delta`` apart, and the zero
at the anti-sun into the Arago point and a fourth point, antipodal to them.
The paper writes the pattern on the stereographic plane
``zeta = tan(theta/2) exp(i phi)`` as
``w(zeta) = -4 (zeta - zeta_Ba)(zeta - zeta_Br)(zeta + 1/zeta_Br*)(zeta + 1/zeta_Ba*) /
[(1 + |zeta|²)² |zeta_Ba + 1/zeta_Ba*| |zeta_Br + 1/zeta_Br*|]``,
the polarization direction at ``arg(w)/2`` from the sun's meridian and the
degree ``dolp_max |w| / (2 - |w|)``, which is the Rayleigh pattern when
``delta = 0``. On the sphere each pair of factors
``(zeta - p)(zeta + 1/p*) / |p + 1/p*|`` is ``(1 + |zeta|²)/2`` times the unit
tangent at the viewing direction of the great circle from ``p`` through it,
scaled by ``sin gamma_p`` (the angle from ``p``): with ``P = (p.x + i p.y)``
the projection of a neutral point onto the basis (``|P| = sin gamma_p``),

    q + i u = dolp_max W / (2 - |W|),    W = -P_Ba P_Br

(``P_Ba = P_Br`` gives the Rayleigh pattern above). This vector form is
continuous where the Babinet point crosses the zenith, where the
stereographic form's normalization changes sign; elsewhere the two agree
(tests/emitters/test_polarized_light.py compares them). The paper's further
depolarization near the horizon is not modelled.
"""

from __future__ import annotations

import math

import drjit as dr

from ..mueller import basis


def rayleigh(w, sun, dolp_max):
    """``(q, u)`` of single-scattering skylight propagating along ``w`` (unit),
    the sun towards ``sun`` (unit)."""
    x, y = basis(w)
    sx, sy = dr.dot(sun, x), dr.dot(sun, y)
    cos_gamma = dr.dot(sun, w)   # -cos(gamma); only its square is used
    scale = -dolp_max * dr.rcp(dr.fma(cos_gamma, cos_gamma, 1.0))
    return scale * (sx * sx - sy * sy), scale * 2.0 * sx * sy


def berry(w, babinet, brewster, dolp_max):
    """``(q, u)`` of skylight propagating along ``w`` in Berry, Dennis and
    Lee's pattern with neutral points ``babinet`` and ``brewster`` (unit
    vectors; the Arago and fourth points are their antipodes)."""
    x, y = basis(w)
    ax, ay = dr.dot(babinet, x), dr.dot(babinet, y)
    bx, by = dr.dot(brewster, x), dr.dot(brewster, y)
    re = -(ax * bx - ay * by)
    im = -(ax * by + ay * bx)
    modulus = dr.sqrt(dr.maximum(dr.fma(ax, ax, ay * ay) * dr.fma(bx, bx, by * by), 0.0))
    scale = dolp_max * dr.rcp(2.0 - modulus)
    return scale * re, scale * im


def neutral_points(sun, zenith, separation_deg, horizontal):
    """``(babinet, brewster)``: unit vectors ``separation_deg / 2`` above and
    below ``sun`` (unit) on its vertical circle, the great circle through the
    zenith and the sun. ``horizontal`` fixes that circle where the sun is at
    the zenith or the nadir. Dr.Jit vectors, differentiable in ``sun``."""
    down = dr.fma(dr.dot(sun, zenith), sun, -zenith)       # increasing zenith angle
    edge = horizontal - dr.dot(horizontal, sun) * sun
    down = dr.normalize(dr.select(dr.squared_norm(down) > 1e-12, down, edge))
    half = math.radians(separation_deg) / 2.0
    c, s = math.cos(half), math.sin(half)
    return c * sun - s * down, c * sun + s * down
