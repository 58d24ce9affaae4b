"""The picture of a fit to goniometer measurements.

Per fitted quantity, a panel of data and models against the signed detector
angle in the plane of incidence (positive on the specular side; one colour
per incidence angle and wavelength; the data as dots over a light band of
their uncertainty, each model a line: three-component solid, two-component
dashed), on a logarithmic axis where the data span more than a decade, and
under it the residual: ``ln(model / data)`` for ``m00``, ``model - data`` for
the others. The band is each value's uncertainty as the fit weighed it
(``y exp(+-s)`` under the logarithmic objectives, ``y +- u`` under the
others). The legend sits beside the panels, off the data. Measurements out of
the plane of incidence are drawn as maps of the hemisphere of detector
directions (seen from above, the light's azimuth to the left: data, the first
model, and its residual), one row per incidence angle of the first wavelength
(at most :data:`MAP_ROWS`), for ``m00`` and DoLP.
"""

from __future__ import annotations

from typing import Dict

import numpy as np

from ..choices import MODELS
from ..measured.measurements import Measurements
from .objectives import OBJECTIVES, make_terms
from .observables import model_observables
from .result import FitResult

__all__ = ["plot_fit", "MAP_ROWS"]

#: Incidence angles drawn as hemisphere maps, at most.
MAP_ROWS = 4


def _in_plane_series(data):
    """(label, rows sorted by signed angle, signed angle) per incidence and wavelength."""
    dphi = np.radians(data.phi_r - data.phi_i)
    in_plane = np.abs(np.sin(dphi)) < 1e-6
    signed = np.where(np.cos(dphi) < 0, data.theta_r, -data.theta_r)     # + specular side
    series = []
    for w in data.wavelengths:
        for t in np.unique(data.theta_i):
            rows = np.flatnonzero((data.wavelength == w) & (data.theta_i == t) & in_plane)
            if rows.size:
                rows = rows[np.argsort(signed[rows])]
                series.append((f"{t:g} deg, {w:g} nm", rows, signed[rows]))
    return series, np.flatnonzero(~in_plane)


def _log_axis(y):
    positive = y[np.isfinite(y) & (y > 0)]
    return positive.size > 1 and positive.max() / positive.min() > 10 and (y[np.isfinite(y)] >= 0).all()


def _residual(q, model, y):
    if q == "m00":
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where((model > 0) & (y > 0), np.log(model / y), np.nan)
    return model - y


def _in_plane_panels(fig, grid, data, fitted, band, series, colors, legend_at):
    quantities = list(data.observed)
    for slot, q in enumerate(quantities):
        top = fig.add_subplot(grid[2 * (slot // grid.ncols), slot % grid.ncols])
        bottom = fig.add_subplot(grid[2 * (slot // grid.ncols) + 1, slot % grid.ncols], sharex=top)
        y_all = data.observed[q]
        log = _log_axis(y_all)
        for g, (label, rows, x) in enumerate(series):
            color = colors(g % 10)
            y, low, high = y_all[rows], band[q][0][rows], band[q][1][rows]
            ok = np.isfinite(y)
            if log:
                low = np.maximum(low, 0.5 * np.nanmin(np.where(y > 0, y, np.nan)))
            top.fill_between(x[ok], low[ok], high[ok], color=color, lw=0, zorder=0,
                             alpha=max(0.04, 0.3 / len(series)))   # overlapping bands stay light
            top.plot(x[ok], y[ok], ".", ms=2.5, color=color, alpha=0.8, zorder=1,
                     label=f"data {label}")
            for model, values in fitted.items():
                top.plot(x, values[q][rows], MODELS[model].line_style, color=color, lw=1.1,
                         zorder=3, label=f"{model}-component" if g == 0 else None)
                bottom.plot(x, _residual(q, values[q][rows], y), MODELS[model].line_style,
                            color=color, lw=0.9)
        if log:
            top.set_yscale("log")
        top.set_title(q)
        top.set_ylabel(q + (" (1/sr)" if q != "dolp" else ""))
        bottom.axhline(0.0, color="k", lw=0.6)
        bottom.set_ylabel("ln(model/data)" if q == "m00" else "model - data")
        bottom.set_xlabel("detector angle (deg, + = specular side)")
    handles, labels = fig.axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, fontsize=7, loc="upper left", bbox_to_anchor=legend_at,
               frameon=False)


def _maps(fig, grid, row0, data, results, fitted, rows_oop):
    import matplotlib
    from matplotlib.colors import LogNorm, Normalize

    quantities = [q for q in ("m00", "dolp") if q in data.observed]
    w0 = data.wavelengths[0]
    first = next(iter(results))
    incidences = np.unique(data.theta_i[rows_oop][data.wavelength[rows_oop] == w0])[:MAP_ROWS]
    r = row0
    for q in quantities:
        for t in incidences:
            rows = rows_oop[(data.theta_i[rows_oop] == t) & (data.wavelength[rows_oop] == w0)
                            & np.isfinite(data.observed[q][rows_oop])]
            if not rows.size:
                continue
            phi = np.radians(data.phi_r[rows] - data.phi_i[rows] - 180.0)
            x = np.sin(np.radians(data.theta_r[rows])) * np.cos(phi)
            yy = np.sin(np.radians(data.theta_r[rows])) * np.sin(phi)
            y, m = data.observed[q][rows], fitted[first][q][rows]
            both = np.concatenate([y, m])
            if q == "m00" and (both > 0).any():
                norm = LogNorm(np.nanmin(both[both > 0]), np.nanmax(both))
            else:
                norm = Normalize(np.nanmin(both), np.nanmax(both))
            res = _residual(q, m, y)
            bound = float(np.nanmax(np.abs(res))) if np.isfinite(res).any() else 1.0
            panels = ((f"{q} data, {t:g} deg, {w0:g} nm", y, norm, "viridis"),
                      (f"{q} {first}-component", m, norm, "viridis"),
                      ("ln(model/data)" if q == "m00" else "model - data", res,
                       Normalize(-bound, bound), "RdBu_r"))
            for c, (title, values, nrm, cmap) in enumerate(panels):
                ax = fig.add_subplot(grid[r, c])
                sc = ax.scatter(x, yy, c=values, s=9, norm=nrm, cmap=matplotlib.colormaps[cmap])
                ax.add_patch(matplotlib.patches.Circle((0, 0), 1.0, fill=False, lw=0.5))
                mirror = np.sin(np.radians(t))
                ax.plot([mirror], [0.0], "k+", ms=7)
                ax.set_aspect("equal")
                ax.set_xlim(-1.05, 1.05)
                ax.set_ylim(-1.05, 1.05)
                ax.set_xticks([])
                ax.set_yticks([])
                ax.set_title(title, fontsize=8)
                fig.colorbar(sc, ax=ax, fraction=0.046, pad=0.02)
            r += 1
    return r


def plot_fit(data: Measurements, results: Dict[str, FitResult], path, title=None):
    """Write the picture of the fit (see the module docstring) to *path* (PNG)."""
    import matplotlib
    matplotlib.use("Agg")
    from matplotlib.figure import Figure
    from matplotlib.gridspec import GridSpec

    quantities = list(data.observed)
    series, rows_oop = _in_plane_series(data)
    fitted = {m: model_observables(data, r.values, r.shadowing, r.dd_distribution, None,
                                   r.distribution) for m, r in results.items()}
    first = next(iter(results.values()))
    band = {}                   # (low, high) of each value's uncertainty, as the fit weighed it
    for t in make_terms(data, first.objective, first.rel_uncertainty, first.abs_uncertainty,
                        first.log_floor):
        low, high = np.full(len(data), np.nan), np.full(len(data), np.nan)
        if OBJECTIVES[t.objective].relative:
            low[t.rows], high[t.rows] = t.y * np.exp(-t.s), t.y * np.exp(t.s)
        else:
            low[t.rows], high[t.rows] = t.y - t.u, t.y + t.u
        band[t.name] = (low, high)
    ncols = min(len(quantities), 4) if series else 3
    plane_rows = -(-len(quantities) // ncols) if series else 0
    map_rows = 0
    if rows_oop.size:
        w0 = data.wavelengths[0]
        per_q = min(MAP_ROWS, np.unique(data.theta_i[rows_oop][data.wavelength[rows_oop] == w0]).size)
        map_rows = per_q * sum(q in data.observed for q in ("m00", "dolp"))
    ncols = max(ncols, 3 if map_rows else 1)
    heights = [3.0, 1.3] * plane_rows + [3.2] * map_rows
    width, height = 4.8 * ncols + 3.4, 1.25 * sum(heights) + 1.0
    fig = Figure(figsize=(width, height))
    right = 1.0 - 2.4 / width                       # 2.4 in for the legend
    grid = GridSpec(len(heights), ncols, figure=fig, height_ratios=heights, hspace=0.45,
                    wspace=0.35, right=right, left=1.0 / width, top=1.0 - 0.7 / height,
                    bottom=0.5 / height)
    colors = matplotlib.colormaps["tab10"]
    if series:
        _in_plane_panels(fig, grid, data, fitted, band, series, colors,
                         (right + 0.01, 1.0 - 0.7 / height))
    if map_rows:
        _maps(fig, grid, 2 * plane_rows, data, results, fitted, rows_oop)
    fig.suptitle(title or "fit", y=1.0 - 0.25 / height)
    fig.savefig(path, dpi=110)
    return path
