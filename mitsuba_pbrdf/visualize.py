"""Pictures of Stokes images (matplotlib, Agg; no display needed).

:func:`save_overview_png` writes one PNG with a row of panels, by default the
tone-mapped intensity and the degree of linear polarization. Each panel is drawn
by a ``plot_*(ax, image)`` function, so new pictures can combine them freely::

    from matplotlib.figure import Figure
    fig = Figure(figsize=(8, 3))
    ax1, ax2 = fig.subplots(1, 2)
    plot_aolp(ax1, image); plot_stokes_component(ax2, image, 1)
    fig.savefig("aolp_s1.png", dpi=150)

Polarization panels use the luminance Stokes vector of each pixel
(:func:`mitsuba_pbrdf.stokes_io.luminance_stokes`): what a panchromatic
polarimeter would measure.
"""

from __future__ import annotations

import os
from typing import Optional, Sequence

import numpy as np

from .stokes_io import StokesImage, aolp, dolp, docp, luminance_stokes

__all__ = [
    "tonemap",
    "plot_intensity",
    "plot_dolp",
    "plot_aolp",
    "plot_docp",
    "plot_stokes_component",
    "PANELS",
    "overview_figure",
    "save_overview_png",
]


def _srgb_encode(linear: np.ndarray) -> np.ndarray:
    linear = np.clip(linear, 0.0, 1.0)
    return np.where(
        linear <= 0.0031308, 12.92 * linear, 1.055 * np.power(linear, 1.0 / 2.4) - 0.055
    )


def _linear_rgb(image: StokesImage) -> np.ndarray:
    if image.rgb is not None:
        return image.rgb
    s0 = image.s0
    if all(b in image.bands for b in "RGB"):
        return np.stack([s0[:, :, image.bands.index(b)] for b in "RGB"], axis=-1)
    return np.repeat(s0.mean(axis=-1, keepdims=True), 3, axis=-1)


def tonemap(rgb: np.ndarray, exposure: Optional[float] = None, percentile: float = 99.0):
    """Linear RGB (H, W, 3) to sRGB-encoded floats in [0, 1].

    With ``exposure=None`` the scale is chosen so that the *percentile*-th
    percentile of the luminance of the non-black pixels maps to 1 (brighter
    pixels, e.g. the highlight core, clip). Returns ``(srgb, exposure)``.
    """
    rgb = np.nan_to_num(np.asarray(rgb, dtype=np.float32), nan=0.0, posinf=0.0, neginf=0.0)
    if exposure is None:
        lum = rgb @ np.array([0.2126, 0.7152, 0.0722], dtype=np.float32)
        lit = lum[lum > 0]
        ref = float(np.percentile(lit, percentile)) if lit.size else 0.0
        exposure = 1.0 / ref if ref > 0 else 1.0
    return _srgb_encode(rgb * exposure), float(exposure)


def _clean(ax, title):
    ax.set_title(title, fontsize=9)
    ax.set_xticks([])
    ax.set_yticks([])


def _colorbar(ax, mappable, label, ticks=None, ticklabels=None):
    cb = ax.figure.colorbar(mappable, ax=ax, fraction=0.046, pad=0.03, ticks=ticks)
    cb.set_label(label, fontsize=8)
    if ticklabels is not None:
        cb.ax.set_yticklabels(ticklabels)
    cb.ax.tick_params(labelsize=7)
    return cb


def plot_intensity(
    ax, image: StokesImage, exposure: Optional[float] = None, percentile: float = 99.0
):
    """Tone-mapped intensity (S0 / the film's RGB preview), sRGB."""
    srgb, exposure = tonemap(_linear_rgb(image), exposure, percentile)
    ax.imshow(srgb, interpolation="nearest")
    _clean(ax, f"Intensity S0 (sRGB, exposure {np.log2(exposure):+.1f} EV)")
    return ax


def plot_dolp(ax, image: StokesImage, cmap: str = "viridis"):
    """Degree of linear polarization, 0..1."""
    im = ax.imshow(
        np.clip(dolp(luminance_stokes(image), axis=-1), 0.0, 1.0),
        cmap=cmap, vmin=0.0, vmax=1.0, interpolation="nearest",
    )
    _clean(ax, "Degree of linear polarization")
    _colorbar(ax, im, "DoLP")
    return ax


def plot_docp(ax, image: StokesImage, cmap: str = "viridis", vmax: float = 1.0):
    """Degree of circular polarization |S3|/S0."""
    im = ax.imshow(
        np.clip(docp(luminance_stokes(image), axis=-1), 0.0, vmax),
        cmap=cmap, vmin=0.0, vmax=vmax, interpolation="nearest",
    )
    _clean(ax, "Degree of circular polarization")
    _colorbar(ax, im, "DoCP")
    return ax


def plot_aolp(ax, image: StokesImage, cmap: str = "twilight", min_dolp: float = 0.01):
    """Angle of linear polarization (cyclic colour map), masked (black) where
    DoLP < *min_dolp* since the angle is noise there."""
    s = luminance_stokes(image)
    angle = np.degrees(aolp(s, axis=-1))
    angle = np.ma.masked_where(dolp(s, axis=-1) < min_dolp, angle)
    import matplotlib

    cm = matplotlib.colormaps[cmap].with_extremes(bad="black")
    im = ax.imshow(angle, cmap=cm, vmin=-90.0, vmax=90.0, interpolation="nearest")
    _clean(ax, "Angle of linear polarization")
    _colorbar(ax, im, "AoLP (degrees)", ticks=[-90, -45, 0, 45, 90])
    return ax


def plot_stokes_component(
    ax, image: StokesImage, i: int, cmap: str = "RdBu_r", percentile: float = 99.0
):
    """S_i / S0 for i in 1..3 (diverging colour map, symmetric limits set by a
    high percentile of |S_i / S0|, at most 1)."""
    if i not in (1, 2, 3):
        raise ValueError(f"Stokes component must be 1, 2 or 3, got {i}")
    s = luminance_stokes(image)
    s0 = s[..., 0]
    ratio = np.zeros_like(s0)
    np.divide(s[..., i], s0, out=ratio, where=s0 > 1e-8)
    lim = float(np.percentile(np.abs(ratio), percentile)) if ratio.size else 1.0
    lim = min(max(lim, 1e-3), 1.0)
    im = ax.imshow(ratio, cmap=cmap, vmin=-lim, vmax=lim, interpolation="nearest")
    _clean(ax, f"Normalized Stokes S{i}/S0")
    _colorbar(ax, im, f"S{i}/S0")
    return ax


#: Panel names accepted by :func:`save_overview_png`.
PANELS = {
    "intensity": plot_intensity,
    "dolp": plot_dolp,
    "aolp": plot_aolp,
    "docp": plot_docp,
    "s1": lambda ax, image: plot_stokes_component(ax, image, 1),
    "s2": lambda ax, image: plot_stokes_component(ax, image, 2),
    "s3": lambda ax, image: plot_stokes_component(ax, image, 3),
}


def overview_figure(
    image: StokesImage,
    panels: Sequence[str] = ("intensity", "dolp"),
    title: Optional[str] = None,
    panel_width: float = 4.0,
):
    """A matplotlib Figure (not attached to pyplot) with one panel per name."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    unknown = [p for p in panels if p not in PANELS]
    if unknown or not panels:
        raise ValueError(f"unknown panel(s) {unknown}; choose from {sorted(PANELS)}")
    aspect = image.height / image.width
    colorbar_width = 0.8  # inches taken by a panel's colour bar and its labels
    fig = Figure(
        figsize=((panel_width + colorbar_width) * len(panels), panel_width * aspect + 0.8),
        layout="constrained",
    )
    FigureCanvasAgg(fig)  # render with Agg, whatever pyplot's backend is
    axes = fig.subplots(1, len(panels), squeeze=False)[0]
    for ax, name in zip(axes, panels):
        PANELS[name](ax, image)
    if title:
        fig.suptitle(title, fontsize=10)
    return fig


def save_overview_png(
    path,
    image: StokesImage,
    panels: Sequence[str] = ("intensity", "dolp"),
    title: Optional[str] = None,
    dpi: int = 150,
) -> str:
    """Write the overview PNG (by default intensity and DoLP side by side).

    *title* defaults to the image's ``metadata["title"]`` if it has one.
    Returns the path.
    """
    path = os.fspath(path)
    if title is None:
        title = image.metadata.get("title")
    fig = overview_figure(image, panels, title)
    parent = os.path.dirname(path)
    if parent:
        os.makedirs(parent, exist_ok=True)
    fig.savefig(path, dpi=dpi, format="png")
    return path
