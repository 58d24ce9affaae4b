"""Helmholtz reciprocity and mirror symmetry of a measured Mueller BRDF, read
into the project's conventions (the checks behind
``validation/ptfe_reciprocity.py`` and ``tests/measured/test_ptfe_reciprocity.py``).

Frames and units: the matrices are
:class:`~mitsuba_pbrdf.measured.measurements.Measurements` rows in the
project's global s/p frames (1/sr); angles in degrees, ``phi_i`` the source's
azimuth; ``dphi = phi_r - phi_i`` wrapped to [-180, 180).

* **Reciprocity.** For a sample that is isotropic (invariant under a rotation
  about its normal, which carries every ray's s/p basis along), the matrix
  depends on (theta_i, theta_r, dphi) alone. Swapping source and viewer turns
  (a, b, dphi) into (b, a, -dphi), and M(r -> i) = Q M(i -> r)^T Q with
  Q = diag(1, 1, -1, 1) (``mitsuba_pbrdf.diagnostics.physics``). So rows A
  (a, b, dphi) and B (b, a, -dphi) of one wavelength must satisfy
  M_B = Q M_A^T Q; a row with a = b and dphi = -dphi (mod 360) is its own pair.
* **Mirror symmetry.** Reflecting a configuration through the plane of
  incidence maps (a, b, dphi) to (a, b, -dphi) and flips the sign of every
  ray's s vector: M(a, b, -dphi) = E M(a, b, dphi) E, E = diag(1, 1, -1, -1),
  for a sample without handedness (an isotropic one that is also its own
  mirror image). Its pairs give the data's noise in the same statistic.

Pairs are matched within ``tol`` degrees in each of theta_i, theta_r and
dphi: NIST's grid puts distinct angles at least 0.5 deg apart and prints them
with 6 significant digits, so any tol between 1e-3 and 0.25 deg finds the same
pairs (:func:`pair_counts_by_tolerance` shows it).
"""

import numpy as np

from mitsuba_pbrdf.measured.pairs import matching_pairs, wrap  # noqa: F401 (wrap: this module's API)

#: Reciprocity's sign matrix in the global s/p frames (docs/conventions.md).
Q = np.diag([1.0, 1.0, -1.0, 1.0])
#: Mirror image through the plane of incidence: s -> -s on both rays.
E = np.diag([1.0, 1.0, -1.0, -1.0])
#: Elements that vanish in the plane of incidence (mirror symmetry there).
OFF_BLOCK = ((0, 2), (0, 3), (1, 2), (1, 3), (2, 0), (2, 1), (3, 0), (3, 1))
#: Matching tolerance of the angles (deg); see the module docstring.
TOL = 0.01


def mueller(data):
    """(N, 4, 4) matrices of ``data.observed`` (m00 ... m33), 1/sr."""
    return np.stack([np.stack([data.observed[f"m{i}{j}"] for j in range(4)], -1)
                     for i in range(4)], -2)


def dphi(data):
    """Azimuth of the viewer relative to the source, deg, in [-180, 180)."""
    return wrap(data.phi_r - data.phi_i)


def _pairs(data, swap, tol, keep):
    """Index pairs (a, b) of rows of one wavelength where row b has
    dphi = -dphi[a] and (theta_i, theta_r) those of row a, swapped if ``swap``
    (each within tol), filtered by ``keep(a, b)`` (the package's search:
    :func:`mitsuba_pbrdf.measured.pairs.matching_pairs`)."""
    pairs = matching_pairs(data, swap, tol)
    return pairs[keep(pairs[:, 0], pairs[:, 1])].reshape(-1, 2)


def reciprocal_pairs(data, tol=TOL):
    """(P, 2) row indices: (a, b, dphi) with (b, a, -dphi) at one wavelength;
    each pair once, a row reciprocal to itself as (r, r)."""
    return _pairs(data, True, tol, lambda a, b: a <= b)


def mirror_pairs(data, tol=TOL):
    """(P, 2) row indices: (a, b, dphi) with (a, b, -dphi), dphi not 0 or 180
    (a row in the plane of incidence is its own mirror image)."""
    return _pairs(data, False, tol, lambda a, b: a < b)


def pair_counts_by_tolerance(data, tols):
    """Number of reciprocal pairs found at each matching tolerance (deg)."""
    return [len(reciprocal_pairs(data, t)) for t in tols]


def reciprocal(M):
    """What reciprocity predicts for the reversed configuration: Q M^T Q."""
    return Q @ np.swapaxes(M, -1, -2) @ Q


def mirrored(M):
    """What mirror symmetry predicts for the mirrored configuration: E M E."""
    return E @ M @ E


def pair_errors(MA, MB, predict):
    """Per pair, three figures of M_B against ``predict(M_A)``, with M00 the
    pair's mean unpolarized BRDF:
    |M00_B - M00_A| / M00 (M00 needs no prediction),
    max_ij |M_B - predict(M_A)|_ij / M00 (the whole matrix, 1/sr over 1/sr),
    max over the 15 polarization elements of |M_B / M00_B - predict(M_A) / M00_A|
    (each matrix in the file's own unit, f_rIJ / f_r11: free of M00's error)."""
    P = predict(MA)
    m00 = 0.5 * (MA[:, 0, 0] + MB[:, 0, 0])
    rel00 = np.abs(MB[:, 0, 0] - MA[:, 0, 0]) / m00
    whole = np.max(np.abs(MB - P), axis=(1, 2)) / m00
    norm = np.abs(MB / MB[:, :1, :1] - P / MA[:, :1, :1]).reshape(-1, 16)[:, 1:]
    return rel00, whole, norm.max(axis=1)


def off_block_noise(data):
    """RMS and max of the 8 off-block elements / M00 on the rows in the plane
    of incidence (dphi 0 or 180), where mirror symmetry makes them 0."""
    rows = np.abs(np.sin(np.radians(dphi(data)))) < 1e-3
    M = mueller(data)[rows]
    v = np.stack([M[:, i, j] / M[:, 0, 0] for i, j in OFF_BLOCK])
    return float(np.sqrt(np.mean(v ** 2))), float(np.max(np.abs(v))), int(rows.sum())


# ---------------------------------------------------------------------------
# Readings of the file that differ from the project's
# ---------------------------------------------------------------------------

def rotator(angle):
    """Stokes rotators (N, 4, 4) for basis rotations by ``angle`` (rad), the
    convention of :func:`mitsuba_pbrdf.measured.nist_layout.nist_to_project`."""
    c, s = np.cos(2 * angle), np.sin(2 * angle)
    R = np.zeros(np.shape(angle) + (4, 4))
    R[..., 0, 0] = R[..., 3, 3] = 1.0
    R[..., 1, 1] = R[..., 2, 2] = c
    R[..., 1, 2], R[..., 2, 1] = s, -s
    return R


def _direction(theta, phi):
    t, p = np.radians(theta), np.radians(phi)
    return np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1)


def _to_sample_y(k):
    """Angle (rad) about k from the ray's s vector (z x k) to the sample's y
    axis projected across k: the rotation between s/p and a basis fixed to
    the sample."""
    s = np.cross([0.0, 0.0, 1.0], k)
    s /= np.linalg.norm(s, axis=-1, keepdims=True)
    y = np.array([0.0, 1.0, 0.0]) - k[..., 1:2] * k
    y /= np.linalg.norm(y, axis=-1, keepdims=True)
    return np.arctan2(np.sum(np.cross(s, y) * k, -1), np.sum(s * y, -1))


def sample_fixed_bases(M, data):
    """The file's matrices read as if in bases fixed to the sample (every
    ray's reference along the sample's y axis), converted to s/p: each side
    rotated by its ray's angle between the two."""
    k_in = -_direction(data.theta_i, data.phi_i)          # propagation towards the sample
    k_out = _direction(data.theta_r, data.phi_r)
    return rotator(_to_sample_y(k_out)) @ M @ rotator(-_to_sample_y(k_in))


#: name: (how the reading differs from nist_layout's, M (N, 4, 4), data -> M').
#: The first two are fixed sign conventions on both sides (conjugations by a
#: diagonal of +-1, which commute with Q and with transposition): reciprocity
#: cannot see them. The others treat the two sides differently or depend on
#: the geometry.
MISREADINGS = {
    "circular sign flipped": (
        "SCATMECH's circular sign kept (no D on either side)",
        lambda M, data: M * np.outer([1, 1, 1, -1], [1, 1, 1, -1])),
    "s and p swapped": (
        "every ray's s and p exchanged (S1, S2 change sign)",
        lambda M, data: M * np.outer([1, -1, -1, 1], [1, -1, -1, 1])),
    "transposed": (
        "f_rIJ read as element (J, I)",
        lambda M, data: np.swapaxes(M, -1, -2)),
    "circular sign on one side": (
        "D applied to the output Stokes vector only",
        lambda M, data: M * np.array([1, 1, 1, -1])[:, None]),
    "incident s from the source": (
        "incident basis built on the direction to the source (s -> -s on the input)",
        lambda M, data: M * E.diagonal()[None, :]),
    "sample-fixed bases": (
        "bases fixed to the sample (y axis) instead of each ray's s/p",
        sample_fixed_bases),
}


def misread_errors(data, pairs, name):
    """:func:`pair_errors` of reciprocity on ``pairs`` with the matrices read
    the wrong way ``name`` (a key of :data:`MISREADINGS`)."""
    M = MISREADINGS[name][1](mueller(data), data)
    return pair_errors(M[pairs[:, 0]], M[pairs[:, 1]], reciprocal)


# ---------------------------------------------------------------------------
# Noise-scaled figures and the model at the same geometries
# ---------------------------------------------------------------------------

def normalized(M):
    """Matrices divided by their M00 (the file's own unit, f_rIJ / f_r11)."""
    return M / M[:, :1, :1]


def mirror_variance(data, pairs):
    """Per polarization element (15, m01 ... m33), half the mean square of
    M_B / M00_B - E M_A E / M00_A over mirror ``pairs``: the variance of one
    measured normalized element, if the sample is mirror-symmetric."""
    N = normalized(mueller(data))
    r = (N[pairs[:, 1]] - mirrored(N[pairs[:, 0]])).reshape(-1, 16)[:, 1:]
    return np.mean(r ** 2, axis=0) / 2


def chi2_per_term(N, pairs, variance, T=Q):
    """Mean over pairs and the 15 polarization elements of
    (N_B - T N_A^T T)^2 / (2 variance): about 1 if the relation holds and the
    residual is noise of that variance. N: normalized matrices (M, 4, 4)."""
    r = (N[pairs[:, 1]] - T @ np.swapaxes(N[pairs[:, 0]], -1, -2) @ T).reshape(-1, 16)[:, 1:]
    return float(np.mean(r ** 2 / (2 * variance)))


#: The eight relations M_B = T M_A^T T, T = diag(1, +-1, +-1, +-1): reciprocity
#: in the project's reading is T = Q; a reading off by one side's sign pattern
#: L (M -> M L or L M) turns the test into T = L Q.
SIGN_RELATIONS = [np.diag([1.0, a, b, c]) for a in (1, -1) for b in (1, -1) for c in (1, -1)]


def reference_rows(data, rows, **params):
    """The float64 reference's BRDF (len(rows), 4, 4), 1/sr, at the geometry of
    ``rows`` of ``data`` (one wavelength-independent n, k: scalars)."""
    from mitsuba_pbrdf import reference

    ti, pi_, tr, pr = (np.radians(a[rows]) for a in
                       (data.theta_i, data.phi_i, data.theta_r, data.phi_r))
    return reference.pbrdf(ti, pi_, tr, pr, **params)


class ModelData:
    """The geometry of ``data`` with the reference's matrices in place of the
    measured ones (what a :data:`MISREADINGS` entry needs: angles in degrees)."""

    def __init__(self, data, rows, **params):
        self.theta_i, self.phi_i = data.theta_i[rows], data.phi_i[rows]
        self.theta_r, self.phi_r = data.theta_r[rows], data.phi_r[rows]
        self.M = reference_rows(data, rows, **params)


def model_errors(data, pairs, name=None, **params):
    """:func:`pair_errors` of reciprocity for the reference model at the
    geometries of ``pairs``, read the project's way (``name=None``) or the
    wrong way ``name``."""
    rows = np.unique(pairs)
    model = ModelData(data, rows, **params)
    M = model.M if name is None else MISREADINGS[name][1](model.M, model)
    where = {r: i for i, r in enumerate(rows)}
    a = np.array([where[r] for r in pairs[:, 0]])
    b = np.array([where[r] for r in pairs[:, 1]])
    return pair_errors(M[a], M[b], reciprocal)
