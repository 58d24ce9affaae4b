"""Mueller matrices and Stokes bases in Mitsuba's conventions: the helpers
that the package's BSDFs, integrators and emitters share.

**Rotations** (:func:`rotator_entries`, :func:`rotate_mueller`,
:func:`rotate_mueller_basis`, :func:`to_world_mueller`): Mitsuba's
``mueller.rotate_stokes_basis``, ``mueller.rotate_mueller_basis`` and
``SurfaceInteraction3f.to_world_mueller`` without trigonometry, same
convention, same results up to float32 rounding.

Mitsuba finds the rotation angle θ between two basis vectors with an inverse
sine and then takes ``sincos(2θ)``; a Mueller rotator needs only
``cos 2θ`` and ``sin 2θ``, which follow from ``cos θ = a·b`` and
``sin θ = forward·(a × b)`` by the double-angle formulas. That removes two
transcendental functions per rotation and their adjoints (a pbrdf inside a
``polarized_normalmap`` evaluated in 0.74 to 0.82 of the time, 0.90 to 0.94
with its adjoint: benchmarks/bsdf_adjoint.md), and keeps the derivative
finite where θ = 0, where the angle Mitsuba measures, ``2 asin(|a - b| / 2)``,
has none.

A rotator mixes only Stokes components 1 and 2, so products are written out
element by element; Dr.Jit folds the literal zeros of sparse matrices such as
a facet's Fresnel matrix or a depolarizer.

**Perturbed shading frames** (:func:`to_unperturbed_bases`): the Stokes-basis
correction shared by ``polarized_normalmap`` and ``polarized_bumpmap``
(docs/conventions.md, "Normal and bump maps").

Mitsuba's convention: a BSDF's Mueller matrix maps a Stokes vector in the basis
``stokes_basis(-wo_hat)`` (light arriving along ``-wo_hat``) to one in the basis
``stokes_basis(wi_hat)`` (light leaving along ``wi_hat``), where ``wo_hat,
wi_hat = wo, wi`` in Radiance mode and ``wi, wo`` in Importance mode, the
directions and basis vectors being written in the BSDF's local shading frame.
A nested BSDF evaluated in a perturbed frame P therefore hands back bases built
from P-local coordinates; the integrator converts them to world space through
the unperturbed frame S. Both are rotations about the propagation direction, so
one Stokes rotator per side fixes the matrix.

**Emitted light** (:func:`emitted`, :func:`basis`, :func:`intensity`,
:func:`linear_ratios`; a filter in front of an emitter:
:func:`linear_diattenuator`, :func:`times`). An emitter of Mitsuba's
polarized variants returns a Mueller matrix from ``eval``,
``eval_direction``, ``sample_direction`` (and ``sample_ray``,
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

Plain functions: ``mi.*`` types are looked up when called, so the module
serves every variant without a reload.
"""

from __future__ import annotations

import drjit as dr
import mitsuba as mi


def rotator_entries(forward, basis_current, basis_target):
    """``(cos 2θ, sin 2θ)`` of Mitsuba's ``mueller.rotate_stokes_basis(forward,
    basis_current, basis_target)``: θ is the angle from ``basis_current`` to
    ``basis_target`` (unit vectors orthogonal to the unit vector ``forward``),
    counter-clockwise about ``forward``."""
    c = dr.dot(basis_current, basis_target)
    s = dr.dot(forward, dr.cross(basis_current, basis_target))
    # The two vectors are unit length up to rounding: normalize the pair.
    inv = dr.rsqrt(dr.maximum(c * c + s * s, 1e-30))
    c, s = c * inv, s * inv
    return c * c - s * s, 2.0 * c * s


def rotate_mueller(M, in_entries, out_entries):
    """``R_out · M · R_inᵀ`` (Mitsuba's ``rotate_mueller_basis``) for rotators
    given by their ``(cos 2θ, sin 2θ)``."""
    ci, si_ = in_entries
    co, so = out_entries
    R = dr.zeros(mi.Spectrum, dr.width(ci))
    rows = [[M[i, j] for j in range(4)] for i in range(4)]
    # rows of R_out · M
    r1 = [co * a + so * b for a, b in zip(rows[1], rows[2])]
    r2 = [co * b - so * a for a, b in zip(rows[1], rows[2])]
    rows[1], rows[2] = r1, r2
    # columns of (R_out · M) · R_inᵀ
    for row in rows:
        a, b = row[1], row[2]
        row[1], row[2] = ci * a + si_ * b, ci * b - si_ * a
    for i in range(4):
        for j in range(4):
            R[i, j] = rows[i][j]
    return R


def rotate_mueller_basis(M, in_forward, in_basis_current, in_basis_target,
                         out_forward, out_basis_current, out_basis_target):
    """Mitsuba's ``mueller.rotate_mueller_basis``: ``M`` maps Stokes vectors
    of light travelling along ``in_forward`` in the basis ``in_basis_current``
    to light along ``out_forward`` in ``out_basis_current``; the result does
    the same in the ``*_target`` bases (all unit vectors)."""
    return rotate_mueller(M, rotator_entries(in_forward, in_basis_current, in_basis_target),
                          rotator_entries(out_forward, out_basis_current, out_basis_target))


def to_world_mueller(si, M, wo_local, wi_local):
    """``si.to_world_mueller(M, wo_local, wi_local)``: a Mueller matrix in the
    implicit Stokes bases of the shading-frame directions ``wo_local`` (light
    arriving, propagation direction) and ``wi_local`` (light leaving)
    re-expressed in the implicit bases of the same directions in world space."""
    in_forward = si.to_world(wo_local)
    out_forward = si.to_world(wi_local)
    return rotate_mueller_basis(
        M, in_forward, si.to_world(mi.mueller.stokes_basis(wo_local)),
        mi.mueller.stokes_basis(in_forward),
        out_forward, si.to_world(mi.mueller.stokes_basis(wi_local)),
        mi.mueller.stokes_basis(out_forward))


# ------------------------------------------------- perturbed shading frames


def to_unperturbed_bases(ctx, value, frame_wrt_si, wo_p, wi_p):
    """Re-express ``value``, a Mueller matrix a nested BSDF returned for the
    P-local directions ``wi_p`` (``si.wi``) and ``wo_p`` in the perturbed frame
    P (``frame_wrt_si``: P's axes in the unperturbed shading frame S), in the
    Stokes bases of the same directions written in S. Unpolarized variants:
    ``value`` unchanged."""
    if not mi.is_polarized:
        return value
    radiance = ctx.mode == mi.TransportMode.Radiance
    wo_hat_p, wi_hat_p = (wo_p, wi_p) if radiance else (wi_p, wo_p)
    to_s = frame_wrt_si.to_world  # P-local -> S-local
    in_forward = to_s(-wo_hat_p)
    out_forward = to_s(wi_hat_p)
    in_entries = rotator_entries(in_forward, to_s(mi.mueller.stokes_basis(-wo_hat_p)),
                                 mi.mueller.stokes_basis(in_forward))
    out_entries = rotator_entries(out_forward, to_s(mi.mueller.stokes_basis(wi_hat_p)),
                                  mi.mueller.stokes_basis(out_forward))
    return rotate_mueller(value, in_entries, out_entries)


# ------------------------------------------------------------ emitted light


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


def linear_diattenuator(e_x, e_y, degree, transmittance):
    """The Mueller matrix (4 x 4 nested lists, row-major, of Floats or floats)
    of a linear diattenuator whose transmission axis has components ``(e_x,
    e_y)`` in the Stokes basis (any length; zero: no axis, the filter passes
    every state, ``transmittance`` times the identity), polarizing
    unpolarized light to ``degree`` p and passing ``transmittance`` T of its
    intensity: principal transmittances T (1 + p) along the axis and
    T (1 - p) across it, so that with ``c, s = cos 2chi, sin 2chi`` and
    ``k = sqrt(1 - p²)``::

        T [[1,   p c,            p s,            0],
           [p c, c² + k s²,      (1 - k) c s,    0],
           [p s, (1 - k) c s,    s² + k c²,      0],
           [0,   0,              0,              k]]

    (Chipman's homogeneous diattenuator). p = 1 is an ideal polarizer (of
    gain 2T): two at angle theta pass ``cos² theta`` (Malus)."""
    c, s = linear_ratios(e_x, e_y, 1.0)
    off = 1.0 - (c * c + s * s)           # 1 where there is no axis, else 0
    k = (1.0 - degree * degree) ** 0.5
    p = degree
    rows = [[1.0, p * c, p * s, 0.0],
            [p * c, c * c + k * s * s + off, (1.0 - k) * c * s, 0.0],
            [p * s, (1.0 - k) * c * s, s * s + k * c * c + off, 0.0],
            [0.0, 0.0, 0.0, k + off * (1.0 - k)]]
    return [[transmittance * e for e in row] for row in rows]


def times(rows, value):
    """``rows · value``: the Mueller matrix ``rows`` (4 x 4 nested lists of
    Floats or floats, the same for every wavelength) applied to ``value``,
    a ``mi.Spectrum`` Mueller matrix (polarized variants)."""
    out = dr.zeros(mi.Spectrum, dr.width(value))
    for i in range(4):
        for j in range(4):
            out[i, j] = sum(rows[i][k] * value[k, j] for k in range(4))
    return out


def linear_ratios(e_x, e_y, degree):
    """Normalized Stokes parameters ``(q, u)`` of light linearly polarized to
    ``degree`` along the line whose direction has components ``(e_x, e_y)``
    in the Stokes basis (any length but zero; the sign does not matter):
    ``q = degree cos 2chi``, ``u = degree sin 2chi`` without trigonometry."""
    norm2 = dr.fma(e_x, e_x, e_y * e_y)
    scale = dr.select(norm2 > 0, degree * dr.rcp(norm2), 0.0)
    return scale * (e_x * e_x - e_y * e_y), scale * 2.0 * e_x * e_y
