"""Pictures of Stokes images (matplotlib, Agg; no display needed).

:func:`save_overview_png` writes one PNG with a grid of labelled panels, each
with its colour bar: by default the tone-mapped intensity and the degree of
linear polarization; ``panels="all"`` gives the full Stokes sheet (intensity,
DoLP, AoLP, DoCP, the HSV polarization composite and S1, S2, S3 normalized by
S0). Each panel is drawn by a ``draw_*(ax, image, ...)`` function (the picture
alone; it returns a :class:`Drawing` with what its colour bar needs) and
titled, with its colour bar, by a ``plot_*(ax, image, ...)`` function, so new
pictures can combine them freely (the gallery's montages share one colour bar
per row)::

    from matplotlib.figure import Figure
    fig = Figure(figsize=(8, 3))
    ax1, ax2 = fig.subplots(1, 2)
    plot_aolp(ax1, image); plot_stokes_component(ax2, image, 1)
    fig.savefig("aolp_s1.png", dpi=150)

Polarization panels use the luminance Stokes vector of each pixel
(:func:`mitsuba_pbrdf.stokes.image.luminance_stokes`, what a panchromatic
polarimeter would measure), or one band's Stokes vector with ``band="R"`` (or
``"Y"``, or a wavelength band's name).

Angles follow the Stokes frame of Mitsuba's ``stokes`` integrator: x-axis =
cross(ray direction, camera up), i.e. image right, y-axis image up; AoLP = 0 is
horizontal and positive angles turn counter-clockwise in the picture.

Colours and scales (:mod:`mitsuba_pbrdf.visualization.colours`): AoLP on the hue
wheel polarization cameras use (grey where DoLP is too low), DoLP and DoCP
from 0 to a stated maximum (``"auto"`` by default: scaled to the data), S1,
S2, S3 / S0 on one symmetric scale in the sheet; each colour bar states its
scale. Unusable pixels (non-finite, S0 < 0, polarization > 1:
:mod:`mitsuba_pbrdf.stokes.quality`) are painted in a marker colour named in
the panel's legend, never drawn as if they were data.
"""

from __future__ import annotations

import inspect
from dataclasses import dataclass, field
from typing import Optional, Sequence, Union

import numpy as np

from .defaults import PICTURE_DEFAULTS
from .colours import (MARKERS, MASKED_GREY, aolp_colormap, aolp_rgb, colour_image,
                      paint, resolve_limit)
from ..stokes.quality import StokesQuality, assess
from .png import save_png
from ..stokes.image import StokesImage, aolp, docp, dolp
from .composites import polarization_hsv, stokes_limit, stokes_ratios
from .tonemap import _LUMA, auto_exposure, linear_rgb, pixel_stokes, tonemap

__all__ = [
    "auto_exposure",
    "tonemap",
    "linear_rgb",
    "pixel_stokes",
    "Drawing",
    "DRAWERS",
    "draw_intensity",
    "draw_dolp",
    "draw_aolp",
    "draw_docp",
    "draw_polarization_hsv",
    "draw_stokes_component",
    "plot_intensity",
    "plot_dolp",
    "plot_aolp",
    "plot_docp",
    "plot_polarization_hsv",
    "plot_stokes_component",
    "polarization_hsv",
    "stokes_ratios",
    "stokes_limit",
    "PANELS",
    "PANEL_PRESETS",
    "PICTURE_DEFAULTS",
    "parse_panels",
    "overview_figure",
    "save_overview_png",
    "save_png",
]

def _clean(ax, title):
    ax.set_title(title, fontsize=9)
    ax.set_xticks([])
    ax.set_yticks([])


def _band_suffix(band):
    return "" if band is None else f" [{band}]"


@dataclass
class Drawing:
    """What a ``draw_*`` function put on its axes: the ``mappable`` its colour
    bar shows (None for the intensity), the bar's ``label``, ``ticks`` and
    ``extend`` (``"neither"``, ``"max"``, ``"both"``: values beyond the scale
    were clipped), a ``title`` for the panel (``short`` for a row label), the
    ``values`` drawn (NaN where nothing is), and the ``legend`` entries
    ``(colour, label)`` of marked pixels."""

    mappable: object
    label: str
    ticks: Optional[list]
    title: str
    short: str
    values: Optional[np.ndarray] = None
    extend: str = "neither"
    legend: list = field(default_factory=list)


def _quality(image: StokesImage, band, quality):
    return assess(image, band) if quality is None else quality


def _show(ax, rgb, panel: str, quality: StokesQuality) -> list:
    """Paint the unusable pixels in the panel's marker colour, draw *rgb*,
    and return the legend entries."""
    colour, name = MARKERS[panel]
    paint(rgb, quality.unusable, colour)
    ax.imshow(np.clip(rgb, 0.0, 1.0), interpolation="nearest")
    n = quality.count
    return [(colour, f"{name}: {n} unusable pixel{'s' if n != 1 else ''}")] if n else []


def _mappable(cmap, vmin, vmax):
    import matplotlib
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    cmap = matplotlib.colormaps[cmap] if isinstance(cmap, str) else cmap
    return ScalarMappable(Normalize(vmin, vmax), cmap)


def _extend(values, vmin, vmax, low=True):
    finite = values[np.isfinite(values)]
    over = bool(finite.size and finite.max() > vmax * (1 + 1e-6))
    under = low and bool(finite.size and finite.min() < vmin * (1 + 1e-6) - 1e-12)
    return {(False, False): "neither", (False, True): "max", (True, False): "min",
            (True, True): "both"}[(under, over)]


def _usable_values(values, quality, s0=None):
    """*values* where the pixel is usable (and lit, if *s0* is given), else NaN."""
    ok = ~quality.unusable
    if s0 is not None:
        ok &= s0 > 0
    return np.where(ok, values, np.nan)


def draw_intensity(ax, image: StokesImage, exposure: Optional[float] = None,
                   percentile: float = 99.0, band: Optional[str] = None,
                   quality: Optional[StokesQuality] = None) -> Drawing:
    """Tone-mapped intensity (the film's RGB preview, or S0 of *band* in grey),
    sRGB. *exposure* is a linear scale (``None``: automatic, see :func:`tonemap`)."""
    quality = _quality(image, band, quality)
    rgb = linear_rgb(image, band)
    if exposure is None:
        exposure = auto_exposure(np.where(quality.unusable[..., None], 0.0, rgb), percentile)
    srgb, exposure = tonemap(rgb, exposure, percentile)
    legend = _show(ax, srgb, "intensity", quality)
    ev = f"{np.log2(exposure):+.1f} EV"
    return Drawing(None, "", None, f"Intensity S0{_band_suffix(band)} (sRGB, {ev})",
                   f"intensity ({ev})", values=linear_rgb(image, band) @ _LUMA, legend=legend)


def _degree_panel(ax, image, band, quality, values, cmap, top, panel, label, title, short):
    quality = _quality(image, band, quality)
    s0 = pixel_stokes(image, band)[..., 0]
    shown = _usable_values(values, quality, s0)
    vmax, automatic = resolve_limit(top, shown)
    rgb = colour_image(np.nan_to_num(shown, nan=0.0), cmap, 0.0, vmax)
    legend = _show(ax, rgb, panel, quality)
    scale = f"0–{vmax:g}" + (", auto" if automatic else "")
    return Drawing(_mappable(cmap, 0.0, vmax), f"{label} ({scale})", None,
                   title + _band_suffix(band), short, values=shown,
                   extend=_extend(shown, 0.0, vmax, low=False), legend=legend)


def draw_dolp(ax, image: StokesImage, dolp_cmap: str = "viridis",
              dolp_limit: Union[float, str] = 1.0, band: Optional[str] = None,
              quality: Optional[StokesQuality] = None) -> Drawing:
    """Degree of linear polarization sqrt(S1² + S2²)/S0, from 0 to *dolp_limit*
    (a number, default 1, or ``"auto"``: the data's 99.5th percentile rounded
    up, what the command line uses; see :mod:`~mitsuba_pbrdf.visualization.colours`),
    ``viridis`` or ``gray``."""
    with np.errstate(invalid="ignore"):
        values = dolp(pixel_stokes(image, band), axis=-1)
    return _degree_panel(ax, image, band, quality, values, dolp_cmap, dolp_limit, "dolp", "DoLP",
                         "Degree of linear polarization", "DoLP")


def draw_docp(ax, image: StokesImage, cmap: str = "viridis",
              docp_max: Union[float, str] = "auto", band: Optional[str] = None,
              quality: Optional[StokesQuality] = None) -> Drawing:
    """Degree of circular polarization |S3|/S0, from 0 to *docp_max* (a
    number, or ``"auto"``: scaled to the data, so the small DoCP of metals shows)."""
    with np.errstate(invalid="ignore"):
        values = docp(pixel_stokes(image, band), axis=-1)
    return _degree_panel(ax, image, band, quality, values, cmap, docp_max, "docp", "DoCP",
                         "Degree of circular polarization", "DoCP")


def draw_aolp(ax, image: StokesImage, min_dolp: float = 0.01, band: Optional[str] = None,
              quality: Optional[StokesQuality] = None) -> Drawing:
    """Angle of linear polarization 0.5·atan2(S2, S1) in degrees on the AoLP
    hue wheel (:func:`~mitsuba_pbrdf.visualization.colours.aolp_rgb`: −90° and +90°
    share a colour, no angle is dark), neutral grey where DoLP < *min_dolp*
    since the angle is noise there."""
    quality = _quality(image, band, quality)
    s = pixel_stokes(image, band)
    with np.errstate(invalid="ignore"):
        angle = np.degrees(aolp(s, axis=-1))
        weak = dolp(s, axis=-1) < min_dolp
    shown = np.where(weak | quality.unusable, np.nan, angle)
    rgb = aolp_rgb(np.nan_to_num(angle))
    paint(rgb, weak, MASKED_GREY)
    legend = [(MASKED_GREY, f"grey: DoLP < {min_dolp:g}")] + _show(ax, rgb, "aolp", quality)
    return Drawing(_mappable(aolp_colormap(), -90.0, 90.0), "AoLP (degrees)",
                   [-90, -45, 0, 45, 90],
                   f"Angle of linear polarization (DoLP ≥ {min_dolp:g})" + _band_suffix(band),
                   f"AoLP (DoLP ≥ {min_dolp:g})", values=shown, legend=legend)


def draw_polarization_hsv(ax, image: StokesImage, dolp_limit: Union[float, str] = 1.0,
                          exposure: Optional[float] = None, band: Optional[str] = None,
                          quality: Optional[StokesQuality] = None) -> Drawing:
    """:func:`polarization_hsv`: colour = AoLP, saturation = DoLP, brightness =
    intensity; the colour bar is the hue scale of AoLP."""
    quality = _quality(image, band, quality)
    s = pixel_stokes(image, band)
    with np.errstate(invalid="ignore"):
        d = np.where(~quality.unusable & (s[..., 0] > 0), dolp(s, axis=-1), np.nan)
    top, automatic = resolve_limit(dolp_limit, d)
    rgb = polarization_hsv(image, top, exposure, band=band)
    legend = _show(ax, rgb, "hsv", quality)
    scale = f"0–{top:g}" + (", auto" if automatic else "")
    return Drawing(_mappable(aolp_colormap(), -90.0, 90.0), "AoLP (degrees)",
                   [-90, -45, 0, 45, 90],
                   f"AoLP (hue) · DoLP (saturation, {scale}) · S0" + _band_suffix(band),
                   "AoLP·DoLP·S0", legend=legend)


def draw_stokes_component(ax, image: StokesImage, i: int, cmap: str = "RdBu_r",
                          percentile: float = 99.0, band: Optional[str] = None,
                          limit: Union[float, str, None] = None,
                          quality: Optional[StokesQuality] = None) -> Drawing:
    """S_i / S0 for i in 1..3, diverging colour map centred on 0 (red positive,
    blue negative), symmetric limits ±*limit*; None or ``"auto"``: this
    component's own scale (:func:`stokes_limit`; the sheet passes one limit
    shared by S1, S2, S3)."""
    if i not in (1, 2, 3):
        raise ValueError(f"Stokes component must be 1, 2 or 3, got {i}")
    quality = _quality(image, band, quality)
    ratio = stokes_ratios(image, band, quality)[..., i - 1]
    if limit is None or isinstance(limit, str):
        lim, scale = stokes_limit(image, (i,), percentile, band, quality), "own scale"
    else:
        lim, scale = float(limit), "shared scale"
    rgb = colour_image(np.nan_to_num(ratio, nan=0.0), cmap, -lim, lim)
    legend = _show(ax, rgb, "stokes", quality)
    meaning = {1: "horizontal (+) / vertical (−)", 2: "+45° (+) / −45° (−)",
               3: "circular handedness"}[i]
    return Drawing(_mappable(cmap, -lim, lim), f"S{i}/S0 (±{lim:g}, {scale})", None,
                   f"S{i}/S0: {meaning}" + _band_suffix(band), f"S{i}/S0", values=ratio,
                   extend=_extend(ratio, -lim, lim), legend=legend)


def _legend(ax, entries):
    if not entries:
        return
    from matplotlib.patches import Patch

    ax.legend(handles=[Patch(facecolor=c, edgecolor="0.4", label=t) for c, t in entries],
              loc="upper center", bbox_to_anchor=(0.5, 0.0), fontsize=6, frameon=False,
              ncol=len(entries), handlelength=1.0, borderaxespad=0.2, columnspacing=1.0)


def _finish(ax, drawing: Drawing, title: Optional[str] = None):
    """Title the panel, give it its colour bar and its legend."""
    _clean(ax, drawing.title if title is None else title)
    if drawing.mappable is not None:
        cb = ax.figure.colorbar(drawing.mappable, ax=ax, fraction=0.046, pad=0.03,
                                ticks=drawing.ticks, extend=drawing.extend)
        cb.set_label(drawing.label, fontsize=8)
        cb.ax.tick_params(labelsize=7)
    _legend(ax, drawing.legend)
    return ax


def plot_intensity(ax, image: StokesImage, exposure: Optional[float] = None,
                   percentile: float = 99.0, band: Optional[str] = None,
                   title: Optional[str] = None, quality: Optional[StokesQuality] = None):
    """:func:`draw_intensity` with its title (the exposure in EV)."""
    return _finish(ax, draw_intensity(ax, image, exposure, percentile, band, quality), title)


def plot_dolp(ax, image: StokesImage, dolp_cmap: str = "viridis",
              dolp_limit: Union[float, str] = 1.0, band: Optional[str] = None,
              quality: Optional[StokesQuality] = None):
    """:func:`draw_dolp` with its title and colour bar."""
    return _finish(ax, draw_dolp(ax, image, dolp_cmap, dolp_limit, band, quality))


def plot_docp(ax, image: StokesImage, cmap: str = "viridis",
              docp_max: Union[float, str] = "auto", band: Optional[str] = None,
              quality: Optional[StokesQuality] = None):
    """:func:`draw_docp` with its title and colour bar."""
    return _finish(ax, draw_docp(ax, image, cmap, docp_max, band, quality))


def plot_aolp(ax, image: StokesImage, min_dolp: float = 0.01, band: Optional[str] = None,
              quality: Optional[StokesQuality] = None):
    """:func:`draw_aolp` with its title and colour bar."""
    return _finish(ax, draw_aolp(ax, image, min_dolp, band, quality))


def plot_polarization_hsv(ax, image: StokesImage, dolp_limit: Union[float, str] = 1.0,
                          exposure: Optional[float] = None, band: Optional[str] = None,
                          quality: Optional[StokesQuality] = None):
    """:func:`draw_polarization_hsv` with its title and colour bar."""
    return _finish(ax, draw_polarization_hsv(ax, image, dolp_limit, exposure, band, quality))


def plot_stokes_component(ax, image: StokesImage, i: int, cmap: str = "RdBu_r",
                          percentile: float = 99.0, band: Optional[str] = None,
                          limit: Union[float, str, None] = None,
                          quality: Optional[StokesQuality] = None):
    """:func:`draw_stokes_component` with its title and colour bar."""
    return _finish(ax, draw_stokes_component(ax, image, i, cmap, percentile, band, limit,
                                             quality))


def _plot_s(i):
    def plot(ax, image, band=None, stokes_limit=None, quality=None):
        return plot_stokes_component(ax, image, i, band=band, limit=stokes_limit,
                                     quality=quality)
    return plot


def _draw_s(i):
    def draw(ax, image, band=None, stokes_limit=None, quality=None):
        return draw_stokes_component(ax, image, i, band=band, limit=stokes_limit,
                                     quality=quality)
    return draw


#: Drawing functions by panel name (what a montage row draws).
DRAWERS = {
    "intensity": draw_intensity,
    "dolp": draw_dolp,
    "aolp": draw_aolp,
    "docp": draw_docp,
    "hsv": draw_polarization_hsv,
    "s1": _draw_s(1),
    "s2": _draw_s(2),
    "s3": _draw_s(3),
}


#: Panel names accepted by :func:`overview_figure` and ``--panels``.
PANELS = {
    "intensity": plot_intensity,
    "dolp": plot_dolp,
    "aolp": plot_aolp,
    "docp": plot_docp,
    "hsv": plot_polarization_hsv,
    "s1": _plot_s(1),
    "s2": _plot_s(2),
    "s3": _plot_s(3),
}

#: Named panel sets: ``all`` is the full Stokes sheet (2 rows of 4).
PANEL_PRESETS = {
    "all": ("intensity", "dolp", "aolp", "docp", "hsv", "s1", "s2", "s3"),
    "default": ("intensity", "dolp"),
}


def parse_panels(panels: Union[str, Sequence[str]]) -> tuple:
    """Panel names from a comma-separated string or a sequence; presets
    (``all``, ``default``) expand. Raises ``ValueError`` naming unknown panels."""
    if isinstance(panels, str):
        panels = [p.strip().lower() for p in panels.split(",") if p.strip()]
    names = []
    for p in panels:
        names.extend(PANEL_PRESETS.get(p, (p,)))
    unknown = [p for p in names if p not in PANELS]
    if unknown or not names:
        raise ValueError(
            f"unknown panel(s) {', '.join(unknown) or '(none)'}; choose from "
            f"{', '.join(PANELS)} or {', '.join(PANEL_PRESETS)}"
        )
    return tuple(names)


def _call_panel(name, ax, image, options):
    function = PANELS[name]
    accepted = inspect.signature(function).parameters
    function(ax, image, **{k: v for k, v in options.items() if k in accepted})


def overview_figure(
    image: StokesImage,
    panels: Union[str, Sequence[str]] = ("intensity", "dolp"),
    title: Optional[str] = None,
    panel_width: float = 4.0,
    ncols: Optional[int] = None,
    **options,
):
    """A matplotlib Figure (not attached to pyplot, drawn with Agg) with one
    panel per name, *ncols* to a row (default: all in one row up to 4, else 4).

    *options* go to the panel functions that take them (defaults:
    :data:`PICTURE_DEFAULTS`, those of ``pbrdf render`` and ``view``): ``band``,
    ``exposure``, ``dolp_cmap``, ``dolp_limit``, ``docp_max``, ``min_dolp``,
    ``quality`` (:func:`~mitsuba_pbrdf.stokes.quality.assess`, computed once
    if not given). S1, S2, S3 / S0 share one scale (:func:`stokes_limit`)
    unless ``stokes_scale="separate"``, or ``stokes_limit=X`` fixes it.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    panels = parse_panels(panels)
    options = {**PICTURE_DEFAULTS, **options}
    band = options.get("band")
    if band is not None:
        image.band(band)  # KeyError naming the bands, before drawing anything
    if options.get("quality") is None:
        options["quality"] = assess(image, band)
    scale = options.pop("stokes_scale")
    if scale not in ("shared", "separate"):
        raise ValueError(f"stokes_scale must be 'shared' or 'separate', got {scale!r}")
    components = [int(p[1]) for p in panels if p in ("s1", "s2", "s3")]
    if options.get("stokes_limit") is None and scale == "shared" and components:
        options["stokes_limit"] = stokes_limit(image, components, band=band,
                                               quality=options["quality"])
    if ncols is None:
        ncols = min(len(panels), 4)
    nrows = -(-len(panels) // ncols)
    aspect = image.height / image.width
    colorbar_width = 0.8  # inches taken by a panel's colour bar and its labels
    fig = Figure(
        figsize=((panel_width + colorbar_width) * ncols,
                 (panel_width * aspect + 0.45) * nrows + (0.35 if title else 0.0)),
        layout="constrained",
    )
    FigureCanvasAgg(fig)  # render with Agg, whatever pyplot's backend is
    axes = fig.subplots(nrows, ncols, squeeze=False).ravel()
    for ax, name in zip(axes, panels):
        _call_panel(name, ax, image, options)
    for ax in axes[len(panels):]:
        ax.set_visible(False)
    if title:
        fig.suptitle(title, fontsize=10)
    return fig


def save_overview_png(
    path,
    image: StokesImage,
    panels: Union[str, Sequence[str]] = ("intensity", "dolp"),
    title: Optional[str] = None,
    dpi: int = 150,
    **options,
) -> str:
    """Write the overview PNG (by default intensity and DoLP side by side;
    ``panels="all"`` for the full Stokes sheet). *title* defaults to the
    image's ``metadata["title"]`` if it has one; *options* as for
    :func:`overview_figure`. Returns the path."""
    if title is None:
        title = image.metadata.get("title")
    fig = overview_figure(image, panels, title, **options)
    return save_png(fig, path, dpi=dpi)
