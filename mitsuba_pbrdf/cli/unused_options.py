"""One-line warnings for picture options that the chosen ``--panels`` never
use (``pbrdf render --panels intensity --dolp-max 1`` would otherwise ignore
``--dolp-max`` in silence). Which panel uses which option is read from the
panel functions' own signatures, so the warning follows the code."""

from __future__ import annotations

import inspect
import sys
from typing import List

from .common import PROG

#: picture option -> (argparse dest, its default, the panel functions' keyword);
#: ``--stokes-scale`` is the S1, S2, S3 panels' (a keyword of the figure, not of
#: a panel function)
PICTURE_OPTIONS = {
    "--dolp-max": ("dolp_max", "auto", "dolp_max"),
    "--dolp-cmap": ("dolp_cmap", "viridis", "dolp_cmap"),
    "--min-dolp": ("min_dolp", 0.01, "min_dolp"),
    "--exposure": ("exposure", None, "exposure"),
}
STOKES_PANELS = ("s1", "s2", "s3")


def unused_picture_options(args, panels) -> List[str]:
    """The warnings (one line each, without the program prefix) for the
    picture options given a non-default value that none of *panels* uses."""
    from ..pictures.panels import PANELS

    users_of = {}
    for name, function in PANELS.items():
        for keyword in inspect.signature(function).parameters:
            users_of.setdefault(keyword, []).append(name)
    warnings = []
    for option, (dest, default, keyword) in PICTURE_OPTIONS.items():
        users = users_of.get(keyword, [])
        if getattr(args, dest) != default and not set(users) & set(panels):
            warnings.append(f"{option} has no effect on the panels {','.join(panels)} "
                            f"(it is used by {', '.join(users)})")
    if args.stokes_scale != "shared" and not set(STOKES_PANELS) & set(panels):
        warnings.append(f"--stokes-scale has no effect on the panels {','.join(panels)} "
                        f"(it is used by {', '.join(STOKES_PANELS)})")
    return warnings


def warn_unused_picture_options(args, panels, command: str) -> None:
    """Print :func:`unused_picture_options` on stderr, one line each."""
    for warning in unused_picture_options(args, panels):
        print(f"{PROG} {command}: warning: {warning}", file=sys.stderr)
