"""A NumPy emulation of Mitsuba's ``measured_polarized`` lookup: the Mueller
BRDF a ``.pbsdf`` table gives between two directions, in the reference's
global s/p frames.

What the plugin does (``src/bsdfs/measured_polarized.cpp`` and
``include/mitsuba/core/distr_2d.h``, Mitsuba 3.9.1), and this module repeats:

1. the Rusinkiewicz angles ``(phi_d, theta_d, theta_h)`` of the light and
   view directions (:func:`~mitsuba_pbrdf.measured.rusinkiewicz.rusinkiewicz`);
2. multilinear interpolation in ``(phi_d, theta_d, theta_h, wavelength)``:
   per axis the interval ``i`` is the last grid value below the argument,
   clamped to ``[0, N - 2]``, and the weight ``(x - g[i]) / (g[i+1] - g[i])``
   is clipped to [0, 1], so arguments outside a grid take its end value (an
   axis of one value is constant). The 16 corner entries are blended, so a
   NaN (unmeasured) corner makes the result NaN;
3. where M00 of the blend is NaN the whole matrix is 0 (the plugin tests the
   spectrum's M00 at once); then ``M00 = max(0, M00)``;
4. the result is rotated from the table's facet frames into the output frames
   (here the reference's global s/p frames; the plugin uses Mitsuba's
   ``stokes_basis``), and the plugin multiplies it by the cosine of the light
   direction (this function does not: it returns the BRDF).

Used to predict a render's interpolation error before comparing it with the
model (``validation/measured_oracle.py``), and to draw measured slices.
"""

from __future__ import annotations

import numpy as np

from .pbsdf import PbsdfTable
from .rusinkiewicz import facet_to_global, rusinkiewicz

__all__ = ["interval_weights", "lookup_facet", "lookup"]


def interval_weights(grid, x):
    """``(index, weight)`` of ``measured_polarized``'s linear interpolation on
    ``grid`` at ``x``: the value is ``(1 - w) g[i] + w g[i + 1]``."""
    grid = np.asarray(grid, dtype=np.float64)
    x = np.asarray(x, dtype=np.float64)
    if grid.size == 1:
        return np.zeros(x.shape, dtype=np.intp), np.zeros(x.shape)
    i = np.clip(np.searchsorted(grid, x, side="left") - 1, 0, grid.size - 2)
    with np.errstate(invalid="ignore"):
        w = np.clip((x - grid[i]) / (grid[i + 1] - grid[i]), 0.0, 1.0)
    return i, w


def lookup_facet(table: PbsdfTable, phi_d, theta_d, theta_h, wavelength):
    """Interpolated table entries (..., 4, 4) at Rusinkiewicz angles (radians)
    and wavelengths (nm) broadcast together, in the table's facet frames,
    with the plugin's NaN and M00 rules (steps 2-3 above)."""
    args = np.broadcast_arrays(*(np.asarray(a, dtype=np.float64)
                                 for a in (phi_d, theta_d, theta_h, wavelength)))
    grids = (table.phi_d, table.theta_d, table.theta_h, table.wavelengths)
    iw = [interval_weights(g, a) for g, a in zip(grids, args)]
    steps = [0 if g.size == 1 else 1 for g in grids]
    out = np.zeros(args[0].shape + (4, 4))
    for corner in range(16):
        bits = [(corner >> (3 - a)) & 1 for a in range(4)]
        weight = np.ones(args[0].shape)
        index = []
        for (i, w), bit, step in zip(iw, bits, steps):
            weight = weight * (w if bit else 1.0 - w)
            index.append(i + bit * step)
        # gathered from the (memory-mapped) table: only these entries are read
        out += weight[..., None, None] * np.asarray(table.M[tuple(index)], dtype=np.float64)
    out[np.isnan(out[..., 0, 0])] = 0.0
    out[..., 0, 0] = np.maximum(out[..., 0, 0], 0.0)
    return out


def lookup(table: PbsdfTable, L, V, wavelength):
    """The Mueller BRDF (..., 4, 4) in 1/sr (no cosine) that
    ``measured_polarized`` gives for light from ``L`` seen from ``V`` (unit
    vectors (..., 3), local frame) at ``wavelength`` (nm, broadcast against
    the directions' shape), in the reference's global s/p frames; 0 where
    either direction is below the horizon."""
    L = np.asarray(L, dtype=np.float64)
    V = np.asarray(V, dtype=np.float64)
    phi_d, theta_d, theta_h = rusinkiewicz(L, V)
    M = lookup_facet(table, phi_d, theta_d, theta_h, wavelength)
    M = facet_to_global(M, L, V)
    above = (L[..., 2] > 0) & (V[..., 2] > 0)
    return np.where(above[..., None, None], M, 0.0)
