"""``pbrdf gallery``: render scenes/gallery and draw README's pictures.

The pictures go to ``out/gallery/`` (beside the EXRs) unless asked otherwise:
the repository's own ``gallery/`` (README's pictures, committed) is written
only with ``--update-repo-pictures``, so a trial run at low ``--spp`` never
replaces them."""

from __future__ import annotations

import os

from .arguments import (check_outputs, chosen_variant, positive_int, progress_options,
                        show_progress, variant_help)
from .errors import CliError


def repository_gallery() -> str:
    """The ``gallery/`` folder of the clone this package runs from (where
    README.md shows its pictures); a :class:`CliError` for an installed copy,
    which has none."""
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    folder = os.path.join(root, "gallery")
    if not (os.path.isfile(os.path.join(root, "README.md")) and os.path.isdir(folder)):
        raise CliError("--update-repo-pictures: this package does not run from a clone of the "
                       f"repository (no README.md and gallery/ in {root}); use --out DIR")
    return folder


def run(args) -> int:
    """``pbrdf gallery``."""
    from ..visualization.gallery import GALLERY_ITEMS, RENDERED_ITEMS, run_gallery

    only = [i.strip() for i in args.only.split(",") if i.strip()] if args.only else None
    unknown = [i for i in only or [] if i not in GALLERY_ITEMS]
    if unknown:
        raise CliError(f"--only: unknown gallery item(s) {', '.join(unknown)}; "
                       f"choose from {', '.join(GALLERY_ITEMS)}")
    positive_int("--spp", args.spp)
    out = args.out or "out/gallery"
    if args.update_repo_pictures:
        if args.out is not None:
            raise CliError("--update-repo-pictures writes README's pictures into the "
                           "repository's gallery/; give it without --out")
        out = repository_gallery()
    if not 0 < args.scale < 100:
        raise CliError(f"--scale must be in (0, 100), got {args.scale}")
    renders = any(item in RENDERED_ITEMS for item in only or GALLERY_ITEMS)
    # the folders can hold files: checked with a file name in each, before rendering
    check_outputs(("--out", os.path.join(out, "pbrdf_plot.png")),
                  ("--exr-dir", os.path.join(args.exr_dir, "default.exr")
                   if args.exr_dir and renders else None))
    variant = chosen_variant(args) if renders else None
    if variant is not None:
        from ..rendering.render import require_polarized

        require_polarized(variant)
    run_gallery(out=out, scenes_dir=args.scenes, exr_dir=args.exr_dir or None,
                spp=args.spp, scale=args.scale, variant=variant, only=only,
                progress=show_progress(args))
    return 0


def add_parser(subparsers):
    g = subparsers.add_parser("gallery", help="render scenes/gallery and draw README's pictures",
                              description="Render the gallery scenes (metals, roughness, polarizer at "
                                          "0/45/90/135 degrees, a polarization camera's images "
                                          "and sensor frames, brushed aluminium, metals under "
                                          "a polarized sky), the Stokes sheet of "
                                          "scenes/default.xml and the pBRDF plot into PNGs.")
    g.add_argument("--out", default=None, metavar="DIR",
                   help="folder of the PNGs (default: out/gallery)")
    g.add_argument("--update-repo-pictures", action="store_true",
                   help="write the PNGs into the repository's gallery/ (README's pictures), "
                        "replacing them; only from a clone")
    g.add_argument("--exr-dir", default="out/gallery", metavar="DIR",
                   help="folder of the Stokes EXRs ('' for none; default: out/gallery)")
    g.add_argument("--scenes", default=None, metavar="DIR",
                   help="folder of the gallery scenes (default: the packaged scenes/gallery)")
    g.add_argument("--only", default=None, metavar="ITEM,...",
                   help="materials, roughness, polarizer, polcam, normalmap, sheet, plot, brushed, "
                        "sky (default: all)")
    g.add_argument("--spp", type=int, default=None, help="samples per pixel (default: each scene's)")
    g.add_argument("--scale", type=float, default=1.0,
                   help="image size factor (default: 1, i.e. 240x180 panels)")
    g.add_argument("--variant", default=None, help=variant_help())
    progress_options(g)
    g.set_defaults(func=run)
