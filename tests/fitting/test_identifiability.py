"""The uncertainties of :mod:`mitsuba_pbrdf.fitting.identifiability` on
Jacobians built from chosen singular values and vectors: a parameter that
shares a weak (not null) direction with undetermined ones gets its marginal
uncertainty, the diagonal of (J^T J)^-1, not the smaller one conditional on
the undetermined parameters held at their fitted values."""

import numpy as np

from mitsuba_pbrdf.fitting.identifiability import analyze

NAMES = ["ks", "kdd", "kid"]          # lobe weights at 1: scale 1 each


def jacobian(s, v_weak, rows=40, seed=1):
    """A rows x 3 Jacobian with singular values *s* (largest first) whose last
    right singular vector is *v_weak* (normalized)."""
    rng = np.random.default_rng(seed)
    v = np.asarray(v_weak, float) / np.linalg.norm(v_weak)
    V = np.linalg.qr(np.column_stack([v, rng.normal(size=(3, 2))]))[0]
    V = V[:, [1, 2, 0]]                                  # the weak one last
    U = np.linalg.qr(rng.normal(size=(rows, 3)))[0]
    return U @ np.diag(s) @ V.T


def test_a_small_share_of_a_weak_direction_widens_the_uncertainty():
    J = jacobian([100.0, 10.0, 0.5], [0.05, 0.3, 0.95])   # ks: share 0.05, moves 10 %
    sd, undetermined, groups = analyze(J, NAMES, np.ones(3))
    assert undetermined == ["kdd", "kid"] and groups == [["kdd", "kid"]]
    marginal = np.sqrt(np.linalg.inv(J.T @ J)[0, 0])
    assert np.isclose(sd[0], marginal, rtol=1e-9)
    assert sd[0] > 0.09                                  # conditional on kdd, kid: < 0.1 / 10


def test_a_small_share_that_moves_a_parameter_by_its_scale_is_undetermined():
    J = jacobian([100.0, 10.0, 0.05], [0.08, 0.3, 0.95])  # ks moves by 0.08 / 0.05 > 100 %
    sd, undetermined, _ = analyze(J, NAMES, np.ones(3))
    assert undetermined == NAMES and np.all(np.isinf(sd))
