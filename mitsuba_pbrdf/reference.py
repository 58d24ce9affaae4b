"""NumPy float64 reference evaluator of the three-component polarized BRDF.

This module evaluates the model of "Modified model of polarized bidirectional
reflectance distribution function for metallic surfaces" (Optics and Laser
Technology 99 (2018) 160-166), as completed in ``MODEL.md``, directly from the
paper's angles. It is an independent derivation of what the Dr.Jit plugin
computes: it imports nothing but NumPy and the standard library (never Mitsuba
or Dr.Jit) and it builds the specular Mueller matrix in the Priest-Germer
*angle* form instead of Mitsuba's vector form.

The full model (paper Eq. 2, 5, 6; ``MODEL.md``)::

    F(wi, wr) = ks * Fs(wi, wr) + [kdd * fdd(wi, wr) + kid / pi] * D0

with ``Fs`` the polarized microfacet specular lobe, ``fdd`` a depolarized,
wider microfacet lobe and ``D0`` the ideal depolarizer (only element 00 is 1).

Units
-----
* Angles in radians: zenith ``theta`` from the surface normal, azimuth ``phi``.
* Wavelengths in nanometres.
* BRDF values in 1/sr. The returned Mueller matrices are BRDFs: they do *not*
  include the cosine factor ``cos(theta_r)`` (or ``cos(theta_i)``).
* ``sigma`` is the per-axis standard deviation of the Gaussian facet slopes
  (paper Eq. 3); the equivalent Beckmann roughness is ``alpha = sqrt(2)*sigma``.

Directions and frames
---------------------
* Local frame: ``z`` is the mean surface normal, ``x``/``y`` the surface axes.
* ``wi = (sin ti cos pi, sin ti sin pi, cos ti)`` points from the surface
  towards the light, ``wr`` (same form with ``tr, pr``) from the surface towards
  the viewer. Both point away from the surface; the in-plane specular direction
  has ``phi_r - phi_i = pi``. Everything is zero where ``cos ti <= 0`` or
  ``cos tr <= 0``.
* Stokes frames ("global s/p frames"): a Stokes vector belongs to a ray with
  propagation direction ``d`` and a reference x-axis ``s``; its y-axis is
  ``p = d x s`` so that ``(s, p, d)`` is right-handed (Mitsuba's handedness).
  ``S1 = I_s - I_p`` and ``S2 > 0`` for light linearly polarized at +45 deg from
  ``s`` towards ``p``.

  - input light propagates along ``d_in = -wi`` with ``s_in = normalize(z x d_in)``;
  - output light propagates along ``d_out = wr`` with ``s_out = normalize(z x d_out)``;
  - at normal incidence (``d`` parallel to ``z``) ``s`` is the surface x-axis
    ``(1, 0, 0)``.

  The returned matrix maps the input Stokes vector (in the input frame) to the
  output Stokes vector (in the output frame).
* Rotation angles: the angle from basis vector ``a`` to ``b`` about ``d`` is
  positive when ``d . (a x b) > 0`` (counter-clockwise seen from the tip of
  ``d``), as in ``mitsuba.mueller.rotate_stokes_basis``. Re-expressing a Stokes
  vector in a basis rotated by ``theta`` multiplies it by
  ``rotator(theta) = [[1,0,0,0],[0,c,s,0],[0,-s,c,0],[0,0,0,1]]`` with
  ``c, s = cos 2theta, sin 2theta`` (Mitsuba's ``mueller.rotator``).

Sign conventions (each pinned by a test in ``tests/test_reference.py``)
-----------------------------------------------------------------------
* Complex index ``N = n + i k`` with ``k >= 0`` and time factor ``exp(-i w t)``
  (the optics convention); the transmitted wave has ``Im(N cos theta_t) >= 0``.
* Fresnel amplitudes in right-handed ``(s, p, d)`` frames for the incident and
  the reflected wave (``fresnel_amplitudes``)::

      r_s = (cos b - N cos t) / (cos b + N cos t)
      r_p = (N cos b - cos t) / (N cos b + cos t)

  so ``r_p = -r_s`` at normal incidence: a mirror reverses the tangential field,
  and the Mueller matrix there is ``R * diag(1, 1, -1, -1)``. This is the same
  sign of ``r_p`` that Mitsuba's ``fresnel_polarized`` uses (Fresnel's 1823
  form ``tan(b - t) / tan(b + t)``, although Mitsuba's comment calls it the
  Verdet convention). Mitsuba evaluates the formulas with ``n - i k``, so its
  amplitudes are the complex conjugates of ours (test
  ``test_fresnel_amplitudes_match_mitsuba_conjugate``).
* Jones to Mueller: ``S0 = |Ex|^2 + |Ey|^2``, ``S1 = |Ex|^2 - |Ey|^2``,
  ``S2 = 2 Re(Ex Ey*)`` and ``S3 = 2 Im(Ex Ey*)`` (``jones_to_mueller``). With
  ``exp(-i w t)`` this is Born & Wolf's ``S3 = 2 a1 a2 sin(delta)``. It is the
  sign for which the facet matrix equals Mitsuba's
  ``mueller.specular_reflection`` element by element, ``m23 = -c sin(delta)``,
  ``m32 = +c sin(delta)`` with ``delta = arg(conj r_p) - arg(conj r_s)`` (test
  ``test_agreement_with_mitsuba_roughconductor``). A Priest-Germer code that
  keeps ``exp(-i w t)`` but writes ``S3 = 2 Im(Ex* Ey)`` differs from Mitsuba
  (and from this module) by the sign of m03, m13, m23, m30, m31, m32.
* Consequences checked by tests: unpolarized light reflected at oblique
  incidence comes out s-polarized, ``S1 > 0`` (``test_reflected_light_is_s_polarized``);
  the in-plane matrix is block-diagonal (``test_in_plane_block_diagonal``).
"""

import functools
import importlib.machinery
import importlib.util
import math
import os

import numpy as np

__all__ = [
    "available_materials",
    "conductor_ior",
    "fresnel_amplitudes",
    "fresnel_mueller",
    "jones_to_mueller",
    "rotator",
    "gaussian_slope_pdf",
    "beckmann_D",
    "ggx_D",
    "smith_G1",
    "shadowing_G",
    "rotation_angles",
    "specular",
    "directional_diffuse",
    "ideal_diffuse",
    "pbrdf",
]

SHADOWING_KINDS = ("vgroove", "smith", "none")
DISTRIBUTIONS = ("beckmann", "ggx")


# ---------------------------------------------------------------------------
# Complex index of refraction: Mitsuba's tabulated conductor spectra
# ---------------------------------------------------------------------------

def _ior_directory():
    """``<mitsuba package>/data/ior``, found without importing Mitsuba.

    ``PathFinder`` searches ``sys.path`` directly: once Mitsuba has been imported,
    ``importlib.util.find_spec("mitsuba")`` returns the spec of its alias
    extension module, which has no package directory."""
    for find in (importlib.machinery.PathFinder.find_spec, importlib.util.find_spec):
        spec = find("mitsuba")
        if spec is not None and spec.submodule_search_locations:
            directory = os.path.join(list(spec.submodule_search_locations)[0], "data", "ior")
            if os.path.isdir(directory):
                return directory
    raise RuntimeError("the mitsuba package is not installed: its data/ior spectra are needed")


def available_materials():
    """Sorted names of the conductors with both ``.eta.spd`` and ``.k.spd`` tables."""
    directory = _ior_directory()
    files = set(os.listdir(directory))
    names = {f[: -len(".eta.spd")] for f in files if f.endswith(".eta.spd")}
    return sorted(name for name in names if name + ".k.spd" in files)


def _read_spd(path):
    """Two columns (wavelength in nm, value); '#' starts a comment."""
    rows = []
    with open(path, encoding="utf-8") as f:
        for line in f:
            line = line.split("#", 1)[0].strip()
            if line:
                wavelength, value = line.split()[:2]
                rows.append((float(wavelength), float(value)))
    table = np.array(rows, dtype=np.float64)
    order = np.argsort(table[:, 0], kind="stable")
    return table[order, 0], table[order, 1]


@functools.lru_cache(maxsize=None)
def _ior_tables(material):
    names = available_materials()
    if material not in names:
        raise ValueError(
            f"unknown conductor material {material!r}; available materials: {', '.join(names)}"
        )
    directory = _ior_directory()
    return (_read_spd(os.path.join(directory, material + ".eta.spd")),
            _read_spd(os.path.join(directory, material + ".k.spd")))


def conductor_ior(material, wavelengths_nm):
    """Real and imaginary parts ``(n, k)`` of the complex index ``n + i k``.

    Linear interpolation of Mitsuba's tables ``data/ior/<material>.{eta,k}.spd``
    (what Mitsuba's ``irregular`` spectrum does in spectral variants). Raises
    ``ValueError`` for an unknown material or a wavelength outside the table.
    """
    (wl_n, n_table), (wl_k, k_table) = _ior_tables(material)
    wavelengths = np.asarray(wavelengths_nm, dtype=np.float64)
    lo, hi = max(wl_n[0], wl_k[0]), min(wl_n[-1], wl_k[-1])
    if np.any(wavelengths < lo) or np.any(wavelengths > hi):
        raise ValueError(
            f"wavelengths outside the {material!r} table range [{lo:g}, {hi:g}] nm"
        )
    return np.interp(wavelengths, wl_n, n_table), np.interp(wavelengths, wl_k, k_table)


# ---------------------------------------------------------------------------
# Fresnel reflection at a facet (the M_jk of paper Eq. 5)
# ---------------------------------------------------------------------------

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


# ---------------------------------------------------------------------------
# Facet distributions and shadowing
# ---------------------------------------------------------------------------

def gaussian_slope_pdf(alpha_angle, sigma):
    """Paper Eq. 3: density of facet tilt angles alpha, per unit solid angle of
    the facet normal, ``exp(-tan^2 a / 2 s^2) / (2 pi s^2 cos^3 a)``.
    It equals ``beckmann_D(cos a, sqrt(2) * sigma) * cos a``."""
    a = np.asarray(alpha_angle, dtype=np.float64)
    sigma = np.asarray(sigma, dtype=np.float64)
    c = np.cos(a)
    return np.exp(-np.tan(a) ** 2 / (2 * sigma**2)) / (2 * np.pi * sigma**2 * c**3)


def _tan2(cos_t):
    cos2 = cos_t * cos_t
    return np.clip(1.0 - cos2, 0.0, None) / np.where(cos2 > 0, cos2, 1.0)


def beckmann_D(cos_theta_h, alpha):
    """Beckmann normal distribution ``exp(-tan^2/alpha^2) / (pi alpha^2 cos^4)``
    (1/sr per unit projected area; ``int D cos dw = 1``); 0 for cos <= 0.
    With ``alpha = sqrt(2) sigma`` it is paper Eq. 3 divided by ``cos theta_h``."""
    c = np.asarray(cos_theta_h, dtype=np.float64)
    alpha = np.asarray(alpha, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        D = np.exp(-_tan2(c) / alpha**2) / (np.pi * alpha**2 * c**4)
    return np.where(c > 0, D, 0.0)


def ggx_D(cos_theta_h, alpha):
    """GGX / Trowbridge-Reitz ``alpha^2 / (pi (cos^2 (alpha^2 - 1) + 1)^2)``; 0 for cos <= 0."""
    c = np.asarray(cos_theta_h, dtype=np.float64)
    alpha = np.asarray(alpha, dtype=np.float64)
    a2 = alpha * alpha
    D = a2 / (np.pi * (c * c * (a2 - 1.0) + 1.0) ** 2)
    return np.where(c > 0, D, 0.0)


_erfc = np.frompyfunc(math.erfc, 1, 1)


def smith_G1(cos_theta, alpha, distribution="beckmann"):
    """Smith's masking function of one direction, ``1 / (1 + Lambda)``.

    Beckmann (exact form): ``a = 1 / (alpha tan theta)``,
    ``Lambda = (erf(a) - 1)/2 + exp(-a^2) / (2 a sqrt(pi))``.
    GGX: ``2 / (1 + sqrt(1 + alpha^2 tan^2 theta))``. 1 at normal incidence.
    """
    c = np.asarray(cos_theta, dtype=np.float64)
    alpha = np.asarray(alpha, dtype=np.float64)
    c, alpha = np.broadcast_arrays(c, alpha)
    tan2 = _tan2(c)
    if distribution == "beckmann":
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            a = 1.0 / (alpha * np.sqrt(tan2))
            a_safe = np.where(np.isfinite(a) & (a > 0), a, 1.0)
            erfc = np.asarray(_erfc(a_safe), dtype=np.float64)
            lam = 0.5 * (np.exp(-a_safe * a_safe) / (a_safe * np.sqrt(np.pi)) - erfc)
            G1 = 1.0 / (1.0 + lam)
        G1 = np.where(tan2 == 0, 1.0, G1)
    elif distribution == "ggx":
        G1 = 2.0 / (1.0 + np.sqrt(1.0 + alpha * alpha * tan2))
    else:
        raise ValueError(f"unknown distribution {distribution!r}; expected one of {DISTRIBUTIONS}")
    return np.where(c > 0, G1, 0.0)


def shadowing_G(theta_i, theta_r, cos_theta_h, cos_beta, alpha, kind="vgroove",
                distribution="beckmann"):
    """Geometric attenuation G of paper Eq. 4-5.

    * ``"vgroove"`` (Torrance-Sparrow / Blinn, the paper's choice):
      ``min(1, 2 cos th cos tr / cos b, 2 cos th cos ti / cos b)``;
    * ``"smith"``: separable Smith ``G1(wi) G1(wr)`` of ``distribution`` with
      roughness ``alpha`` (Mitsuba's ``roughconductor`` form);
    * ``"none"``: 1 (the original Priest-Germer model, unbounded at grazing).
    """
    cos_i = np.cos(np.asarray(theta_i, dtype=np.float64))
    cos_r = np.cos(np.asarray(theta_r, dtype=np.float64))
    cos_h = np.asarray(cos_theta_h, dtype=np.float64)
    cos_b = np.asarray(cos_beta, dtype=np.float64)
    if kind == "vgroove":
        with np.errstate(divide="ignore", invalid="ignore"):
            G = np.minimum(1.0, np.minimum(2 * cos_h * cos_r / cos_b, 2 * cos_h * cos_i / cos_b))
        G = np.where(cos_b > 0, G, 0.0)
    elif kind == "smith":
        G = smith_G1(cos_i, alpha, distribution) * smith_G1(cos_r, alpha, distribution)
        G = np.where(cos_b > 0, G, 0.0)               # facet seen from the front by both
    elif kind == "none":
        G = np.ones(np.broadcast_shapes(cos_i.shape, cos_r.shape, cos_h.shape, cos_b.shape))
    else:
        raise ValueError(f"unknown shadowing {kind!r}; expected one of {SHADOWING_KINDS}")
    return np.where((cos_i > 0) & (cos_r > 0), G, 0.0)


# ---------------------------------------------------------------------------
# Bistatic geometry in the Priest-Germer angle form
# ---------------------------------------------------------------------------

def _canonical(theta, phi):
    """theta in [0, pi]; a negative zenith angle is the same direction at phi + pi."""
    theta = np.asarray(theta, dtype=np.float64)
    phi = np.asarray(phi, dtype=np.float64)
    return np.abs(theta), np.where(theta < 0, phi + np.pi, phi)


def _geometry(theta_i, phi_i, theta_r, phi_r):
    """Angles of the bistatic geometry, all from the paper's (theta, phi)."""
    ti, phi_i = _canonical(theta_i, phi_i)
    tr, phi_r = _canonical(theta_r, phi_r)
    ti, phi_i, tr, phi_r = np.broadcast_arrays(ti, phi_i, tr, phi_r)
    g = {"cos_i": np.cos(ti), "sin_i": np.sin(ti), "cos_r": np.cos(tr), "sin_r": np.sin(tr)}

    # Normal incidence / exitance: the Stokes x-axis is the surface x-axis. The
    # formulas below use s_in = (sin phi_i, -cos phi_i, 0) and
    # s_out = (-sin phi_r, cos phi_r, 0), which are (1, 0, 0) for phi_i = pi/2
    # and phi_r = -pi/2.
    phi_i = np.where(g["sin_i"] == 0, 0.5 * np.pi, phi_i)
    phi_r = np.where(g["sin_r"] == 0, -0.5 * np.pi, phi_r)
    dphi = phi_r - phi_i
    g["sin_dphi"], g["cos_dphi"] = np.sin(dphi), np.cos(dphi)

    # 2 beta is the angle between wi and wr (both pointing away from the surface)
    # cos 2b = cos ti cos tr + sin ti sin tr cos dphi. Half-angle forms of
    # (1 +- cos 2b) / 2, sums of non-negative terms, avoid the cancellation of
    # 1 + cos 2b near grazing mirror geometry (cos 2b -> -1), where it cost up to
    # 1e-3 of cos b at cos theta = 1e-7 and wiped out narrow lobes:
    #   cos^2 b = cos^2((ti + tr)/2) + sin ti sin tr cos^2(dphi/2)
    #   sin^2 b = sin^2((ti - tr)/2) + sin ti sin tr sin^2(dphi/2)
    sin_sin = g["sin_i"] * g["sin_r"]
    g["cos_b"] = np.sqrt(np.cos(0.5 * (ti + tr)) ** 2 + sin_sin * np.cos(0.5 * dphi) ** 2)
    g["sin_b"] = np.sqrt(np.sin(0.5 * (ti - tr)) ** 2 + sin_sin * np.sin(0.5 * dphi) ** 2)
    # cos b = wi . h
    with np.errstate(divide="ignore", invalid="ignore"):
        cos_h = (g["cos_i"] + g["cos_r"]) / (2.0 * g["cos_b"])     # cos theta_h = h . z
    g["cos_h"] = np.where(g["cos_b"] > 0, np.clip(cos_h, -1.0, 1.0), 0.0)
    return g


def rotation_angles(theta_i, phi_i, theta_r, phi_r):
    """Priest-Germer rotation angles ``(eta_i, eta_r)`` from the global s/p
    frames to the facet's s/p frame.

    ``eta_i`` is the signed angle, about ``d_in = -wi``, from ``s_in`` to the
    facet's s-axis ``s_f = (wi x wr) / |wi x wr|`` (perpendicular to the facet's
    plane of incidence); ``eta_r`` is the angle about ``d_out = wr`` from
    ``s_out`` to ``s_f``. Priest and Germer write them as::

        cos eta_i = (cos th - cos ti cos b) / (sin ti sin b)
        cos eta_r = (cos th - cos tr cos b) / (sin tr sin b)

    with the sign of ``sin eta`` following ``sin(phi_r - phi_i)``. Substituting
    ``cos tr = 2 cos th cos b - cos ti`` and the expression of ``cos 2b`` gives
    the same angles without the 0/0 at normal incidence or retro-reflection::

        cos eta_i = (sin ti cos tr - cos ti sin tr cos dphi) / sin 2b
        sin eta_i = sin tr sin dphi / sin 2b
        cos eta_r = (sin tr cos ti - cos tr sin ti cos dphi) / sin 2b
        sin eta_r = sin ti sin dphi / sin 2b

    which are evaluated here with ``atan2`` (``sin 2b > 0`` drops out). Where the
    facet's plane of incidence is undefined (``wi = wr``) both angles are 0: the
    facet matrix there is ``R diag(1, 1, -1, -1)``, which any common s-axis
    leaves unchanged.
    """
    g = _geometry(theta_i, phi_i, theta_r, phi_r)
    return _rotation_angles(g)


def _rotation_angles(g):
    eta_i = np.arctan2(g["sin_r"] * g["sin_dphi"],
                       g["sin_i"] * g["cos_r"] - g["cos_i"] * g["sin_r"] * g["cos_dphi"])
    eta_r = np.arctan2(g["sin_i"] * g["sin_dphi"],
                       g["sin_r"] * g["cos_i"] - g["cos_r"] * g["sin_i"] * g["cos_dphi"])
    return eta_i, eta_r


# ---------------------------------------------------------------------------
# The three components (paper Eq. 2)
# ---------------------------------------------------------------------------

def _check_kinds(shadowing, distribution):
    if shadowing not in SHADOWING_KINDS:
        raise ValueError(f"unknown shadowing {shadowing!r}; expected one of {SHADOWING_KINDS}")
    if distribution not in DISTRIBUTIONS:
        raise ValueError(f"unknown distribution {distribution!r}; expected one of {DISTRIBUTIONS}")


def _above(g):
    return (g["cos_i"] > 0) & (g["cos_r"] > 0)


def specular(theta_i, phi_i, theta_r, phi_r, n, k, sigma, shadowing="vgroove"):
    """Specular Mueller BRDF ``fs`` (..., 4, 4) in the global s/p frames (paper Eq. 4-5):

        f_jk = D(h) G M_jk / (4 cos ti cos tr),   D = Beckmann with alpha = sqrt(2) sigma

    ``M`` is the facet's Fresnel Mueller matrix rotated into the global frames.
    For ``shadowing="smith"`` G is the Beckmann Smith G of the same alpha.
    """
    _check_kinds(shadowing, "beckmann")
    g = _geometry(theta_i, phi_i, theta_r, phi_r)
    shape = np.broadcast_shapes(g["cos_i"].shape, np.shape(n), np.shape(k), np.shape(sigma))
    above = np.broadcast_to(_above(g), shape)
    alpha = np.sqrt(2.0) * np.asarray(sigma, dtype=np.float64)

    # Paper Eq. 3-4: p(alpha)/cos(alpha) is the Beckmann D of the half vector
    D = beckmann_D(g["cos_h"], alpha)
    G = shadowing_G(np.arccos(g["cos_i"]), np.arccos(g["cos_r"]), g["cos_h"], g["cos_b"],
                    alpha, shadowing, "beckmann")
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = D * G / (4.0 * g["cos_i"] * g["cos_r"])
    scale = np.where(above, np.broadcast_to(scale, shape), 0.0)

    # Jones matrix of the facet in its own s/p frames, rotated into the global
    # frames: E_out = R(-eta_r) diag(r_s, r_p) R(eta_i) E_in (P-G ref. [3] of the paper)
    r_s, r_p = fresnel_amplitudes(g["cos_b"], n, k)
    eta_i, eta_r = _rotation_angles(g)
    J_facet = np.zeros(np.broadcast_shapes(r_s.shape, r_p.shape) + (2, 2), dtype=np.complex128)
    J_facet[..., 0, 0] = r_s
    J_facet[..., 1, 1] = r_p
    J = _jones_rotator(-eta_r) @ J_facet @ _jones_rotator(eta_i)
    M = jones_to_mueller(J)                                    # paper Eq. 5: M_jk

    fs = np.broadcast_to(scale, shape)[..., None, None] * np.broadcast_to(M, shape + (4, 4))
    return np.where(above[..., None, None], fs, 0.0)


def directional_diffuse(theta_i, phi_i, theta_r, phi_r, sigma_dd, shadowing="vgroove",
                        distribution="beckmann"):
    """Directional diffuse BRDF ``fdd = Ddd(h) G / (4 cos ti cos tr)`` (1/sr, a
    scalar: this lobe is depolarized). ``Ddd`` has width ``alpha_dd = sqrt(2) sigma_dd``
    and is Beckmann or GGX; for ``shadowing="smith"`` G uses that distribution and width."""
    _check_kinds(shadowing, distribution)
    g = _geometry(theta_i, phi_i, theta_r, phi_r)
    alpha_dd = np.sqrt(2.0) * np.asarray(sigma_dd, dtype=np.float64)
    D = (beckmann_D if distribution == "beckmann" else ggx_D)(g["cos_h"], alpha_dd)
    G = shadowing_G(np.arccos(g["cos_i"]), np.arccos(g["cos_r"]), g["cos_h"], g["cos_b"],
                    alpha_dd, shadowing, distribution)
    with np.errstate(divide="ignore", invalid="ignore"):
        f = D * G / (4.0 * g["cos_i"] * g["cos_r"])
    return np.where(_above(g), f, 0.0)


def ideal_diffuse(theta_i, theta_r):
    """Lambertian ``fid = 1/pi`` (1/sr) where both directions are above the surface."""
    cos_i = np.cos(np.asarray(theta_i, dtype=np.float64))
    cos_r = np.cos(np.asarray(theta_r, dtype=np.float64))
    return np.where((cos_i > 0) & (cos_r > 0), 1.0 / np.pi, 0.0)


def pbrdf(theta_i, phi_i, theta_r, phi_r, n, k, sigma, ks=1.0, kdd=0.0, sigma_dd=0.5,
          kid=0.0, shadowing="vgroove", dd_distribution="beckmann"):
    """The full pBRDF (paper Eq. 2, 5, 6), a float64 array (..., 4, 4) in 1/sr::

        F = ks Fs + [kdd fdd + kid / pi] D0

    All arguments broadcast against each other (e.g. angles of shape (m, 1) and
    ``n, k, ks`` of shape (w,) for w wavelengths give (m, w, 4, 4)). Apply it to
    a Stokes vector of the incident light (frame ``s_in``) to get the reflected
    Stokes vector (frame ``s_out``) per unit irradiance, paper Eq. 6.
    """
    _check_kinds(shadowing, dd_distribution)
    Fs = specular(theta_i, phi_i, theta_r, phi_r, n, k, sigma, shadowing)
    fdd = directional_diffuse(theta_i, phi_i, theta_r, phi_r, sigma_dd, shadowing, dd_distribution)
    fid = ideal_diffuse(theta_i, theta_r)
    ks = np.asarray(ks, dtype=np.float64)
    depolarized = np.asarray(kdd, dtype=np.float64) * fdd + np.asarray(kid, dtype=np.float64) * fid
    shape = np.broadcast_shapes(Fs.shape[:-2], ks.shape, depolarized.shape)
    F = np.broadcast_to(ks, shape)[..., None, None] * Fs
    F[..., 0, 0] += np.broadcast_to(depolarized, shape)               # times D0
    return F
