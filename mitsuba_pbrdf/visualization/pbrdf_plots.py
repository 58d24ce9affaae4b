"""Plots of the model's pBRDF: lobes, Mueller elements and degree of polarization.

Everything here is computed with the NumPy float64 reference evaluator
(:mod:`mitsuba_pbrdf.reference`): no Mitsuba variant is needed, and the plugin
agrees with it to about 3e-5 of M00 (``docs/validation.md``). Frames and
signs are the reference's: global s/p frames, S1 = I_s − I_p, so S1 > 0
means s-polarized (``docs/conventions.md``).

::

    from mitsuba_pbrdf.visualization.pbrdf_plots import PBRDFParams, save_pbrdf_plot
    save_pbrdf_plot("cu.png", PBRDFParams(material="Cu", sigma=0.1, kdd=0.2), theta_i=40)

Geometry of the plots: the light lies in the plane of incidence at azimuth
φi = 0 and zenith θi. *In-plane* curves use a signed reflection angle θr:
positive on the specular side (φr = 180°, the mirror direction is θr = θi),
negative on the side of the light (φr = 0°, backscattering; the light itself
is at θr = −θi). *Hemisphere* maps show the whole reflected hemisphere seen from
above, projected on the disk (x, y) = sin θr (−cos φr, sin φr), oriented like
the in-plane plots: the light is at (−sin θi, 0) on the left, the mirror
direction at (sin θi, 0) on the right.

Anisotropic surfaces (``sigma_u`` ≠ ``sigma_v``): the light's azimuth φi
(``phi_i``, degrees from the surface's s axis ``dp_du``) turns the plane of
incidence; every panel is drawn in the turned frame (light on the left) and
the maps mark the s axis with an arrow. The figure then adds a row of maps
with the light turned by 90°, so both axes of the stretched lobe show.

Exactly at the normal (θr = 0) the global s/p frame switches to the surface's
x-axis (the reference's convention), a 90° jump of the Stokes frame that flips
the signs of m22, m23, ...; the grids here avoid that single direction.

The degree of polarization plotted is that of the reflected light when the
incident light is unpolarized: DoP = sqrt(M10² + M20² + M30²) / M00.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from ..reference.params import PBRDFParams, check_theta_i, dop_unpolarized

__all__ = [
    "PBRDFParams",
    "InPlane",
    "in_plane",
    "hemisphere",
    "dop_unpolarized",
    "plot_polar_lobe",
    "plot_in_plane_m00",
    "plot_in_plane_elements",
    "plot_in_plane_dop",
    "plot_hemisphere",
    "is_anisotropic",
    "pbrdf_figure",
    "save_pbrdf_plot",
    "DEFAULT_WAVELENGTHS",
]

#: Wavelengths (nm) drawn by default: blue, green (the "main" one), red.
DEFAULT_WAVELENGTHS = (550.0, 450.0, 650.0)

@dataclass
class InPlane:
    """In-plane evaluation: ``angles`` (deg, signed θr, shape (n,)),
    ``wavelengths`` (nm, (w,)), ``M`` (n, w, 4, 4) of the whole model and
    ``lobes`` {name: M00 (n, w)} of each weighted lobe."""

    theta_i: float
    angles: np.ndarray
    wavelengths: np.ndarray
    M: np.ndarray
    lobes: dict


def in_plane(params: PBRDFParams, theta_i: float,
             wavelengths: Sequence[float] = DEFAULT_WAVELENGTHS,
             n_angles: int = 720, phi_i: float = 0.0) -> InPlane:
    """Evaluate in the plane of incidence for θi = *theta_i* degrees (light at
    azimuth *phi_i* degrees), at *n_angles* signed reflection angles in
    (−90°, 90°) (module docstring; an even count leaves out θr = 0)."""
    params.validate()
    check_theta_i(theta_i)
    limit = 89.75
    angles = np.linspace(-limit, limit, n_angles)
    theta_r = np.radians(np.abs(angles))
    phi = math.radians(phi_i)
    phi_r = np.where(angles >= 0, np.pi, 0.0) + phi
    ti = np.full_like(theta_r, math.radians(theta_i))
    wl = np.asarray(wavelengths, dtype=np.float64)
    M = params.evaluate(ti, phi, theta_r, phi_r, wl)
    lobes = {}
    for lobe, weight in (("specular", params.ks), ("directional_diffuse", params.kdd),
                         ("ideal_diffuse", params.kid)):
        if weight:
            lobes[lobe] = params.evaluate(ti, phi, theta_r, phi_r, wl, lobe)[..., 0, 0]
    return InPlane(float(theta_i), angles, wl, M, lobes)


def hemisphere(params: PBRDFParams, theta_i: float, wavelength: float = 550.0,
               resolution: int = 200, phi_i: float = 0.0):
    """Evaluate over the reflected hemisphere on a *resolution*² grid of the
    projected disk (module docstring; an even resolution leaves out the
    normal), the light at azimuth *phi_i* degrees, the disk turned with it;
    returns ``(x, y, M)`` with M (res, res, 4, 4) (NaN outside the disk)."""
    params.validate()
    check_theta_i(theta_i)
    x = np.linspace(-1.0, 1.0, resolution)
    X, Y = np.meshgrid(x, x)
    r = np.hypot(X, Y)
    inside = r < 0.9995
    theta_r = np.arcsin(np.clip(r, 0.0, 0.9995))
    phi = math.radians(phi_i)
    phi_r = np.arctan2(Y, -X) + phi
    M = params.evaluate(np.full_like(theta_r, math.radians(theta_i)), phi, theta_r, phi_r,
                        [wavelength])[..., 0, :, :]
    M = np.where(inside[..., None, None], M, np.nan)
    return X, Y, M


# ---------------------------------------------------------------------------
# Plotting (each function draws on the axes it is given)

_LOBE_STYLE = {
    "specular": ("specular (polarizing)", "--"),
    "directional_diffuse": ("directional diffuse", "-."),
    "ideal_diffuse": ("ideal diffuse", ":"),
}


def _wavelength_colour(wl):
    """An approximate display colour for a visible wavelength (nm)."""
    import matplotlib

    t = np.clip((float(wl) - 420.0) / (680.0 - 420.0), 0.0, 1.0)
    return matplotlib.colormaps["turbo"](0.1 + 0.8 * t)


def _mark_geometry(ax, theta_i, vertical=True):
    ax.axvline(theta_i, color="0.6", lw=0.8, ls="--")
    ax.axvline(-theta_i, color="0.8", lw=0.8, ls=":")


def plot_polar_lobe(ax, data: InPlane, wavelength_index: int = 0, log: bool = False):
    """Polar plot of the in-plane lobe M00(θr), normalized to its peak, total
    and per lobe, at one wavelength; *ax* must be a polar Axes. The normal
    points up; the light comes from the left (arrow)."""
    theta = np.radians(data.angles)
    m00 = data.M[:, wavelength_index, 0, 0]
    peak = np.nanmax(m00) if np.nanmax(m00) > 0 else 1.0

    def radius(v):
        v = np.asarray(v) / peak
        return np.clip(1.0 + np.log10(np.maximum(v, 1e-4)) / 4.0, 0.0, None) if log else v

    ax.set_theta_zero_location("N")
    ax.set_theta_direction(-1)  # positive angles (specular side) to the right
    ax.set_thetamin(-90)
    ax.set_thetamax(90)
    ax.plot(theta, radius(m00), color="k", lw=1.5, label="total M00")
    for lobe, values in data.lobes.items():
        if len(data.lobes) > 1:
            name, style = _LOBE_STYLE[lobe]
            ax.plot(theta, radius(values[:, wavelength_index]), ls=style, lw=1, label=name)
    ti = math.radians(data.theta_i)
    ax.annotate("", xy=(0.0, 0.0), xytext=(-ti, 1.1 if not log else 1.1),
                arrowprops=dict(arrowstyle="->", color="tab:orange", lw=1.5),
                annotation_clip=False)
    ax.plot([ti], [1.0], marker="o", ms=3, color="0.5")
    ax.set_rlim(0, 1.15)
    ax.set_rticks([0.25, 0.5, 0.75, 1.0] if not log else [0.25, 0.5, 0.75, 1.0])
    if log:
        ax.set_yticklabels(["1e-3", "1e-2", "0.1", "1"], fontsize=6)
    else:
        ax.tick_params(axis="y", labelsize=6)
    ax.tick_params(axis="x", labelsize=7)
    ax.set_title(f"In-plane lobe at {data.wavelengths[wavelength_index]:g} nm "
                 f"({'log, ' if log else ''}÷ peak)", fontsize=9)
    ax.legend(fontsize=6, loc="lower center", bbox_to_anchor=(0.5, -0.22), ncol=2,
              frameon=False)
    return ax


def plot_in_plane_m00(ax, data: InPlane):
    """M00 (1/sr, log scale) against the signed θr: the whole model at each
    wavelength and, at the first wavelength, each weighted lobe."""
    for w, wl in enumerate(data.wavelengths):
        ax.semilogy(data.angles, data.M[:, w, 0, 0], color=_wavelength_colour(wl), lw=1.4,
                    label=f"total, {wl:g} nm")
    if len(data.lobes) > 1:
        for lobe, values in data.lobes.items():
            name, style = _LOBE_STYLE[lobe]
            ax.semilogy(data.angles, values[:, 0], color="0.35", ls=style, lw=1,
                        label=f"{name}, {data.wavelengths[0]:g} nm")
    positive = data.M[:, :, 0, 0][data.M[:, :, 0, 0] > 0]
    if positive.size:
        ax.set_ylim(max(positive.min(), positive.max() * 1e-5) * 0.5, positive.max() * 2)
    _mark_geometry(ax, data.theta_i)
    _axes_in_plane(ax, "M00 (1/sr)", "BRDF M00 in the plane of incidence")
    ax.legend(fontsize=6, loc="upper left")
    return ax


def plot_in_plane_elements(ax, data: InPlane, wavelength_index: int = 0):
    """Normalized Mueller elements m01, m11, m22, m23, m33 (/M00) against the
    signed θr; in the plane of incidence the others vanish (m10 = m01,
    m32 = −m23)."""
    M = data.M[:, wavelength_index]
    m00 = M[:, 0, 0]
    for (i, j), colour, style in zip([(0, 1), (1, 1), (3, 3), (2, 2), (2, 3)],
                                     ["tab:red", "tab:purple", "tab:cyan", "tab:blue",
                                      "tab:green"], ["-", "-", "-", "--", "-"]):
        ratio = np.divide(M[:, i, j], m00, out=np.full_like(m00, np.nan), where=m00 > 0)
        ax.plot(data.angles, ratio, color=colour, ls=style, lw=1.3, label=f"m{i}{j}/m00")
    ax.axhline(0.0, color="0.7", lw=0.6)
    ax.set_ylim(-1.05, 1.05)
    _mark_geometry(ax, data.theta_i)
    _axes_in_plane(ax, "normalized element",
                   f"Mueller elements at {data.wavelengths[wavelength_index]:g} nm")
    ax.legend(fontsize=6, loc="lower left", ncol=2)
    return ax


def plot_in_plane_dop(ax, data: InPlane):
    """DoP of the reflected light (unpolarized incident light) against the
    signed θr, at each wavelength."""
    dop = dop_unpolarized(data.M)
    for w, wl in enumerate(data.wavelengths):
        ax.plot(data.angles, dop[:, w], color=_wavelength_colour(wl), lw=1.4, label=f"{wl:g} nm")
    ax.set_ylim(0.0, max(0.05, float(np.nanmax(dop)) * 1.15))
    _mark_geometry(ax, data.theta_i)
    _axes_in_plane(ax, "DoP", "Degree of polarization, unpolarized light in")
    ax.legend(fontsize=6, loc="upper left")
    return ax


def _axes_in_plane(ax, ylabel, title):
    ax.set_xlim(-90, 90)
    ax.set_xticks([-90, -60, -30, 0, 30, 60, 90])
    ax.set_xlabel("signed reflection angle θr (deg; + specular side)", fontsize=8)
    ax.set_ylabel(ylabel, fontsize=8)
    ax.set_title(title, fontsize=9)
    ax.tick_params(labelsize=7)
    ax.grid(alpha=0.3)


def is_anisotropic(params: PBRDFParams) -> bool:
    """Whether any lobe of *params* has different widths along s and t."""
    pairs = ((params.sigma, params.sigma_u, params.sigma_v),
             (params.sigma_dd, params.sigma_dd_u, params.sigma_dd_v))
    return any((base if u is None else u) != (base if v is None else v) for base, u, v in pairs)


def plot_hemisphere(ax, params: PBRDFParams, theta_i: float, quantity: str = "m00",
                    wavelength: float = 550.0, resolution: int = 200, phi_i: float = 0.0):
    """Map of ``m00`` (log colour scale, 1/sr) or ``dop`` over the reflected
    hemisphere (projected disk, seen from above); the light's direction is
    marked with a star, the mirror direction with a cross; for an anisotropic
    surface, an arrow shows the surface's s axis (the light at azimuth
    *phi_i* degrees from it)."""
    from matplotlib.colors import LogNorm

    X, Y, M = hemisphere(params, theta_i, wavelength, resolution, phi_i)
    if quantity == "m00":
        values = M[..., 0, 0]
        positive = values[np.isfinite(values) & (values > 0)]
        vmax = positive.max() if positive.size else 1.0
        norm = LogNorm(vmin=max(positive.min() if positive.size else vmax * 1e-4, vmax * 1e-4),
                       vmax=vmax)
        im = ax.pcolormesh(X, Y, np.where(values > 0, values, np.nan), norm=norm, cmap="magma",
                           shading="auto", rasterized=True)
        label, title = "M00 (1/sr)", "BRDF M00 over the hemisphere"
    elif quantity == "dop":
        values = np.where(np.isfinite(M[..., 0, 0]), dop_unpolarized(np.nan_to_num(M)), np.nan)
        im = ax.pcolormesh(X, Y, values, vmin=0.0, vmax=max(0.05, float(np.nanmax(values))),
                           cmap="viridis", shading="auto", rasterized=True)
        label, title = "DoP", "DoP over the hemisphere"
    else:
        raise ValueError(f"quantity must be 'm00' or 'dop', got {quantity!r}")
    s = math.sin(math.radians(theta_i))
    ax.plot([-s], [0.0], marker="*", color="tab:orange", ms=9, mec="k", mew=0.5, ls="none",
            label="light")
    ax.plot([s], [0.0], marker="x", color="w", ms=6, mec="k", ls="none",
            label="mirror direction")
    t = np.linspace(0, 2 * np.pi, 200)
    for deg in (30, 60, 90):
        r = math.sin(math.radians(deg))
        ax.plot(r * np.cos(t), r * np.sin(t), color="0.6", lw=0.5)
    ax.set_aspect("equal")
    ax.set_xlim(-1.02, 1.02)
    ax.set_ylim(-1.02, 1.02)
    ax.set_xticks([])
    ax.set_yticks([])
    if is_anisotropic(params):     # azimuth 0 is drawn at (-cos phi_i, -sin phi_i)
        c, s_ = math.cos(math.radians(phi_i)), math.sin(math.radians(phi_i))
        ax.annotate("s (dp_du)", xy=(-0.95 * c, -0.95 * s_), xytext=(-0.45 * c, -0.45 * s_),
                    color="w", fontsize=7, ha="center", va="center",
                    arrowprops=dict(arrowstyle="->", color="w", lw=1.0))
        title += f", φi = {phi_i:g}°"
    ax.set_title(f"{title} ({wavelength:g} nm)", fontsize=9)
    cb = ax.figure.colorbar(im, ax=ax, fraction=0.046, pad=0.03)
    cb.set_label(label, fontsize=8)
    cb.ax.tick_params(labelsize=7)
    ax.legend(fontsize=6, loc="lower left", framealpha=0.6)
    ax.text(0.98, 0.02, "rings: θr = 30°, 60°, 90°", transform=ax.transAxes, fontsize=6,
            ha="right", va="bottom", color="0.4")
    return ax


def pbrdf_figure(params: PBRDFParams, theta_i: float,
                 wavelengths: Sequence[float] = DEFAULT_WAVELENGTHS,
                 title: Optional[str] = None, resolution: int = 200, phi_i: float = 0.0):
    """The composite plot sheet (2 × 3 panels; matplotlib Figure drawn with
    Agg): polar lobe, M00, normalized Mueller elements and DoP in the plane of
    incidence, M00 and DoP maps over the hemisphere. The first wavelength is
    the one used for single-wavelength panels. The light lies at azimuth
    *phi_i* degrees; an anisotropic surface gets a third row: the M00 and DoP
    maps with the light turned by 90°."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    params.validate()
    check_theta_i(theta_i)
    wavelengths = [float(w) for w in wavelengths]
    if not wavelengths:
        raise ValueError("give at least one wavelength")
    data = in_plane(params, theta_i, wavelengths, phi_i=phi_i)
    anisotropic = is_anisotropic(params)
    fig = Figure(figsize=(15, 13.8 if anisotropic else 9.2), layout="constrained")
    FigureCanvasAgg(fig)
    grid = fig.add_gridspec(3 if anisotropic else 2, 3)
    plot_polar_lobe(fig.add_subplot(grid[0, 0], projection="polar"), data)
    plot_in_plane_m00(fig.add_subplot(grid[0, 1]), data)
    plot_in_plane_elements(fig.add_subplot(grid[0, 2]), data)
    plot_in_plane_dop(fig.add_subplot(grid[1, 0]), data)
    plot_hemisphere(fig.add_subplot(grid[1, 1]), params, theta_i, "m00", wavelengths[0],
                    resolution, phi_i)
    plot_hemisphere(fig.add_subplot(grid[1, 2]), params, theta_i, "dop", wavelengths[0],
                    resolution, phi_i)
    if anisotropic:
        plot_hemisphere(fig.add_subplot(grid[2, 1]), params, theta_i, "m00", wavelengths[0],
                        resolution, phi_i + 90.0)
        plot_hemisphere(fig.add_subplot(grid[2, 2]), params, theta_i, "dop", wavelengths[0],
                        resolution, phi_i + 90.0)
        note = fig.add_subplot(grid[2, 0])
        note.axis("off")
        note.text(0.02, 0.5, "Anisotropic surface: the maps on the right turn\nthe light by "
                  "90° about the normal.\nArrows: the surface's s axis (dp_du),\nalong which "
                  "the RMS slope is sigma_u.", fontsize=10, va="center")
    if title is None:
        title = (f"pBRDF: {params.label()}; θi = {theta_i:g}°"
                 + (f", φi = {phi_i:g}°" if phi_i else "") + " "
                 "(NumPy float64 reference evaluator)")
    fig.suptitle(title, fontsize=11)
    return fig


def save_pbrdf_plot(path, params: PBRDFParams, theta_i: float,
                    wavelengths: Sequence[float] = DEFAULT_WAVELENGTHS,
                    title: Optional[str] = None, dpi: int = 110,
                    colors: Optional[int] = None, phi_i: float = 0.0) -> str:
    """Write :func:`pbrdf_figure` as a PNG; returns the path. *colors* as for
    :func:`mitsuba_pbrdf.visualization.panels.save_png`."""
    from .panels import save_png

    fig = pbrdf_figure(params, theta_i, wavelengths, title, phi_i=phi_i)
    return save_png(fig, os.fspath(path), dpi=dpi, colors=colors)


