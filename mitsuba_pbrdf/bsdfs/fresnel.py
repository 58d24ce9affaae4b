"""Fresnel reflection on a facet of complex index n + ik, vectorized over the
wavelengths of a Dr.Jit spectrum (the role of Mitsuba's ``fresnel.h`` and
``mueller.h`` for this plugin): complex amplitudes, the unpolarized
reflectance, and the facet's Mueller matrix rotated into Mitsuba's implicit
Stokes bases.

Mitsuba's ``mi.mueller.specular_reflection`` has no spectral overload callable
from Python, hence these functions. Dimensionless; cosines of the angle of
incidence on the facet.
"""

import drjit as dr
import mitsuba as mi

from ..mueller import rotate_mueller_basis


def fresnel_amplitudes(cos_beta, eta, k):
    """Complex reflection amplitudes (a_s, a_p) as (re, im) pairs, vectorized over
    wavelengths, for a facet of index N = eta + i k seen at ``cos_beta``.

    a_s = (cos - w) / (cos + w),  a_p = (w - N^2 cos) / (w + N^2 cos),
    w = sqrt(N^2 - sin^2) = N cos_t on the principal branch (Im w >= 0: the
    transmitted wave decays), Fresnel's sign convention for a_p as in Mitsuba
    (a_p = a_s at normal incidence).
    """
    c = dr.clip(cos_beta, 0.0, 1.0)
    n2_re = eta * eta - k * k  # N^2
    n2_im = 2.0 * eta * k
    u_re = n2_re - (1.0 - c * c)  # N^2 - sin^2
    u_im = n2_im
    # Numerically stable principal square root of u.
    modulus = dr.sqrt(dr.fma(u_re, u_re, u_im * u_im))
    t = dr.sqrt(dr.maximum(0.5 * (modulus + dr.abs(u_re)), 0.0))
    safe_t = dr.select(t > 0, t, 1.0)
    # u_im = 2 n k >= 0 (k >= 0 is validated; k = -0.0 must act as +0.0, so no
    # copysign): the root with Im w >= 0.
    w_re = dr.select(u_re >= 0, t, dr.abs(u_im) / (2.0 * safe_t))
    w_im = dr.select(u_re >= 0, dr.abs(u_im) / (2.0 * safe_t), t)

    def ratio(a_re, a_im, b_re, b_im):  # (a - b) / (a + b) as (re, im)
        num_re, num_im = a_re - b_re, a_im - b_im
        den_re, den_im = a_re + b_re, a_im + b_im
        inv = dr.rcp(dr.maximum(den_re * den_re + den_im * den_im, 1e-30))
        return ((num_re * den_re + num_im * den_im) * inv,
                (num_im * den_re - num_re * den_im) * inv)

    a_s = ratio(c, 0.0 * c, w_re, w_im)
    a_p = ratio(w_re, w_im, n2_re * c, n2_im * c)
    return a_s, a_p


def fresnel_unpolarized(cos_beta, eta, k):
    """Unpolarized reflectance (R_s + R_p) / 2."""
    (s_re, s_im), (p_re, p_im) = fresnel_amplitudes(cos_beta, eta, k)
    return 0.5 * (s_re * s_re + s_im * s_im + p_re * p_re + p_im * p_im)


def fresnel_mueller_entries(cos_beta, eta, k):
    """Entries (A, B, C, S) of the facet's reflection Mueller matrix in its s/p frame,

        [[A, B, 0,  0],
         [B, A, 0,  0],
         [0, 0, C, -S],
         [0, 0, S,  C]],

    A = (R_s + R_p)/2, B = (R_s - R_p)/2, C + iS = r_p conj(r_s) in Mitsuba 3.9's
    convention: N = n - ik (time factor exp(+i w t)) and the Verdet sign of r_p
    (r_p = -r_s at normal incidence), i.e. r_s = conj(a_s), r_p = -conj(a_p)
    with the amplitudes of :func:`fresnel_amplitudes`."""
    (s_re, s_im), (p_re, p_im) = fresnel_amplitudes(cos_beta, eta, k)
    r_s = s_re * s_re + s_im * s_im
    r_p = p_re * p_re + p_im * p_im
    return (0.5 * (r_s + r_p), 0.5 * (r_s - r_p),
            -(p_re * s_re + p_im * s_im), p_im * s_re - p_re * s_im)


def specular_mueller(ctx, si, wo, h, eta, k, weight):
    """``weight`` x Fresnel Mueller matrix of the facet with normal ``h``, rotated
    from the facet's s/p frames into Mitsuba's implicit Stokes bases."""
    # Light arrives along -wo_hat and leaves along wi_hat.
    radiance = ctx.mode == mi.TransportMode.Radiance
    wo_hat = wo if radiance else si.wi
    wi_hat = si.wi if radiance else wo

    # cos(beta) from the incident side, as roughconductor computes it (same
    # value, same float32 rounding).
    A, B, C, S = (weight * e for e in fresnel_mueller_entries(dr.dot(wo_hat, h), eta, k))
    M = dr.zeros(mi.Spectrum, dr.width(weight))
    M[0, 0] = A
    M[0, 1] = B
    M[1, 0] = B
    M[1, 1] = A
    M[2, 2] = C
    M[2, 3] = -S
    M[3, 2] = S
    M[3, 3] = C

    # The facet's s axis is perpendicular to its plane of reflection.
    s_in = dr.cross(h, -wo_hat)
    s_out = dr.cross(h, wi_hat)
    # At normal incidence on the facet (retro-reflection) any s axis
    # perpendicular to h serves, as long as input and output share it.
    collinear = dr.squared_norm(s_in) < 1e-12
    s_any = mi.coordinate_system(h)[0]
    s_in = dr.select(collinear, s_any, dr.normalize(s_in))
    s_out = dr.select(collinear, s_any, dr.normalize(s_out))
    return rotate_mueller_basis(M, -wo_hat, s_in, mi.mueller.stokes_basis(-wo_hat),
                                wi_hat, s_out, mi.mueller.stokes_basis(wi_hat))
