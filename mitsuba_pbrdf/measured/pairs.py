"""Rows of a set of measurements that are the same geometry with the light and
the detector swapped (reciprocal pairs), or mirrored through the plane of
incidence, found in O(N log N): a campaign of 10^6 rows has them too.

Angles in degrees; ``dphi = phi_r - phi_i`` wrapped to [-180, 180). Rows A and
B of one wavelength are *swapped* when B's (theta_i, theta_r, dphi) is A's
(theta_r, theta_i, -dphi), and *mirrored* when it is A's (theta_i, theta_r,
-dphi), each angle within ``tol``. An isotropic sample's M00 is the same in
both rows of either (Helmholtz reciprocity; mirror symmetry).
"""

from __future__ import annotations

import numpy as np

__all__ = ["TOL", "wrap", "matching_pairs"]

#: Matching tolerance of the angles (deg): goniometers step by 0.1 deg or more and
#: files print 6 significant digits.
TOL = 0.01


def wrap(angle):
    """Degrees wrapped to [-180, 180)."""
    return (np.asarray(angle, dtype=np.float64) + 180.0) % 360.0 - 180.0


def matching_pairs(data, swap=True, tol=TOL) -> np.ndarray:
    """(P, 2) row indices (a, b), every match both ways (a row may match
    itself), sorted by wavelength, then a, then b: b swapped (``swap``) or
    mirrored from a, as the module docstring says."""
    d = wrap(data.phi_r - data.phi_i)
    ti, tr = np.asarray(data.theta_i, np.float64), np.asarray(data.theta_r, np.float64)
    w = row_w = np.searchsorted(data.wavelengths, data.wavelength)
    # cells at least tol wide: two angles within tol are at most one cell apart
    n_theta = int(np.ceil(max(np.max(np.abs(ti), initial=0), np.max(np.abs(tr), initial=0))
                          / tol)) + 2
    n_phi = max(int(np.floor(360.0 / tol)), 1)
    if len(data.wavelengths) * float(n_theta) ** 2 * n_phi >= 2.0 ** 62:
        raise ValueError(f"matching tolerance {tol:g} deg is too fine for this data")
    cell_t = lambda t: np.floor(np.abs(t) / tol).astype(np.int64)
    cell_p = lambda p: np.floor((p + 180.0) * n_phi / 360.0).astype(np.int64) % n_phi

    def key(w_, a, b, c):
        return ((w_ * n_theta + a) * n_theta + b) * n_phi + c

    keys = key(w.astype(np.int64), cell_t(ti), cell_t(tr), cell_p(d))
    order = np.argsort(keys, kind="stable")
    ordered = keys[order]
    want_i, want_r = (tr, ti) if swap else (ti, tr)
    want_d = wrap(-d)
    ci, cr, cd = cell_t(want_i), cell_t(want_r), cell_p(want_d)
    # the searches in the order of the wanted cells: sorted needles search fast
    by_want = np.argsort(key(w.astype(np.int64), ci, cr, cd), kind="stable")
    w, ci, cr, cd = w[by_want], ci[by_want], cr[by_want], cd[by_want]
    found = []
    for oi in (-1, 0, 1):
        for orr in (-1, 0, 1):
            for od in (-1, 0, 1):
                a_cell, b_cell = ci + oi, cr + orr
                ok = (a_cell >= 0) & (b_cell >= 0)
                target = key(w.astype(np.int64), a_cell, b_cell, (cd + od) % n_phi)
                lo = np.searchsorted(ordered, target, "left")
                hi = np.searchsorted(ordered, target, "right")
                counts = np.where(ok, hi - lo, 0)
                a = np.repeat(by_want, counts)
                first = np.repeat(lo, counts)
                within = np.arange(len(a)) - np.repeat(np.cumsum(counts) - counts, counts)
                b = order[first + within]
                found.append(np.stack([a, b], 1))
    pairs = np.concatenate(found) if found else np.zeros((0, 2), np.int64)
    if n_phi < 3:
        pairs = np.unique(pairs, axis=0)          # the azimuth's three cells are not distinct
    a, b = pairs[:, 0], pairs[:, 1]
    match = ((row_w[a] == row_w[b]) & (np.abs(ti[b] - want_i[a]) < tol) & (np.abs(tr[b] - want_r[a]) < tol)
             & (np.abs(wrap(d[a] + d[b])) < tol))
    pairs = pairs[match]
    return pairs[np.lexsort((pairs[:, 1], pairs[:, 0], row_w[pairs[:, 0]]))].reshape(-1, 2)
