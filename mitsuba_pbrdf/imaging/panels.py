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
(:func:`mitsuba_pbrdf.imaging.stokes.luminance_stokes`, what a panchromatic
polarimeter would measure), or one band's Stokes vector with ``band="R"`` (or
``"Y"``, or a wavelength band's name).

Angles follow the Stokes frame of Mitsuba's ``stokes`` integrator: x-axis =
cross(ray direction, camera up), i.e. image right, y-axis image up; AoLP = 0 is
horizontal and positive angles turn counter-clockwise in the picture.
"""

from __future__ import annotations

import inspect
import os
from dataclasses import dataclass
from typing import Optional, Sequence, Union

import numpy as np

from .stokes import StokesImage, aolp, docp, dolp, luminance_stokes

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
    "PANELS",
    "PANEL_PRESETS",
    "parse_panels",
    "overview_figure",
    "save_overview_png",
    "save_png",
]

#: Rec. 709 luminance weights of linear R, G, B.
_LUMA = np.array([0.2126, 0.7152, 0.0722], dtype=np.float32)


def _srgb_encode(linear: np.ndarray) -> np.ndarray:
    linear = np.clip(linear, 0.0, 1.0)
    return np.where(
        linear <= 0.0031308, 12.92 * linear, 1.055 * np.power(linear, 1.0 / 2.4) - 0.055
    )


def linear_rgb(image: StokesImage, band: Optional[str] = None) -> np.ndarray:
    """Linear RGB (H, W, 3) of the image: its preview, the RGB bands of S0,
    the mean of its bands, or S0 of *band* in grey."""
    if band is not None:
        return np.repeat(image.band(band)[:, :, :1], 3, axis=-1)
    if image.rgb is not None:
        return image.rgb
    s0 = image.s0
    if all(b in image.bands for b in "RGB"):
        return np.stack([s0[:, :, image.bands.index(b)] for b in "RGB"], axis=-1)
    return np.repeat(s0.mean(axis=-1, keepdims=True), 3, axis=-1)


def auto_exposure(rgb: np.ndarray, percentile: float = 99.0) -> float:
    """The scale that maps the *percentile*-th percentile of the luminance of
    the non-black pixels of linear *rgb* (H, W, 3) to 1 (1.0 for a black image)."""
    rgb = np.nan_to_num(np.asarray(rgb, dtype=np.float32), nan=0.0, posinf=0.0, neginf=0.0)
    lum = rgb @ _LUMA
    lit = lum[lum > 0]
    ref = float(np.percentile(lit, percentile)) if lit.size else 0.0
    return 1.0 / ref if ref > 0 else 1.0


def tonemap(rgb: np.ndarray, exposure: Optional[float] = None, percentile: float = 99.0):
    """Linear RGB (H, W, 3) to sRGB-encoded floats in [0, 1].

    With ``exposure=None`` the scale is chosen by :func:`auto_exposure` (the
    *percentile*-th percentile of the luminance of the non-black pixels maps to
    1; brighter pixels, e.g. the highlight core, clip). Pass the same
    *exposure* to compare pictures. Returns ``(srgb, exposure)``.
    """
    rgb = np.nan_to_num(np.asarray(rgb, dtype=np.float32), nan=0.0, posinf=0.0, neginf=0.0)
    if exposure is None:
        exposure = auto_exposure(rgb, percentile)
    return _srgb_encode(rgb * exposure), float(exposure)


def pixel_stokes(image: StokesImage, band: Optional[str] = None) -> np.ndarray:
    """One Stokes vector per pixel, shape (H, W, 4): the luminance combination
    of the bands (:func:`~mitsuba_pbrdf.imaging.stokes.luminance_stokes`), or the
    band named *band*."""
    return luminance_stokes(image) if band is None else image.band(band)


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


def _band_suffix(band):
    return "" if band is None else f" [{band}]"


@dataclass
class Drawing:
    """What a ``draw_*`` function put on its axes: the ``mappable`` its colour
    bar shows (None for the intensity), the bar's ``label`` and ``ticks``,
    and a ``title`` for the panel (``short`` for a row label)."""

    mappable: object
    label: str
    ticks: Optional[list]
    title: str
    short: str


def draw_intensity(ax, image: StokesImage, exposure: Optional[float] = None,
                   percentile: float = 99.0, band: Optional[str] = None) -> Drawing:
    """Tone-mapped intensity (the film's RGB preview, or S0 of *band* in grey),
    sRGB. *exposure* is a linear scale (``None``: automatic, see :func:`tonemap`)."""
    srgb, exposure = tonemap(linear_rgb(image, band), exposure, percentile)
    ax.imshow(srgb, interpolation="nearest")
    ev = f"{np.log2(exposure):+.1f} EV"
    return Drawing(None, "", None, f"Intensity S0{_band_suffix(band)} (sRGB, {ev})",
                   f"intensity ({ev})")


def draw_dolp(ax, image: StokesImage, dolp_cmap: str = "viridis", dolp_max: float = 1.0,
              band: Optional[str] = None) -> Drawing:
    """Degree of linear polarization sqrt(S1² + S2²)/S0, from 0 to *dolp_max*
    (``viridis``, or ``gray`` for greyscale)."""
    im = ax.imshow(np.clip(dolp(pixel_stokes(image, band), axis=-1), 0.0, dolp_max),
                   cmap=dolp_cmap, vmin=0.0, vmax=dolp_max, interpolation="nearest")
    return Drawing(im, "DoLP", None, "Degree of linear polarization" + _band_suffix(band), "DoLP")


def draw_docp(ax, image: StokesImage, cmap: str = "viridis", docp_max: float = 1.0,
              band: Optional[str] = None) -> Drawing:
    """Degree of circular polarization |S3|/S0, from 0 to *docp_max*."""
    im = ax.imshow(np.clip(docp(pixel_stokes(image, band), axis=-1), 0.0, docp_max),
                   cmap=cmap, vmin=0.0, vmax=docp_max, interpolation="nearest")
    return Drawing(im, "DoCP", None, "Degree of circular polarization" + _band_suffix(band),
                   "DoCP")


def draw_aolp(ax, image: StokesImage, aolp_cmap: str = "twilight", min_dolp: float = 0.01,
              band: Optional[str] = None) -> Drawing:
    """Angle of linear polarization 0.5·atan2(S2, S1) in degrees, with a cyclic
    colour map (-90° and +90° get the same colour), black where
    DoLP < *min_dolp* since the angle is noise there."""
    import matplotlib

    s = pixel_stokes(image, band)
    angle = np.ma.masked_where(dolp(s, axis=-1) < min_dolp, np.degrees(aolp(s, axis=-1)))
    cm = matplotlib.colormaps[aolp_cmap].with_extremes(bad="black")
    im = ax.imshow(angle, cmap=cm, vmin=-90.0, vmax=90.0, interpolation="nearest")
    return Drawing(im, "AoLP (degrees)", [-90, -45, 0, 45, 90],
                   f"Angle of linear polarization (DoLP ≥ {min_dolp:g})" + _band_suffix(band),
                   f"AoLP (DoLP ≥ {min_dolp:g})")


def polarization_hsv(
    image: StokesImage,
    dolp_max: float = 1.0,
    exposure: Optional[float] = None,
    percentile: float = 99.0,
    band: Optional[str] = None,
) -> np.ndarray:
    """The usual polarization composite as RGB in [0, 1], shape (H, W, 3):
    hue = AoLP (a full turn of hue for 180°), saturation = DoLP / *dolp_max*,
    value = tone-mapped intensity (luminance)."""
    from matplotlib.colors import hsv_to_rgb

    s = pixel_stokes(image, band)
    hue = (np.degrees(aolp(s, axis=-1)) % 180.0) / 180.0
    saturation = np.clip(dolp(s, axis=-1) / dolp_max, 0.0, 1.0)
    srgb, _ = tonemap(linear_rgb(image, band), exposure, percentile)
    value = np.clip(srgb @ _LUMA, 0.0, 1.0)
    return hsv_to_rgb(np.stack([hue, saturation, value], axis=-1).astype(np.float32))


def draw_polarization_hsv(ax, image: StokesImage, dolp_max: float = 1.0,
                          exposure: Optional[float] = None,
                          band: Optional[str] = None) -> Drawing:
    """:func:`polarization_hsv`: colour = AoLP, saturation = DoLP, brightness =
    intensity; the colour bar is the hue scale of AoLP."""
    import matplotlib
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import ListedColormap, Normalize

    ax.imshow(polarization_hsv(image, dolp_max, exposure, band=band), interpolation="nearest")
    # hue = (AoLP mod 180°) / 180°: red at 0°, cyan at ±90°, continuous across ±90°
    hues = (np.linspace(-90.0, 90.0, 256) % 180.0) / 180.0
    sm = ScalarMappable(Normalize(-90.0, 90.0), ListedColormap(matplotlib.colormaps["hsv"](hues)))
    return Drawing(sm, "AoLP (degrees)", [-90, -45, 0, 45, 90],
                   f"AoLP (hue) · DoLP (saturation, 0–{dolp_max:g}) · S0" + _band_suffix(band),
                   "AoLP·DoLP·S0")


def draw_stokes_component(ax, image: StokesImage, i: int, cmap: str = "RdBu_r",
                          percentile: float = 99.0, band: Optional[str] = None) -> Drawing:
    """S_i / S0 for i in 1..3, diverging colour map centred on 0 (red positive,
    blue negative), symmetric limits set by the *percentile*-th percentile of
    |S_i / S0| (at most 1, at least 0.001)."""
    if i not in (1, 2, 3):
        raise ValueError(f"Stokes component must be 1, 2 or 3, got {i}")
    s = pixel_stokes(image, band)
    s0 = s[..., 0]
    ratio = np.zeros_like(s0)
    np.divide(s[..., i], s0, out=ratio, where=s0 > 1e-8)
    lim = float(np.percentile(np.abs(ratio), percentile)) if ratio.size else 1.0
    lim = min(max(lim, 1e-3), 1.0)
    im = ax.imshow(ratio, cmap=cmap, vmin=-lim, vmax=lim, interpolation="nearest")
    meaning = {1: "horizontal (+) / vertical (−)", 2: "+45° (+) / −45° (−)",
               3: "circular handedness"}[i]
    return Drawing(im, f"S{i}/S0", None, f"S{i}/S0: {meaning}" + _band_suffix(band), f"S{i}/S0")


def _finish(ax, drawing: Drawing, title: Optional[str] = None):
    """Title the panel and give it its colour bar."""
    _clean(ax, drawing.title if title is None else title)
    if drawing.mappable is not None:
        _colorbar(ax, drawing.mappable, drawing.label, ticks=drawing.ticks)
    return ax


def plot_intensity(ax, image: StokesImage, exposure: Optional[float] = None,
                   percentile: float = 99.0, band: Optional[str] = None,
                   title: Optional[str] = None):
    """:func:`draw_intensity` with its title (the exposure in EV)."""
    return _finish(ax, draw_intensity(ax, image, exposure, percentile, band), title)


def plot_dolp(ax, image: StokesImage, dolp_cmap: str = "viridis", dolp_max: float = 1.0,
              band: Optional[str] = None):
    """:func:`draw_dolp` with its title and colour bar."""
    return _finish(ax, draw_dolp(ax, image, dolp_cmap, dolp_max, band))


def plot_docp(ax, image: StokesImage, cmap: str = "viridis", docp_max: float = 1.0,
              band: Optional[str] = None):
    """:func:`draw_docp` with its title and colour bar."""
    return _finish(ax, draw_docp(ax, image, cmap, docp_max, band))


def plot_aolp(ax, image: StokesImage, aolp_cmap: str = "twilight", min_dolp: float = 0.01,
              band: Optional[str] = None):
    """:func:`draw_aolp` with its title and colour bar."""
    return _finish(ax, draw_aolp(ax, image, aolp_cmap, min_dolp, band))


def plot_polarization_hsv(ax, image: StokesImage, dolp_max: float = 1.0,
                          exposure: Optional[float] = None, band: Optional[str] = None):
    """:func:`draw_polarization_hsv` with its title and colour bar."""
    return _finish(ax, draw_polarization_hsv(ax, image, dolp_max, exposure, band))


def plot_stokes_component(ax, image: StokesImage, i: int, cmap: str = "RdBu_r",
                          percentile: float = 99.0, band: Optional[str] = None):
    """:func:`draw_stokes_component` with its title and colour bar."""
    return _finish(ax, draw_stokes_component(ax, image, i, cmap, percentile, band))


def _plot_s1(ax, image, band=None):
    return plot_stokes_component(ax, image, 1, band=band)


def _plot_s2(ax, image, band=None):
    return plot_stokes_component(ax, image, 2, band=band)


def _plot_s3(ax, image, band=None):
    return plot_stokes_component(ax, image, 3, band=band)


#: Drawing functions by panel name (what a montage row draws).
DRAWERS = {
    "intensity": draw_intensity,
    "dolp": draw_dolp,
    "aolp": draw_aolp,
    "docp": draw_docp,
    "hsv": draw_polarization_hsv,
    "s1": lambda ax, image, **o: draw_stokes_component(ax, image, 1, **o),
    "s2": lambda ax, image, **o: draw_stokes_component(ax, image, 2, **o),
    "s3": lambda ax, image, **o: draw_stokes_component(ax, image, 3, **o),
}


#: Panel names accepted by :func:`overview_figure` and ``--panels``.
PANELS = {
    "intensity": plot_intensity,
    "dolp": plot_dolp,
    "aolp": plot_aolp,
    "docp": plot_docp,
    "hsv": plot_polarization_hsv,
    "s1": _plot_s1,
    "s2": _plot_s2,
    "s3": _plot_s3,
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

    *options* go to the panel functions that take them: ``band``,
    ``exposure``, ``dolp_cmap``, ``dolp_max``, ``min_dolp``, ``aolp_cmap``, ...
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    panels = parse_panels(panels)
    if options.get("band") is not None:
        image.band(options["band"])  # KeyError naming the bands, before drawing anything
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


def save_png(fig, path, dpi: int = 150, colors: Optional[int] = None) -> str:
    """Save a matplotlib figure as PNG (creating the folder). With *colors*
    (e.g. 256) the PNG is palette-quantized with dithering: for pictures of
    noisy renders, committed to the repository, 2-3x smaller. Returns the path."""
    path = os.fspath(path)
    parent = os.path.dirname(path)
    if parent:
        os.makedirs(parent, exist_ok=True)
    if colors is None:
        fig.savefig(path, dpi=dpi, format="png")
        return path
    import io

    from PIL import Image

    buffer = io.BytesIO()
    fig.savefig(buffer, dpi=dpi, format="png")
    buffer.seek(0)
    with Image.open(buffer) as picture:
        rgb = picture.convert("RGB")
        palette = rgb.quantize(colors=colors, method=Image.Quantize.MAXCOVERAGE)
        # dithered against that palette, so smooth colour ramps do not band
        rgb.quantize(palette=palette, dither=Image.Dither.FLOYDSTEINBERG).save(
            path, format="PNG", optimize=True)
    return path


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
