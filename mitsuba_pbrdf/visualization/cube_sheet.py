"""Pictures of a Stokes cube (``pbrdf view --cube``): a contact sheet with
one row per band (S0, DoLP, AoLP) and, for a pixel or a region, the Stokes
spectrum: S0 (left axis, the cube's radiance units) and S1/S0, S2/S0, S3/S0
(right axis) against the band centres in nm, with the region's mean.

::

    region = parse_region("10,8")            # a pixel: x, y (from the top-left)
    region = parse_region("10,8,4,4")        # a region: x, y, width, height
    spectrum = stokes_spectrum(image, region)  # (n_bands, 4), the region's mean
    save_cube_sheet("sheet.png", image, region=region)   # one DoLP scale for all bands
    save_cube_sheet("sheet.png", image, dolp_scale="per-band")
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..errors import ParameterError
from ..stokes.image import StokesImage
from .defaults import PICTURE_DEFAULTS
from .png import save_png

__all__ = ["Region", "SHEET_OPTIONS", "DOLP_SCALES", "shared_dolp_limit", "parse_region",
           "region_spectrum", "stokes_spectrum", "band_centres",
           "cube_sheet_figure", "save_cube_sheet", "write_spectrum_csv"]


@dataclass(frozen=True)
class Region:
    """Pixels x..x+width-1, y..y+height-1 (x to the right, y down from the top-left)."""

    x: int
    y: int
    width: int = 1
    height: int = 1

    def describe(self) -> str:
        if self.width == self.height == 1:
            return f"pixel ({self.x}, {self.y})"
        return f"region {self.width}x{self.height} at ({self.x}, {self.y})"


def parse_region(text: str, image: Optional[StokesImage] = None) -> Region:
    """``X,Y`` or ``X,Y,W,H`` (pixels); :class:`ParameterError` naming
    ``spectrum`` if malformed or (with *image*) outside the image."""
    parts = [p.strip() for p in str(text).split(",")]
    try:
        values = [int(p) for p in parts]
    except ValueError:
        values = []
    if len(values) not in (2, 4):
        raise ParameterError("spectrum", f"expects X,Y (a pixel) or X,Y,W,H (a region), got "
                             f"{text!r}")
    region = Region(*values)
    if region.x < 0 or region.y < 0 or region.width < 1 or region.height < 1:
        raise ParameterError("spectrum", f"needs X, Y >= 0 and W, H >= 1, got {text!r}")
    if image is not None and (region.x + region.width > image.width
                              or region.y + region.height > image.height):
        raise ParameterError("spectrum", f"{region.describe()} is outside the "
                             f"{image.width}x{image.height} image")
    return region


def band_centres(image: StokesImage) -> np.ndarray:
    """The band centres (nm) from the band names (``460nm`` -> 460); NaN for
    a band not named so."""
    out = []
    for name in image.bands:
        try:
            out.append(float(name[:-2]) if name.endswith("nm") else math.nan)
        except ValueError:
            out.append(math.nan)
    return np.array(out)


def region_spectrum(image: StokesImage, region: Region):
    """The mean Stokes vector per band, shape (n_bands, 4), float64, of the
    pixels of *region* usable in every band (:mod:`mitsuba_pbrdf.stokes.quality`),
    and how many pixels that is. :class:`ParameterError` naming ``spectrum``
    when a band is not named after its wavelength (``460nm``: the CSV's
    ``centre_nm``) or when no pixel of the region is usable."""
    from ..stokes.quality import assess

    centres = band_centres(image)
    if not np.all(np.isfinite(centres)):
        raise ParameterError("spectrum", f"a Stokes spectrum needs bands named after their "
                             f"wavelengths (a cube of pbrdf render --bands, e.g. 460nm); "
                             f"this image has bands {', '.join(image.bands)}")
    rows = slice(region.y, region.y + region.height)
    cols = slice(region.x, region.x + region.width)
    usable = np.ones((region.height, region.width), bool)
    for band in image.bands:
        usable &= ~assess(image, band).unusable[rows, cols]
    if not usable.any():
        raise ParameterError("spectrum", f"{region.describe()}: no pixel is usable in every "
                             "band (non-finite, S0 < 0 or degree of polarization > 1)")
    block = image.stokes[rows, cols].astype(np.float64)[usable]   # (n, 4, bands)
    return block.mean(axis=0).T, int(usable.sum())


def stokes_spectrum(image: StokesImage, region: Region) -> np.ndarray:
    """Mean Stokes vector of *region*'s usable pixels per band, shape
    (n_bands, 4), float64 (:func:`region_spectrum`)."""
    return region_spectrum(image, region)[0]


def write_spectrum_csv(path, image: StokesImage, region: Region) -> str:
    """The region's Stokes spectrum as CSV (band, centre_nm, S0..S3, DoLP),
    written atomically."""
    from ..outputs import atomic_path, escape_text

    spectrum = stokes_spectrum(image, region)
    with np.errstate(invalid="ignore", divide="ignore"):
        dolp = np.hypot(spectrum[:, 1], spectrum[:, 2]) / spectrum[:, 0]
    lines = [f"# {escape_text(region.describe(), 'line')}", "band,centre_nm,S0,S1,S2,S3,DoLP"]
    for name, c, s, d in zip(image.bands, band_centres(image), spectrum, dolp):
        lines.append(",".join([escape_text(name, "csv"), f"{c:g}"] + [f"{v:.7g}" for v in s]
                              + [f"{d:.7g}"]))
    with atomic_path(path) as tmp:
        with open(tmp, "w", encoding="utf-8") as f:
            f.write("\n".join(lines) + "\n")
    return str(path)


def _spectrum_axes(ax, image: StokesImage, region: Region):
    spectrum = stokes_spectrum(image, region)
    centres = band_centres(image)
    x = centres if np.all(np.isfinite(centres)) else np.arange(len(image.bands))
    ax.plot(x, spectrum[:, 0], "k-o", ms=3, label="S0")
    ax.set_xlabel("wavelength (nm)" if x is centres else "band")
    ax.set_ylabel("S0")
    twin = ax.twinx()
    with np.errstate(invalid="ignore", divide="ignore"):
        for i, colour in ((1, "tab:red"), (2, "tab:blue"), (3, "tab:green")):
            twin.plot(x, spectrum[:, i] / spectrum[:, 0], "-s", ms=3, color=colour,
                      label=f"S{i}/S0")
    twin.set_ylabel("S1/S0, S2/S0, S3/S0")
    lines = ax.get_legend_handles_labels()
    more = twin.get_legend_handles_labels()
    ax.legend(lines[0] + more[0], lines[1] + more[1], fontsize=7, loc="best")
    ax.set_title(f"Stokes spectrum, {region.describe()}", fontsize=9)


#: The picture options :func:`cube_sheet_figure` takes (the S0 panels use each
#: band's own exposure; there is no choice of panels nor of Stokes scale).
SHEET_OPTIONS = ("dolp_limit", "min_dolp", "dolp_cmap")


#: ``dolp_scale`` of :func:`cube_sheet_figure`: one DoLP scale for every band
#: (the default, so bands compare by colour) or each band its own.
DOLP_SCALES = ("shared", "per-band")


def shared_dolp_limit(image: StokesImage, qualities=None) -> float:
    """The top of one DoLP scale for all bands of *image*: the automatic limit
    (:func:`~mitsuba_pbrdf.visualization.colours.auto_limit`) of the usable, lit
    pixels' DoLP of every band together."""
    from ..stokes.image import dolp
    from ..stokes.quality import assess
    from .colours import auto_limit
    from .tonemap import pixel_stokes

    values = []
    for i, band in enumerate(image.bands):
        quality = assess(image, band) if qualities is None else qualities[i]
        s = pixel_stokes(image, band)
        with np.errstate(invalid="ignore", divide="ignore"):
            d = dolp(s, axis=-1)
        values.append(d[~quality.unusable & (s[..., 0] > 0)].ravel())
    return auto_limit(np.concatenate(values) if values else np.zeros(0))


def cube_sheet_figure(image: StokesImage, region: Optional[Region] = None,
                      title: Optional[str] = None, panel_width: float = 2.6,
                      dolp_scale: str = "shared", **options):
    """A matplotlib Figure: one row per band with S0, DoLP and AoLP (each
    with its colour bar; S0 in grey with the band's own exposure), and with
    *region* its Stokes spectrum on top, the region outlined in each S0 panel.
    *options* (:data:`SHEET_OPTIONS`): ``dolp_limit``, ``min_dolp``, ``dolp_cmap``
    (defaults: :data:`~.defaults.PICTURE_DEFAULTS`, ``dolp_limit="auto"``);
    TypeError for any other. With ``dolp_limit``
    ``"auto"``, *dolp_scale* ``"shared"`` (default) gives every band one DoLP
    scale (:func:`shared_dolp_limit`), so a weakly polarized band looks weak;
    ``"per-band"`` scales each band to its own data."""
    unknown = sorted(set(options) - set(SHEET_OPTIONS))
    if unknown:
        raise TypeError(f"cube_sheet_figure: unexpected option(s) {', '.join(unknown)}; "
                        f"it takes {', '.join(SHEET_OPTIONS)}")
    if dolp_scale not in DOLP_SCALES:
        raise ParameterError("dolp_scale", f"must be {' or '.join(DOLP_SCALES)}, got "
                             f"{dolp_scale!r}")
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.patches import Rectangle

    from ..stokes.quality import assess
    from .panels import _finish, draw_aolp, draw_dolp, plot_intensity

    n = len(image.bands)
    aspect = image.height / image.width
    top = 1 if region is not None else 0
    heights = [3.0] * top + [panel_width * aspect + 0.4] * n
    fig = Figure(figsize=((panel_width + 0.8) * 3, sum(heights) + (0.4 if title else 0)),
                 layout="constrained")
    FigureCanvasAgg(fig)
    grid = fig.add_gridspec(n + top, 3, height_ratios=heights)
    if region is not None:
        _spectrum_axes(fig.add_subplot(grid[0, :]), image, region)
    qualities = [assess(image, band) for band in image.bands]
    options = {**PICTURE_DEFAULTS, **options}
    dolp_limit = options["dolp_limit"]
    automatic = isinstance(dolp_limit, str) and dolp_limit.strip().lower() == "auto"
    if automatic and dolp_scale == "shared":
        dolp_limit = shared_dolp_limit(image, qualities)
        title = (title + "; " if title else "") + f"DoLP 0–{dolp_limit:g} in every band (auto)"
    for row, band in enumerate(image.bands):
        quality = qualities[row]
        axes = [fig.add_subplot(grid[row + top, c]) for c in range(3)]
        # short titles: three panels of a row share panel_width x 3 inches
        plot_intensity(axes[0], image, band=band, quality=quality, title=f"S0 [{band}]")
        _finish(axes[1], draw_dolp(axes[1], image, options["dolp_cmap"],
                                   dolp_limit, band=band, quality=quality), f"DoLP [{band}]")
        _finish(axes[2], draw_aolp(axes[2], image, options["min_dolp"], band=band,
                                   quality=quality), f"AoLP [{band}]")
        if region is not None:
            axes[0].add_patch(Rectangle((region.x - 0.5, region.y - 0.5), region.width,
                                        region.height, fill=False, edgecolor="red", lw=1))
    if title:
        fig.suptitle(title, fontsize=10)
    return fig


def save_cube_sheet(path, image: StokesImage, region: Optional[Region] = None,
                    title: Optional[str] = None, dpi: int = 100, dolp_scale: str = "shared",
                    csv=None, **options) -> str:
    """Write :func:`cube_sheet_figure` as a PNG (atomically), and with *csv*
    the *region*'s Stokes spectrum there (:func:`write_spectrum_csv`): both
    files or neither (``pbrdf view --spectrum``). Returns the PNG's path."""
    from ..outputs import together

    if title is None:
        title = image.metadata.get("title")
    if csv is not None and region is None:
        raise ParameterError("csv", "the spectrum is a region's: give region too")
    with together():
        png = save_png(cube_sheet_figure(image, region, title, dolp_scale=dolp_scale, **options),
                       path, dpi=dpi)
        if csv is not None:
            write_spectrum_csv(csv, image, region)
    return png
