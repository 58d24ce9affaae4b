"""The bistatic geometry in the Priest-Germer angle form: the angle beta of
incidence on the facet, the facet's tilt theta_h and the rotations from the
global s/p frames to the facet's s/p frame, all from the paper's
(theta, phi) of the two directions.
"""

import numpy as np


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


def bistatic_geometry(theta_i, phi_i, theta_r, phi_r):
    """The angles of the bistatic geometry (a dict of arrays: ``cos_i``,
    ``cos_r``, ``cos_b``, ``cos_h``, ...), the part of every lobe that does not
    depend on the model's parameters: computed once, it is the ``geometry``
    argument of :func:`~.model.specular` and its neighbours."""
    return _geometry(theta_i, phi_i, theta_r, phi_r)


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
