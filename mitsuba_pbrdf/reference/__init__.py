"""NumPy float64 reference evaluator of the three-component polarized BRDF.

This module evaluates the model of "Modified model of polarized bidirectional
reflectance distribution function for metallic surfaces" (Optics and Laser
Technology 99 (2018) 160-166), as completed in ``docs/model.md``, directly from the
paper's angles. It is an independent derivation of what the Dr.Jit plugin
computes: it imports nothing but NumPy and the standard library (never Mitsuba
or Dr.Jit) and it builds the specular Mueller matrix in the Priest-Germer
*angle* form instead of Mitsuba's vector form.

The full model (paper Eq. 2, 5, 6; ``docs/model.md``)::

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

Sign conventions (each pinned by a test in ``tests/reference/test_model.py``)
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

Modules, in the order of the paper: :mod:`.materials` (tabulated n + ik),
:mod:`.fresnel` (the facet's Jones and Mueller matrices, Eq. 5),
:mod:`.microfacet` (Eq. 3 and the shadowing G), :mod:`.geometry` (the
bistatic angles and the Priest-Germer rotations), :mod:`.model` (the three
components and the full pBRDF, Eq. 2-6), :mod:`.params` (a record of the
model's parameters with its checks).
"""

from ..schema import DD_DISTRIBUTIONS as DISTRIBUTIONS
from ..schema import REFERENCE_SHADOWING as SHADOWING_KINDS
from . import anisotropic, fresnel, geometry, materials, microfacet, model  # noqa: F401 (submodules)
from .anisotropic import anisotropic_D, projected_alpha, slope_density, smith_G1_anisotropic
from .fresnel import (fresnel_amplitudes, fresnel_mueller, fresnel_unpolarized, jones_to_mueller,
                      rotator)
from .geometry import bistatic_geometry, rotation_angles
from .materials import available_materials, conductor_ior
from .microfacet import beckmann_D, gaussian_slope_pdf, ggx_D, shadowing_G, smith_G1
from .model import (directional_diffuse, ideal_diffuse, microfacet_lobe, pbrdf, specular,
                    specular_unpolarized)
from .params import PBRDFParams, dop_unpolarized

__all__ = [
    "SHADOWING_KINDS",
    "DISTRIBUTIONS",
    "available_materials",
    "conductor_ior",
    "fresnel_amplitudes",
    "fresnel_mueller",
    "fresnel_unpolarized",
    "jones_to_mueller",
    "rotator",
    "gaussian_slope_pdf",
    "beckmann_D",
    "ggx_D",
    "smith_G1",
    "shadowing_G",
    "rotation_angles",
    "bistatic_geometry",
    "specular",
    "specular_unpolarized",
    "directional_diffuse",
    "microfacet_lobe",
    "ideal_diffuse",
    "pbrdf",
    "PBRDFParams",
    "dop_unpolarized",
]
