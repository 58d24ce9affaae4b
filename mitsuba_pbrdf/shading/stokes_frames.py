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

import mitsuba as mi

from ..plugin.rotators import rotate_mueller, rotator_entries

__all__ = ["rotator_entries", "rotate_mueller", "to_unperturbed_bases"]


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
