"""The geometry of ``.pbsdf`` tables, as Mitsuba's ``measured_polarized``
(``src/bsdfs/measured_polarized.cpp``, Mitsuba 3.9.1) reads them: the
Rusinkiewicz angles of a pair of directions, and the Stokes frames of the
table's Mueller matrices. NumPy only.

Directions (arrays ``(..., 3)`` in the local frame, z the surface normal):
``L`` points from the surface towards the light, ``V`` towards the viewer
(``measured_polarized``'s ``wo_hat`` and ``wi_hat`` in radiance mode; the
reference evaluator's ``wi`` and ``wr``).

**Rusinkiewicz angles** (radians): ``h = normalize(L + V)``,
``theta_h = acos(h . z)``, ``theta_d = acos(h . L)``; with the binormal
``b = normalize(z x h)`` and tangent ``t = normalize(b x h)`` (``t`` is the
direction of increasing theta at h), ``phi_d = atan2(b . L_p, t . L_p)`` in
(-pi, pi] where ``L_p`` is L projected perpendicular to h. In-plane geometries
have ``phi_d`` = 0 or +-pi; swapping L and V adds pi to ``phi_d``.

**Stokes frames of the table**: both the input frame (light propagating along
``-L``) and the output frame (propagating along ``V``) have the x-axis
``x_f = normalize(L x V)``, perpendicular to the plane of L and V: the
facet's s-axis (the reference evaluator's ``s_f``). ``measured_polarized``
rotates these into Mitsuba's implicit ``stokes_basis`` frames; here
:func:`facet_to_global` rotates them into the reference evaluator's global s/p
frames (x-axis ``normalize(z x d)`` for propagation ``d``, the surface x-axis
at normal incidence). Where ``L = V`` (``theta_d = 0``) any common x-axis
gives the same matrix (the facet reflects at normal incidence); the global
input axis is used.

**Values**: Mueller BRDFs in 1/sr without the cosine factor;
``measured_polarized`` multiplies by the cosine of the light direction itself.
"""

from __future__ import annotations

import numpy as np

from ..reference import rotator

__all__ = ["directions", "angles", "rusinkiewicz", "spherical", "facet_axis",
           "global_axis", "facet_to_global", "global_to_facet"]

_Z = np.array([0.0, 0.0, 1.0])


def _normalize(v):
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        return v / n, n[..., 0]


def directions(phi_d, theta_d, theta_h):
    """``(L, V)`` of Rusinkiewicz angles (broadcast), with h in the x-z plane
    (``phi_h = 0``): ``b = y``, ``t = (cos theta_h, 0, -sin theta_h)``,
    ``L = cos theta_d h + sin theta_d (cos phi_d t + sin phi_d b)`` and ``V``
    its mirror image about h. Well defined at ``theta_h = 0``."""
    pd, td, th = np.broadcast_arrays(*(np.asarray(a, dtype=np.float64)
                                       for a in (phi_d, theta_d, theta_h)))
    h = np.stack([np.sin(th), np.zeros_like(th), np.cos(th)], -1)
    t = np.stack([np.cos(th), np.zeros_like(th), -np.sin(th)], -1)
    b = np.broadcast_to([0.0, 1.0, 0.0], h.shape)
    sd = np.sin(td)[..., None]
    L = np.cos(td)[..., None] * h + sd * (np.cos(pd)[..., None] * t + np.sin(pd)[..., None] * b)
    V = 2.0 * np.cos(td)[..., None] * h - L
    return L, V


def rusinkiewicz(L, V):
    """``(phi_d, theta_d, theta_h)`` of directions ``L``, ``V`` (..., 3), as
    ``measured_polarized`` computes them (its ``phi_d`` is NaN at
    ``theta_h = 0``; here the binormal falls back to the y-axis there)."""
    h, _ = _normalize(np.asarray(L, np.float64) + np.asarray(V, np.float64))
    theta_h = np.arccos(np.clip(h[..., 2], -1.0, 1.0))
    theta_d = np.arccos(np.clip(np.sum(h * L, -1), -1.0, 1.0))
    b, nb = _normalize(np.cross(_Z, h))
    b = np.where((nb > 1e-12)[..., None], b, [0.0, 1.0, 0.0])
    t, _ = _normalize(np.cross(b, h))
    Lp = L - np.sum(L * h, -1, keepdims=True) * h
    phi_d = np.arctan2(np.sum(b * Lp, -1), np.sum(t * Lp, -1))
    return phi_d, theta_d, theta_h


def spherical(w):
    """``(theta, phi)`` of directions ``w`` (..., 3), radians."""
    w = np.asarray(w, dtype=np.float64)
    return np.arctan2(np.hypot(w[..., 0], w[..., 1]), w[..., 2]), np.arctan2(w[..., 1], w[..., 0])


def angles(L, V):
    """``(theta_i, phi_i, theta_r, phi_r)`` of the reference evaluator, radians."""
    return spherical(L) + spherical(V)


def global_axis(d):
    """The reference's global s-axis of a ray propagating along ``d``:
    ``normalize(z x d)``, the surface x-axis where ``d`` is along z."""
    s, n = _normalize(np.cross(_Z, d))
    return np.where((n > 0)[..., None], s, [1.0, 0.0, 0.0])


def facet_axis(L, V):
    """The table's common x-axis ``normalize(L x V)`` (the global input axis
    where L and V are parallel)."""
    x, n = _normalize(np.cross(L, V))
    return np.where((n > 1e-12)[..., None], x, global_axis(-np.asarray(L, np.float64)))


def _angle(forward, a, b):
    """Signed angle from basis vector ``a`` to ``b`` about ``forward``
    (Mitsuba's ``rotate_stokes_basis``: positive when forward . (a x b) > 0)."""
    return np.arctan2(np.sum(forward * np.cross(a, b), -1), np.sum(a * b, -1))


def _rotations(L, V):
    L = np.asarray(L, dtype=np.float64)
    V = np.asarray(V, dtype=np.float64)
    x = facet_axis(L, V)
    d_in, d_out = -L, V
    return (_angle(d_in, x, global_axis(d_in)), _angle(d_out, x, global_axis(d_out)))


def _rotators(M, L, V):
    """Input and output rotators, with axes added for M's extra axes (e.g.
    wavelengths) between the geometry's and the 4 x 4."""
    a_in, a_out = _rotations(L, V)
    extra = (1,) * (np.ndim(M) - 2 - a_in.ndim)
    return (rotator(a_in).reshape(a_in.shape + extra + (4, 4)),
            rotator(a_out).reshape(a_out.shape + extra + (4, 4)))


def facet_to_global(M, L, V):
    """Mueller matrices ``M`` (geometry..., [wavelengths...,] 4, 4) in the
    table's frames re-expressed in the reference's global s/p frames:
    ``R_out M R_in^T``."""
    R_in, R_out = _rotators(M, L, V)
    return R_out @ M @ np.swapaxes(R_in, -1, -2)


def global_to_facet(M, L, V):
    """The inverse of :func:`facet_to_global`."""
    R_in, R_out = _rotators(M, L, V)
    return np.swapaxes(R_out, -1, -2) @ M @ R_in
