"""Physical realizability of Mueller matrices: Cloude's coherency matrix and
the degree of polarization of the output over the Poincaré sphere.

Works on any array of Mueller matrices (``(..., 4, 4)``, any units: a BRDF in
1/sr, a reflectance, a sample weight), whatever produced them, e.g.
:func:`mitsuba_pbrdf.frames.eval_global` of any Mitsuba BSDF. Stokes vectors
follow the project's convention (:func:`mitsuba_pbrdf.reference.jones_to_mueller`):
S0 = |Ex|² + |Ey|², S1 = |Ex|² − |Ey|², S2 = 2 Re(Ex Ey*), S3 = 2 Im(Ex Ey*);
realizability does not depend on the frames the matrices are expressed in.

Pure NumPy: no Mitsuba needed.
"""

import numpy as np

#: Unit roundoff of float32.
U32 = 2.0 ** -24
#: Realizability tolerance relative to M00 for a float32 Mueller matrix assembled
#: from realizable factors (a non-negative scale, the Jones-derived facet
#: matrix built from two complex amplitudes, orthogonal frame rotations,
#: depolarizers with non-negative weights), as the ``pbrdf`` plugin's: only the
#: rounding of its 16 entries (a few float32 operations each,
#: |dM_ij| <= 4 u M00) can make it unphysical, and that moves the coherency
#: eigenvalues by at most ||dH||_2 <= ||dM||_F / 2 <= 8 u M00 (H = sum M_ij
#: B_ij / 4 with orthogonal B_ij of Frobenius norm 2). Allow 16 u.
REALIZABILITY_TOL = 16 * U32

# Pauli-like basis s_i with S_i = E^H s_i E for a Jones vector E.
_S = np.array([
    [[1, 0], [0, 1]],
    [[1, 0], [0, -1]],
    [[0, 1], [1, 0]],
    [[0, 1j], [-1j, 0]],
], dtype=np.complex128)
# The Mueller matrix of a Jones matrix J is M_ij = tr(s_i J s_j J^H) / 2, and
# H = sum_ij M_ij (s_i kron conj(s_j)) / 4 equals vec(J) vec(J)^H / 2 (row-major
# vec): Hermitian, positive semi-definite, rank 1. A Mueller matrix is a convex
# sum of such (physically realizable) exactly when H >= 0 (Cloude 1986).
_BASIS = np.einsum("iab,jcd->ijacbd", _S, np.conj(_S)).reshape(4, 4, 4, 4) / 4.0


def coherency_matrix(M):
    """Cloude's coherency matrix (..., 4, 4) complex Hermitian, trace M00."""
    M = np.asarray(M, dtype=np.float64)
    return np.einsum("...ij,ijab->...ab", M, _BASIS)


def coherency_eigenvalues(M):
    """Eigenvalues (..., 4), ascending, of Cloude's coherency matrix of M.

    All are >= 0 for a physically realizable Mueller matrix and they sum to
    M00; a non-depolarizing (Jones) matrix has one non-zero eigenvalue."""
    return np.linalg.eigvalsh(coherency_matrix(M))


def output_dop(M, stokes_in):
    """Degree of polarization of M applied to each input Stokes vector.

    ``M`` (..., 4, 4), ``stokes_in`` (s, 4); returns (S0 (..., s), polarized
    part |S1..S3| (..., s))."""
    out = np.einsum("...ij,sj->...si", M, stokes_in)
    return out[..., 0], np.sqrt(np.sum(out[..., 1:] ** 2, axis=-1))


def poincare_inputs(n=62, seed=0):
    """Unpolarized light, the six pure states (+-S1, +-S2, +-S3) and ``n``
    random fully polarized states: (n + 7, 4) Stokes vectors with S0 = 1."""
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    pure = np.vstack([np.eye(3), -np.eye(3), v])
    return np.vstack([[1.0, 0, 0, 0], np.hstack([np.ones((len(pure), 1)), pure])])


def realizability(M, floor=0.0, inputs=None):
    """How far Mueller matrices ``M`` (..., 4, 4) are from realizable.

    Only matrices with M00 > ``floor`` are checked: set it where the
    entries stop being normal numbers with full relative precision (far tails
    of narrow lobes underflow to denormals, whose few significant bits make any
    matrix look unphysical). Each matrix is divided by its M00 first (squares
    of entries ~1e-160 would underflow).

    Returns ``(count, min eigenvalue / M00, max DOP excess / M00, min M00)``:
    the number of matrices checked, the smallest coherency eigenvalue (>= 0
    when realizable) and the largest (|S_out,1..3| − S_out,0) / M00 over the
    input Stokes vectors ``inputs`` (default :func:`poincare_inputs`; <= 0 when
    realizable; measured so even where the output intensity vanishes).
    """
    inputs = poincare_inputs() if inputs is None else inputs
    M = np.asarray(M, dtype=np.float64)
    m00 = M[..., 0, 0]
    ok = m00 > floor
    normalized = M[ok] / m00[ok][..., None, None]
    lam = coherency_eigenvalues(normalized)[..., 0]
    s0, pol = output_dop(normalized, inputs)
    excess = np.max(pol - s0, axis=-1)
    return int(ok.sum()), float(lam.min()), float(excess.max()), float(m00[ok].min())
