"""Emitted Stokes vectors as Mitsuba sees them.

An emitter of Mitsuba's polarized variants returns a Mueller matrix from
``eval``, ``eval_direction``, ``sample_direction`` (and ``sample_ray``,
``sample_wavelengths``); the integrator multiplies the path's Mueller matrices
into it and reads its first column as the Stokes vector of the light. Mitsuba's
own emitters return the depolarizer ``diag(L, 0, 0, 0)`` (unpolarized light).
A polarized emitter returns a matrix whose first column is
``L * (1, q, u, v)``: q, u, v are the normalized Stokes parameters S1/S0,
S2/S0, S3/S0, expressed in the Stokes basis ``mi.mueller.stokes_basis(w)`` of
light propagating along ``w`` (x axis that vector, y axis ``w x x``, angles
counter-clockwise from x towards y when looking into the beam). For light
arriving along ``-d`` from an infinite emitter seen in direction ``d``,
``w = -d`` (``si.wi`` in ``eval``, ``-ds.d`` for a direction sample).
docs/polarized-light.md derives this and the tests check it.

Plain functions: ``mi.*`` is looked up when called, so they serve every
variant without a reload.
"""

from __future__ import annotations

import drjit as dr
import mitsuba as mi


def intensity(value):
    """The intensity (radiance spectrum) of a value an emitter returned: its
    Mueller matrix's element 00 in polarized variants, the value otherwise."""
    return value[0, 0] if mi.is_polarized else value


def emitted(radiance, q, u, v=None):
    """The Mueller matrix whose first column is ``radiance * (1, q, u, v)``
    (q, u, v: Float or spectral, normalized Stokes parameters in the basis of
    :func:`basis`); ``radiance`` itself in unpolarized variants."""
    if not mi.is_polarized:
        return radiance
    m = dr.zeros(mi.Spectrum, dr.width(radiance))
    m[0, 0] = radiance
    m[1, 0] = radiance * q
    m[2, 0] = radiance * u
    if v is not None:
        m[3, 0] = radiance * v
    return m


def basis(w):
    """``(x, y)``: the Stokes basis Mitsuba implies for light propagating
    along ``w`` (``x = mi.mueller.stokes_basis(w)``, ``y = w x x``)."""
    x = mi.mueller.stokes_basis(w)
    return x, dr.cross(w, x)


def linear_ratios(e_x, e_y, degree):
    """Normalized Stokes parameters ``(q, u)`` of light linearly polarized to
    ``degree`` along the line whose direction has components ``(e_x, e_y)``
    in the Stokes basis (any length but zero; the sign does not matter):
    ``q = degree cos 2chi``, ``u = degree sin 2chi`` without trigonometry."""
    norm2 = dr.fma(e_x, e_x, e_y * e_y)
    scale = dr.select(norm2 > 0, degree * dr.rcp(norm2), 0.0)
    return scale * (e_x * e_x - e_y * e_y), scale * 2.0 * e_x * e_y
