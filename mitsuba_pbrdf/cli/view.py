"""``pbrdf view``: the Stokes sheet (PNG) of a Stokes EXR.

Unusable pixels (non-finite, S0 < 0, polarization > 1;
:mod:`mitsuba_pbrdf.stokes.quality`) are counted in a one-line warning and
marked in the picture; a file with no usable pixel is an error (exit 2).

A Stokes cube (``pbrdf render --bands``) can be drawn as a contact sheet
(``--cube``: S0, DoLP, AoLP per band) with the Stokes spectrum of a pixel or
region (``--spectrum X,Y[,W,H]``, also written as ``<out>.csv``;
:mod:`mitsuba_pbrdf.visualization.cube_sheet`), its DoLP on one scale for all bands
(``--dolp-scale per-band``: each its own); ``--band 460nm`` draws one band.
The files of ``pbrdf polcam`` (a raw mosaic, or a polarizer image with the
other three beside it) are drawn as the Stokes image the camera measures
(intensity, DoLP, AoLP; :mod:`mitsuba_pbrdf.camera.raw_frames`)."""

from __future__ import annotations

import os
import sys

from ..errors import one_line
from ..interrupts import release
from .arguments import check_outputs, require_file
from .errors import PROG, CliError
from .pictures import (picture_kwargs, picture_options, report_quality,
                       warn_unused_picture_options)


def polcam_siblings(path: str) -> list:
    """``(name, path)`` of the other polarizer images that ``view`` reads
    with a polarizer image ``<stem>_I<angle>.exr`` of ``pbrdf polcam``."""
    from ..camera.raw_frames import polarizer_siblings

    return [("a polarizer image beside STOKES.exr", p) for p in polarizer_siblings(path)]


def run(args) -> int:
    """``pbrdf view``."""
    from ..camera.raw_frames import read_viewable_exr
    from ..visualization.panels import save_overview_png
    from ..visualization.cube_sheet import DOLP_SCALES

    require_file(args.exr, "EXR file")
    picture_kwargs(args)  # the options' own checks, before reading anything
    if args.dolp_scale not in DOLP_SCALES:
        raise CliError(f"--dolp-scale must be {' or '.join(DOLP_SCALES)}, got {args.dolp_scale!r}")
    out = args.out or os.path.splitext(args.exr)[0] + ".png"
    # with --spectrum the sheet's CSV goes beside it (<out>.csv)
    csv = os.path.splitext(out)[0] + ".csv" if args.spectrum is not None else None
    check_outputs(("--out", out, ("png",)), ("--out", csv, ("csv",)),
                  inputs=[("STOKES.exr", args.exr)] + polcam_siblings(args.exr))
    existed = os.path.exists(out)
    try:
        image, polcam = read_viewable_exr(args.exr)
    except (FileNotFoundError, ValueError) as e:
        raise CliError(one_line(e)) from e
    release()  # read: drawing is plain Python, Ctrl-C stops it at once (mitsuba_pbrdf.interrupts)
    if args.cube or args.spectrum is not None:
        return _cube_sheet(args, image, out, existed)
    picture = picture_kwargs(args, image)
    if polcam and args.panels == "all":  # a camera sees no S3: what it measures
        picture["panels"] = ("intensity", "dolp", "aolp")
    warn_unused_picture_options(args, picture["panels"], "view")
    if args.dolp_scale != "shared":
        print(f"{PROG} view: warning: --dolp-scale has no effect without --cube or --spectrum "
              "(it sets the DoLP scale of a cube's contact sheet)", file=sys.stderr)
    quality = report_quality(image, picture["band"], args.exr, "view")
    if not image.metadata.get("title"):
        image.metadata["title"] = os.path.basename(args.exr)
    path = save_overview_png(out, image, quality=quality, **picture)
    print(f"{'replaced' if existed else 'wrote'} {path}")
    return 0


def _cube_sheet(args, image, out: str, existed: bool) -> int:
    """``--cube`` / ``--spectrum``: the contact sheet (and the spectrum CSV)."""
    from ..visualization.cube_sheet import parse_region, region_spectrum, save_cube_sheet
    from ..stokes.quality import UnusableImageError, require_usable

    if args.band is not None:
        raise CliError("--band draws one band; --cube and --spectrum draw them all")
    warn_unused_picture_options(args, None, "view")
    region = None if args.spectrum is None else parse_region(args.spectrum, image)
    if region is not None:
        try:
            region_spectrum(image, region)  # ParameterError naming --spectrum
        except ValueError:
            try:  # the whole image's verdict first, where it is the cause
                require_usable(image, args.exr, bands=image.bands)
            except UnusableImageError as e:
                raise CliError(str(e)) from None
            raise
    # the unusable-pixel rule, for every band the sheet draws
    report_quality(image, None, args.exr, "view", bands=image.bands)
    if not image.metadata.get("title"):
        image.metadata["title"] = os.path.basename(args.exr)
    dolp_limit = args.dolp_limit if args.dolp_limit == "auto" else float(args.dolp_limit)
    csv = os.path.splitext(out)[0] + ".csv" if region is not None else None
    path = save_cube_sheet(out, image, region=region, csv=csv, dolp_limit=dolp_limit,
                           min_dolp=args.min_dolp, dolp_cmap=args.dolp_cmap,
                           dolp_scale=args.dolp_scale)   # the sheet and the CSV, or neither
    print(f"{'replaced' if existed else 'wrote'} {path} ({len(image.bands)} bands)")
    if region is not None:
        print(f"wrote {csv} (Stokes spectrum, {region.describe()})")
    return 0


def add_parser(subparsers):
    v = subparsers.add_parser(
        "view", help="draw the Stokes sheet (PNG) of a Stokes EXR",
        description="Draw pictures of a Stokes EXR: tone-mapped intensity, DoLP, AoLP (hue "
                    "wheel, grey where DoLP is low), DoCP, the HSV composite (hue AoLP, "
                    "saturation DoLP, value intensity) and S1, S2, S3 / S0 (diverging, one "
                    "shared scale), each with its colour bar. Unusable pixels are counted and "
                    "marked.")
    v.add_argument("exr", metavar="STOKES.exr",
                   help="EXR with Stokes channels S0.<band> ... S3.<band>")
    v.add_argument("--out", metavar="PNG", default=None,
                   help="output PNG, replaced if it exists (default: next to the EXR)")
    picture_options(v, "all")
    v.add_argument("--cube", action="store_true",
                   help="a Stokes cube's contact sheet: S0, DoLP and AoLP for every band "
                        "(see docs/spectral-cube.md)")
    v.add_argument("--spectrum", metavar="X,Y[,W,H]", default=None,
                   help="with the contact sheet, the Stokes spectrum (S0 and S1-S3/S0 per band) "
                        "of a pixel or the mean of a region (pixels from the top-left); also "
                        "written as <out>.csv")
    v.add_argument("--dolp-scale", default="shared", metavar="shared|per-band",
                   help="with the contact sheet and --dolp-limit auto: one DoLP scale for every "
                        "band, so bands compare by colour, or each band scaled to its own data "
                        "(default: shared)")
    v.set_defaults(func=run)
