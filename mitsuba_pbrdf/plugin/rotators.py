"""Stokes-basis rotations without trigonometry: Mitsuba's
``mueller.rotate_stokes_basis``, ``mueller.rotate_mueller_basis`` and
``SurfaceInteraction3f.to_world_mueller``, same convention, same results up
to float32 rounding.

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
a facet's Fresnel matrix or a depolarizer. Plain functions: ``mi.*`` types
are looked up when called, so the module serves every polarized variant.
"""

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
