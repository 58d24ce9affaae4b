"""The picture options of ``pbrdf render`` and ``view`` (``--panels``,
``--band``, ``--dolp-limit`` ...): the options with their defaults from the one
table, :data:`~mitsuba_pbrdf.visualization.defaults.PICTURE_DEFAULTS`
(:func:`picture_options`), their checked values as keyword arguments of
:func:`~mitsuba_pbrdf.visualization.panels.save_overview_png`
(:func:`picture_kwargs`), the unusable-pixel report (:func:`report_quality`),
and one-line warnings for options that the chosen ``--panels`` never use
(:func:`warn_unused_picture_options`: ``pbrdf render --panels intensity
--dolp-limit 1`` would otherwise ignore ``--dolp-limit`` in silence; which panel
uses which option is read from the panel functions' own signatures, so the
warning follows the code).

``--band`` picks one band of the Stokes image (``R``, ``632.8nm``, ``460nm``:
:attr:`~mitsuba_pbrdf.stokes.StokesImage.bands`), the image's word for it."""

from __future__ import annotations

import inspect
import sys
from typing import List

from ..visualization.defaults import PICTURE_DEFAULTS
from .arguments import RenamedOption, finite_float, typed_option
from .errors import PROG, CliError

__all__ = ["picture_options", "picture_kwargs", "parse_panels", "scale_value", "report_quality",
           "warn_quality",
           "unused_picture_options", "unused_cube_sheet_options", "warn_unused_picture_options"]

def picture_options(parser, panels_default: str):
    """The options of the Stokes pictures that ``render`` and ``view`` draw
    (defaults: :data:`~mitsuba_pbrdf.visualization.defaults.PICTURE_DEFAULTS`, as in Python)."""
    D = PICTURE_DEFAULTS
    parser.add_argument("--panels", default=panels_default,
                        help="comma-separated panels: intensity, dolp, aolp, docp, hsv, s1, s2, "
                             f"s3, or 'all' (the 2 x 4 sheet) (default: {panels_default})")
    parser.add_argument("--band", default=None,
                        help="draw one band (e.g. R, or a wavelength band's name) instead of the "
                             "luminance combination of the bands")
    # --dolp-max: the former spelling (dolp_max is polarized_sky's physical maximum)
    parser.add_argument("--dolp-limit", "--dolp-max", default=D["dolp_limit"], metavar="X|auto",
                        action=RenamedOption,
                        help="top of the DoLP colour scale (and of the saturation of the hsv "
                             "panel); auto: the image's 99.5th percentile rounded up "
                             f"(default: {D['dolp_limit']}; --dolp-max is deprecated)")
    parser.add_argument("--dolp-cmap", default=D["dolp_cmap"], choices=["viridis", "gray"],
                        help=f"colour map of the DoLP panel (default: {D['dolp_cmap']})")
    parser.add_argument("--min-dolp", type=float, default=D["min_dolp"],
                        help=f"AoLP is grey where DoLP is below this (default: {D['min_dolp']})")
    parser.add_argument("--stokes-scale", default=D["stokes_scale"],
                        choices=["shared", "separate"],
                        help="one symmetric scale for S1/S0, S2/S0, S3/S0, or one each "
                             f"(default: {D['stokes_scale']})")
    parser.add_argument("--exposure", type=float, default=D["exposure"], metavar="EV",
                        help="intensity exposure in stops (default: automatic)")


def picture_kwargs(args, image=None) -> dict:
    """Checked keyword arguments of :func:`~mitsuba_pbrdf.visualization.panels.save_overview_png`
    from the picture options (and *image*'s bands, for ``--band``)."""
    panels = parse_panels(args.panels)
    finite_float("--min-dolp", args.min_dolp, 0.0, 1.0)
    finite_float("--exposure", args.exposure)
    options = dict(panels=panels, band=args.band, dolp_cmap=args.dolp_cmap,
                   dolp_limit=scale_value(typed_option(args, "dolp_limit", "--dolp-limit"),
                                          args.dolp_limit), min_dolp=args.min_dolp,
                   stokes_scale=args.stokes_scale)
    if args.exposure is not None:
        options["exposure"] = 2.0 ** args.exposure
    if image is not None and args.band is not None and args.band not in image.bands:
        raise CliError(f"no band {args.band!r}; bands are {', '.join(image.bands)}")
    return options


def parse_panels(text: str):
    """``--panels`` as panel names, or a :class:`CliError` naming unknown ones."""
    from ..visualization.panels import parse_panels as parse

    try:
        return parse(text)
    except ValueError as e:
        raise CliError(f"--panels: {e}") from e


def scale_value(name: str, text: str):
    """A picture scale option: ``auto`` or a finite number > 0 (as a float)."""
    if text is None or text.strip().lower() == "auto":
        return "auto"
    try:
        value = float(text)
    except ValueError:
        raise CliError(f"{name} must be a number > 0 or 'auto', got {text!r}") from None
    finite_float(name, value, low=0.0, low_open=True)
    return value


def report_quality(image, band, source: str, command: str, bands=None):
    """Warn (one line on stderr) about unusable pixels of *image*; a
    :class:`CliError` when none is usable in *band* (None: the luminance
    vector) or in any of *bands* (:func:`~mitsuba_pbrdf.stokes.quality.require_usable`).
    Returns the assessment of *band*."""
    from ..stokes.quality import UnusableImageError, require_usable

    try:
        quality = require_usable(image, source, bands=bands, band=band)
    except UnusableImageError as e:
        raise CliError(str(e)) from None
    warn_quality(quality, source, command)
    return quality


def warn_quality(quality, source: str, command: str) -> None:
    """One line on stderr about an image's unusable pixels (*quality*:
    :func:`~mitsuba_pbrdf.stokes.quality.assess`), or its being black."""
    if quality.count:
        print(f"{PROG} {command}: warning: {source}: {quality.summary()}; marked in the "
              "picture (see its legend)", file=sys.stderr)
    elif quality.black:
        print(f"{PROG} {command}: warning: {source}: the image is black (S0 = 0 everywhere)",
              file=sys.stderr)


#: picture option -> (argparse dest, its default, the panel functions' keyword);
#: ``--stokes-scale`` is the S1, S2, S3 panels' (a keyword of the figure, not of
#: a panel function)
PICTURE_OPTIONS = {
    f"--{keyword.replace('_', '-')}": (keyword, PICTURE_DEFAULTS[keyword], keyword)
    for keyword in ("dolp_limit", "dolp_cmap", "min_dolp", "exposure")
}
STOKES_PANELS = ("s1", "s2", "s3")


def _given(args) -> List[tuple]:
    """``(option, keyword)`` of the picture options given a non-default value."""
    given = [(typed_option(args, dest, option), keyword)
             for option, (dest, default, keyword) in PICTURE_OPTIONS.items()
             if getattr(args, dest) != default]
    if args.stokes_scale != PICTURE_DEFAULTS["stokes_scale"]:
        given.append(("--stokes-scale", "stokes_scale"))
    return given


def unused_picture_options(args, panels) -> List[str]:
    """The warnings (one line each, without the program prefix) for the
    picture options given a non-default value that none of *panels* uses."""
    from ..visualization.panels import PANELS

    users_of = {"stokes_scale": list(STOKES_PANELS)}
    for name, function in PANELS.items():
        for keyword in inspect.signature(function).parameters:
            users_of.setdefault(keyword, []).append(name)
    return [f"{option} has no effect on the panels {','.join(panels)} "
            f"(it is used by {', '.join(users_of.get(keyword, []))})"
            for option, keyword in _given(args)
            if not set(users_of.get(keyword, [])) & set(panels)]


def unused_cube_sheet_options(args) -> List[str]:
    """The warnings, as :func:`unused_picture_options`, for the contact sheet of
    a Stokes cube (``view --cube`` / ``--spectrum``): it draws S0 (each band at
    its own exposure), DoLP and AoLP of every band and takes only
    :data:`~mitsuba_pbrdf.visualization.cube_sheet.SHEET_OPTIONS`."""
    from ..visualization.cube_sheet import SHEET_OPTIONS

    used = ", ".join("--" + keyword.replace("_", "-") for keyword in SHEET_OPTIONS)
    why = f"(it draws S0, DoLP and AoLP of every band; it uses {used})"
    ignored = [option for option, keyword in _given(args) if keyword not in SHEET_OPTIONS]
    if args.panels != "all":
        ignored.insert(0, "--panels")
    return [f"{option} has no effect on the contact sheet of a cube {why}" for option in ignored]


def warn_unused_picture_options(args, panels, command: str) -> None:
    """Print :func:`unused_picture_options` (with *panels* None, those of the
    cube's contact sheet: :func:`unused_cube_sheet_options`) on stderr, one line each."""
    warnings = (unused_cube_sheet_options(args) if panels is None
                else unused_picture_options(args, panels))
    for warning in warnings:
        print(f"{PROG} {command}: warning: {warning}", file=sys.stderr)
