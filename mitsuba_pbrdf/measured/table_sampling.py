"""Choose the entries of a ``.pbsdf`` table that a fit uses, as
:class:`~mitsuba_pbrdf.measured.Measurements` in the reference's global s/p
frames.

A KAIST table has 3 million cells of 5 x 16 values: a fit uses a few
thousand cells, read from the file one by one (:meth:`PbsdfTable.cells`;
nothing else of ``M`` is read):

* **in-plane slices**: every cell with ``phi_d`` on the grid values nearest 0
  and +-pi (light, normal and viewer in one plane; ``theta_i`` and
  ``theta_r`` then follow from theta_d and theta_h), up to half the budget,
  spread evenly over (theta_d, theta_h);
* **a stratified sample** of the rest: the cells with both directions above
  ``max_angle`` from the horizon, in table order, cut into equal strata with
  one random cell from each, so every region of (phi_d, theta_d, theta_h) is
  represented in proportion to its number of cells.

Cells where the light or the viewer is more than ``max_angle`` from the normal
are left out (grazing cells are the least reliable in measured data and
carry the model's 1 / cos singularity). A cell-wavelength entry with any NaN
element (unmeasured) is skipped; an infinite value is an error. The fit's
uncertainty model weighs each Mueller element by ``rel * |value| + abs * M00``
of its own entry (``pbrdf fit --rel-uncertainty``, ``--abs-uncertainty``): a
polarimeter's errors scale with the intensity, the specular peak (large M00)
does not drown the tails, and elements that are zero up to float32 rounding
(m03, m30 of an isotropic surface) are not given absurd weights.
"""

from __future__ import annotations

import math

import numpy as np

from .measurements import ELEMENTS, Measurements
from .pbsdf import PbsdfError, PbsdfTable
from .rusinkiewicz import angles, directions, facet_to_global

__all__ = ["sample_table", "table_cells"]


def table_cells(table: PbsdfTable, cells=3000, max_angle=80.0, seed=0):
    """Indices ``(ip, id, ih)`` of the cells a fit uses (see the module docstring)."""
    if cells < 1:
        raise ValueError(f"cells must be at least 1, got {cells}")
    if not 0.0 < max_angle < 90.0:
        raise ValueError(f"max_angle must be in (0, 90) degrees, got {max_angle:g}")
    # z of L and V (rusinkiewicz.directions): cos td cos th -+ sin td cos pd sin th,
    # by broadcasting (a KAIST grid has 3 million cells: no direction vectors)
    cos_cos = (np.cos(table.theta_d)[:, None] * np.cos(table.theta_h)[None, :])[None]
    sin_sin = (np.sin(table.theta_d)[:, None] * np.sin(table.theta_h)[None, :])[None]
    tilt = np.cos(table.phi_d)[:, None, None] * sin_sin
    limit = math.cos(math.radians(max_angle))
    valid = (cos_cos - tilt >= limit) & (cos_cos + tilt >= limit)
    del tilt
    rng = np.random.default_rng(seed)
    near = [int(np.argmin(np.abs(table.phi_d - a))) for a in (-np.pi, 0.0, np.pi)]
    in_plane = np.zeros(table.phi_d.size, bool)
    for j, a in zip(near, (-np.pi, 0.0, np.pi)):
        in_plane[j] |= abs(table.phi_d[j] - a) < math.radians(1.0)
    plane = np.flatnonzero((valid & in_plane[:, None, None]).ravel())
    if plane.size > cells // 2:
        plane = plane[np.linspace(0, plane.size - 1, cells // 2).round().astype(int)]
    rest = np.flatnonzero((valid & ~in_plane[:, None, None]).ravel())
    budget = min(cells - plane.size, rest.size)
    if budget > 0:
        edges = np.linspace(0, rest.size, budget + 1).astype(int)
        rest = rest[edges[:-1] + (rng.random(budget) * (edges[1:] - edges[:-1])).astype(int)]
    else:
        rest = rest[:0]
    chosen = np.unique(np.concatenate([plane, rest]))
    if chosen.size == 0:
        raise ValueError(f"{table.source}: no cell has both directions within {max_angle:g} deg "
                         f"of the normal")
    return np.unravel_index(chosen, valid.shape)


def sample_table(table: PbsdfTable, cells=3000, max_angle=80.0, seed=0, quantities=None):
    """The chosen cells as :class:`Measurements`: one row per cell and
    wavelength, angles in degrees, Mueller elements in 1/sr in the global s/p
    frames (``quantities``: names among ``m00`` ... ``m33``, ``dolp``;
    default the 16 elements)."""
    quantities = list(ELEMENTS) if quantities is None else list(quantities)
    unknown = [q for q in quantities if q not in ELEMENTS + ("dolp",)]
    if unknown or not quantities:
        raise ValueError(f"unknown quantities {', '.join(unknown) or '(none)'}; "
                         f"choose among m00 ... m33, dolp")
    ip, id_, ih = table_cells(table, cells, max_angle, seed)
    M = table.cells(ip, id_, ih).astype(np.float64)                 # (n, W, 4, 4)
    bad = np.isinf(M)
    if bad.any():
        c = np.argwhere(bad)[0]
        raise PbsdfError(f"{table.source}: M[{ip[c[0]]}, {id_[c[0]]}, {ih[c[0]]}, {c[1]}] "
                         f"is infinite")
    L, V = directions(table.phi_d[ip], table.theta_d[id_], table.theta_h[ih])
    M = facet_to_global(M, L, V)
    W = table.wavelengths.size
    ok = np.isfinite(M).all(axis=(-1, -2))                           # (n, W)
    ti, pi_, tr, pr = (np.degrees(np.repeat(a, W)) for a in angles(L, V))
    wavelength = np.tile(table.wavelengths, ip.size)
    M = M.reshape(-1, 4, 4)
    keep = ok.ravel()
    if not keep.any():
        raise ValueError(f"{table.source}: every chosen cell is NaN (unmeasured)")
    observed = {}
    for q in quantities:
        if q == "dolp":
            with np.errstate(invalid="ignore", divide="ignore"):
                d = np.hypot(M[:, 1, 0], M[:, 2, 0]) / M[:, 0, 0]
            observed[q] = np.where(M[:, 0, 0] > 0, np.clip(d, 0.0, 1.0), np.nan)[keep]
        else:
            observed[q] = M[:, int(q[1]), int(q[2])][keep]
    if "m00" in observed:
        observed["m00"] = np.maximum(observed["m00"], 0.0)
    return Measurements(ti[keep], pi_[keep], np.clip(tr[keep], 0, None), pr[keep],
                        wavelength[keep], observed, {}, table.source,
                        row_scale=np.maximum(M[keep, 0, 0], 0.0))
