"""Fresnel reflection at a facet (the M_jk of paper Eq. 5): complex amplitudes,
Jones to Mueller, and the rotator that changes a Stokes vector's basis.
Conventions in the package docstring (:mod:`mitsuba_pbrdf.reference`).
"""

import numpy as np


def fresnel_amplitudes(cos_beta, n, k):
    """Complex reflection amplitudes ``(r_s, r_p)`` at local incidence angle beta.

    ``N = n + i k`` (``exp(-i w t)``), right-handed ``(s, p, d)`` frames for both
    waves, so ``r_p = -r_s`` at normal incidence (see the module docstring).
    ``w = N cos(theta_t) = sqrt(N^2 - sin^2 beta)`` is the principal root, whose
    imaginary part is >= 0 (a wave decaying into the metal).
    """
    cos_b = np.asarray(cos_beta, dtype=np.float64)
    eta = np.asarray(n, dtype=np.float64) + 1j * np.asarray(k, dtype=np.float64)
    sin2_b = np.clip(1.0 - cos_b * cos_b, 0.0, 1.0)
    eta2 = eta * eta
    w = np.sqrt(eta2 - sin2_b)                        # N cos(theta_t)
    r_s = (cos_b - w) / (cos_b + w)
    r_p = (eta2 * cos_b - w) / (eta2 * cos_b + w)     # (N cos b - cos t)/(N cos b + cos t)
    return r_s, r_p


def fresnel_unpolarized(cos_beta, n, k):
    """Reflectance of unpolarized light ``(|r_s|^2 + |r_p|^2) / 2`` (element 00
    of :func:`fresnel_mueller`)."""
    r_s, r_p = fresnel_amplitudes(cos_beta, n, k)
    return 0.5 * (np.abs(r_s) ** 2 + np.abs(r_p) ** 2)


# Stokes vector S = A . (E kron E*), with (E kron E*) = (ExEx*, ExEy*, EyEx*, EyEy*):
#   S0 = |Ex|^2 + |Ey|^2, S1 = |Ex|^2 - |Ey|^2, S2 = 2 Re(Ex Ey*), S3 = 2 Im(Ex Ey*)
_A = np.array([[1, 0, 0, 1],
               [1, 0, 0, -1],
               [0, 1, 1, 0],
               [0, -1j, 1j, 0]], dtype=np.complex128)
_A_INV = 0.5 * np.array([[1, 1, 0, 0],
                         [0, 0, 1, 1j],
                         [0, 0, 1, -1j],
                         [1, -1, 0, 0]], dtype=np.complex128)


def jones_to_mueller(J):
    """Mueller matrix ``A (J kron J*) A^-1`` of Jones matrices ``J`` (..., 2, 2)."""
    J = np.asarray(J)
    K = np.einsum("...ac,...bd->...abcd", J, np.conj(J))
    K = K.reshape(J.shape[:-2] + (4, 4))
    return np.real(_A @ K @ _A_INV)


def fresnel_mueller(cos_beta, n, k):
    """Mueller matrix (..., 4, 4) of reflection in the facet's own s/p frames."""
    r_s, r_p = fresnel_amplitudes(cos_beta, n, k)
    J = np.zeros(r_s.shape + (2, 2), dtype=np.complex128)
    J[..., 0, 0] = r_s
    J[..., 1, 1] = r_p
    return jones_to_mueller(J)


def rotator(theta):
    """Mueller matrix (..., 4, 4) that re-expresses a Stokes vector in a basis
    rotated by ``theta`` about the propagation direction (Mitsuba's
    ``mueller.rotator``)."""
    theta = np.asarray(theta, dtype=np.float64)
    c, s = np.cos(2 * theta), np.sin(2 * theta)
    R = np.zeros(theta.shape + (4, 4))
    R[..., 0, 0] = R[..., 3, 3] = 1.0
    R[..., 1, 1] = R[..., 2, 2] = c
    R[..., 1, 2] = s
    R[..., 2, 1] = -s
    return R


def _jones_rotator(theta):
    """Jones analogue of ``rotator``: ``E' = [[c, s], [-s, c]] E``."""
    c, s = np.cos(theta), np.sin(theta)
    return np.stack([np.stack([c, s], -1), np.stack([-s, c], -1)], -2)
