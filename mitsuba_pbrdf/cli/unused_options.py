"""One-line warnings for picture options that the chosen ``--panels`` never
use (``pbrdf render --panels intensity --dolp-max 1`` would otherwise ignore
``--dolp-max`` in silence). Which panel uses which option is read from the
panel functions' own signatures, so the warning follows the code."""

from __future__ import annotations

import inspect
import sys
from typing import List

from ..visualization.defaults import PICTURE_DEFAULTS
from .common import PROG

#: picture option -> (argparse dest, its default, the panel functions' keyword);
#: ``--stokes-scale`` is the S1, S2, S3 panels' (a keyword of the figure, not of
#: a panel function)
PICTURE_OPTIONS = {
    f"--{keyword.replace('_', '-')}": (keyword, PICTURE_DEFAULTS[keyword], keyword)
    for keyword in ("dolp_max", "dolp_cmap", "min_dolp", "exposure")
}
STOKES_PANELS = ("s1", "s2", "s3")


def _given(args) -> List[tuple]:
    """``(option, keyword)`` of the picture options given a non-default value."""
    given = [(option, keyword) for option, (dest, default, keyword) in PICTURE_OPTIONS.items()
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
