"""``pbrdf view``: the Stokes sheet (PNG) of a Stokes EXR."""

from __future__ import annotations

import os

from .common import CliError, one_line, parse_panels, require_file


def run(args) -> int:
    """``pbrdf view``."""
    from ..imaging.exr import read_stokes_exr
    from ..imaging.panels import save_overview_png
    from ..imaging.stokes import StokesChannelError

    require_file(args.exr, "EXR file")
    panels = parse_panels(args.panels)
    if args.dolp_max is not None and not args.dolp_max > 0:
        raise CliError(f"--dolp-max must be > 0, got {args.dolp_max}")
    try:
        image = read_stokes_exr(args.exr)
    except (StokesChannelError, ValueError) as e:
        raise CliError(one_line(e)) from e
    if args.band is not None and args.band not in image.bands:
        raise CliError(f"no band {args.band!r} in {args.exr}; bands are {', '.join(image.bands)}")
    out = args.out or os.path.splitext(args.exr)[0] + ".png"
    if not image.metadata.get("title"):
        image.metadata["title"] = os.path.basename(args.exr)
    options = dict(band=args.band, dolp_cmap=args.dolp_cmap, min_dolp=args.min_dolp)
    if args.dolp_max is not None:
        options["dolp_max"] = args.dolp_max
    if args.exposure is not None:
        options["exposure"] = 2.0 ** args.exposure
    print(f"wrote {save_overview_png(out, image, panels=panels, **options)}")
    return 0


def add_parser(subparsers):
    v = subparsers.add_parser("view", help="draw the Stokes sheet (PNG) of a Stokes EXR",
                              description="Draw pictures of a Stokes EXR: tone-mapped intensity, DoLP, "
                                          "AoLP (cyclic, masked where DoLP is low), DoCP, the HSV "
                                          "composite (hue AoLP, saturation DoLP, value intensity) and "
                                          "S1, S2, S3 / S0 (diverging), each with its colour bar.")
    v.add_argument("exr", metavar="STOKES.exr", help="EXR with Stokes channels S0.<band> ... S3.<band>")
    v.add_argument("--out", metavar="PNG", default=None, help="output PNG (default: next to the EXR)")
    v.add_argument("--panels", default="all", help="comma-separated panels, as for render "
                                                   "(default: all, a 2 x 4 sheet)")
    v.add_argument("--band", default=None,
                   help="draw one band (e.g. R, or a wavelength band's name) instead of the "
                        "luminance combination of the bands")
    v.add_argument("--dolp-cmap", default="viridis", choices=["viridis", "gray"],
                   help="colour map of the DoLP panel (default: viridis)")
    v.add_argument("--dolp-max", type=float, default=None,
                   help="top of the DoLP scale (default: 1)")
    v.add_argument("--min-dolp", type=float, default=0.01,
                   help="AoLP is masked (black) where DoLP is below this (default: 0.01)")
    v.add_argument("--exposure", type=float, default=None, metavar="EV",
                   help="intensity exposure in stops (default: automatic)")
    v.set_defaults(func=run)
