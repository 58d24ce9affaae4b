"""The Stokes-basis correction shared by ``polarized_normalmap`` and
``polarized_bumpmap``: a Mueller matrix that a nested BSDF returned in the
Stokes bases of a perturbed shading frame, re-expressed in the bases that the
integrator expects for the unperturbed shading frame (docs/conventions.md,
"Normal and bump maps").

Mitsuba's convention: a BSDF's Mueller matrix maps a Stokes vector in the basis
``stokes_basis(-wo_hat)`` (light arriving along ``-wo_hat``) to one in the basis
``stokes_basis(wi_hat)`` (light leaving along ``wi_hat``), where ``wo_hat,
wi_hat = wo, wi`` in Radiance mode and ``wi, wo`` in Importance mode, the
directions and basis vectors being written in the BSDF's local shading frame.
A nested BSDF evaluated in a perturbed frame P therefore hands back bases built
from P-local coordinates; the integrator converts them to world space through
the unperturbed frame S. Both are rotations about the propagation direction, so
one Stokes rotator per side fixes the matrix.

Plain functions (no class bound to a variant's ``mi.BSDF``): ``mi.*`` types are
looked up when called, so the module serves every variant without a reload.
"""

import drjit as dr
import mitsuba as mi


def rotator_entries(forward, basis_current, basis_target):
    """``(cos 2θ, sin 2θ)`` of Mitsuba's ``mueller.rotate_stokes_basis(forward,
    basis_current, basis_target)``: θ is the angle from ``basis_current`` to
    ``basis_target`` (unit vectors orthogonal to the unit vector ``forward``),
    counter-clockwise about ``forward``.

    Computed from cos θ and sin θ directly (no ``acos``), so the derivatives
    stay finite where θ = 0 (a flat normal map)."""
    c = dr.dot(basis_current, basis_target)
    s = dr.dot(forward, dr.cross(basis_current, basis_target))
    # The two vectors are unit length up to rounding: normalize the pair.
    inv = dr.rsqrt(dr.maximum(c * c + s * s, 1e-30))
    c, s = c * inv, s * inv
    return c * c - s * s, 2.0 * c * s


def rotate_mueller(M, in_entries, out_entries):
    """``R_out · M · R_inᵀ`` (Mitsuba's ``rotate_mueller_basis``) for rotators
    given by their ``(cos 2θ, sin 2θ)``. A rotator mixes only Stokes rows and
    columns 1 and 2, so the product is written out element by element."""
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
