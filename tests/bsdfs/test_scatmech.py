"""The specular lobe against NIST's SCATMECH (``pySCATMECH``), a Mueller-matrix
microfacet BRDF written independently by a co-author of the model.

SCATMECH's ``Facet_BRDF_Model`` (no shadowing: the Priest-Germer model, our
``shadowing="none"``) and ``Shadowed_Facet_BRDF_Model`` with the
``Torrance_Sparrow_Shadow_Function`` (``min(1, 2 cos d cos ti / cos b,
2 cos d cos ts / cos b)``: our ``"vgroove"``) give the Mueller BRDF (1/sr, no
cosine) of reflecting facets on a substrate of index n + ik.

Conventions mapped (read in SCATMECH's sources, ``facet.cpp``, ``torrspar.cpp``,
``mueller.h``):

* **Slope distribution**: set explicitly to ``Gaussian_Slope_Distribution_Function``
  (the default is exponential), ``P(slope) = exp(-slope^2 / s^2) / (pi s^2)``:
  its ``s`` is the RMS of the 2-D slope, ``s = sqrt(2) sigma`` (our per-axis
  sigma), i.e. the Beckmann alpha.
* **Units**: wavelength ``lambda`` in micrometres (0.633 here; a bare facet's
  Fresnel coefficients do not depend on it), substrate ``(n,k)``, angles in radians.
* **Geometry**: SCATMECH's incident direction has azimuth pi and its viewing
  azimuth ``phis`` is 0 at the specular direction: our ``phi_i = pi``,
  ``phi_r = phis``, ``theta_i = thetai``, ``theta_r = thetas``.
* **Stokes basis** (``coords="psps"``): s perpendicular to each ray's plane of
  incidence, p completing the right-handed (s, p, k) frame: our global s/p
  frames; ``S1 = |Es|^2 - |Ep|^2``, ``S2 = 2 Re(Es* Ep)``.
* **Circular sign**: SCATMECH writes ``S3 = 2 Im(Es* Ep)`` (``I(lcp) - I(rcp)``)
  with n + ik (time factor exp(-i w t)); the reference adopts Mitsuba's sign,
  ``S3 = 2 Im(Es Ep*)``. So ``M_ours = D M_SCATMECH D`` with ``D = diag(1, 1, 1,
  -1)``: m03, m13, m23, m30, m31, m32 change sign, nothing else.

Tolerances: reference (float64) vs SCATMECH (float64): the two evaluate the same
expressions through different algebra (SCATMECH: facet normal vectors and
closed-form Jones elements; the reference: Priest-Germer angles and rotations),
so they agree to rounding, ~1e-14 of M00; 1e-9 of the configuration's largest
M00 leaves room for cancellation near grazing while catching any model error
(a sign, a factor or a frame shows up at order 1). Plugin (float32) vs
SCATMECH: the plugin-vs-reference tolerance of ``tests/bsdfs/test_pbrdf_vs_reference.py``,
``1e-4 M00 + 1e-7 max(M00)`` per element.
"""

import itertools

import numpy as np
import pytest

import pySCATMECH.brdf as pySCATMECH  # the test extra installs it (pyproject.toml, install.sh)

from mitsuba_pbrdf import frames as mf
from mitsuba_pbrdf import reference as ref

D = np.diag([1.0, 1.0, 1.0, -1.0])
MATERIALS = {"Al-like": (1.2, 7.26), "Au-like": (0.27, 3.4), "Cr-like": (3.1, 3.3),
             "dielectric": (1.5, 0.0)}
SIGMAS = (0.05, 0.15, 0.35)
SHADOWING = {"none": "Facet_BRDF_Model", "vgroove": "Shadowed_Facet_BRDF_Model"}


def geometries():
    """(theta_i, theta_s, phi_s) in radians: a grid from normal to 80 deg,
    in and out of the plane, near and far from the specular direction."""
    t = np.radians([0.0, 10.0, 30.0, 50.0, 70.0, 80.0])      # theta_i > 0: see below
    p = np.radians([-150.0, -60.0, -20.0, -3.0, 0.0, 5.0, 45.0, 120.0])
    g = np.array(list(itertools.product(t[1:], t, p)))
    return g[:, 0], g[:, 1], g[:, 2]


def scatmech_mueller(shadowing, n, k, sigma, ti, ts, ps):
    model = pySCATMECH.BRDF_Model(SHADOWING[shadowing],
                                  sdf="Gaussian_Slope_Distribution_Function")
    model.setParameters({"lambda": 0.633, "substrate": f"({n!r},{k!r})",
                         "sdf.s": repr(float(np.sqrt(2.0) * sigma)), "type": "0"})
    if shadowing == "vgroove":
        assert model.getParameters()["shadow"] == "Torrance_Sparrow_Shadow_Function"
    assert model.getParameters()["sdf"] == "Gaussian_Slope_Distribution_Function"
    S = np.array([np.array(model.MuellerBRDF(a, b, c, 0.0, "psps"))
                  for a, b, c in zip(ti, ts, ps)])
    return D @ S @ D


@pytest.mark.parametrize("shadowing", list(SHADOWING))
@pytest.mark.parametrize("material", list(MATERIALS))
def test_reference_matches_scatmech(material, shadowing):
    n, k = MATERIALS[material]
    ti, ts, ps = geometries()
    worst = np.zeros((4, 4))
    for sigma in SIGMAS:
        S = scatmech_mueller(shadowing, n, k, sigma, ti, ts, ps)
        # at normal viewing SCATMECH's psps frame is the limit along phis; the
        # reference's global frame there is the surface x-axis: take the limit
        R = ref.specular(ti, np.pi, np.where(ts == 0, 1e-9, ts), ps, n, k, sigma, shadowing)
        scale = np.abs(S[:, 0, 0]).max()
        worst = np.maximum(worst, np.abs(R - S).max(axis=0) / scale)
        assert scale > 0
    assert np.all(worst <= 1e-9), f"{material}, {shadowing}: per element\n{worst}"


@pytest.mark.parametrize("material", ["Al-like", "Au-like"])
def test_plugin_matches_scatmech(material):
    import mitsuba as mi

    n, k = MATERIALS[material]
    ti, ts, ps = geometries()
    keep = (ts > 0) & (ts < np.radians(75)) & (ti < np.radians(75))   # normal viewing: see above
    ti, ts, ps = ti[keep], ts[keep], ps[keep]
    d = lambda t, p: np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1)
    for sigma in SIGMAS:
        bsdf = mi.load_dict({"type": "pbrdf", "eta": n, "k": k, "sigma": sigma, "ks": 1.0,
                             "kdd": 0.0, "kid": 0.0, "shadowing": "vgroove"})
        wo_hat, wi_hat = d(ti, np.pi), d(ts, ps)          # towards the light, the viewer
        P = mf.eval_global(bsdf, wi_hat, wo_hat, (500.0, 550.0, 600.0, 650.0))[:, 1]
        S = scatmech_mueller("vgroove", n, k, sigma, *(mf.to_angles(wo_hat)[0],
                                                       mf.to_angles(wi_hat)[0],
                                                       mf.to_angles(wi_hat)[1]))
        m00 = S[:, 0, 0][:, None, None]
        bound = 1e-4 * m00 + 1e-7 * m00.max()
        excess = np.abs(P - S) / bound
        assert excess.max() <= 1.0, (sigma, np.unravel_index(np.argmax(excess), excess.shape))
