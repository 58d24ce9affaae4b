"""Command line: ``pbrdf`` (or ``python -m mitsuba_pbrdf``).

::

    pbrdf render SCENE.xml [--spp N] [--variant V] [--seed S] [--passes N] [--out DIR_OR_STEM]
                           [-D key=value ...] [--panels P,...] [--no-progress]
    pbrdf view STOKES.exr [--out PNG] [--panels all|P,...] [--band B] [--dolp-cmap gray]
                          [--dolp-max X] [--min-dolp X] [--exposure EV]
    pbrdf plot [--material M | --eta N --k K] [--sigma S] [--ks W] [--kdd W] [--sigma-dd S]
               [--kid W] [--shadowing vgroove|smith] [--dd-distribution beckmann|ggx]
               [--theta-i DEG] [--wavelengths NM,...] [--out PNG]
    pbrdf gallery [--out DIR] [--only ITEM,...] [--spp N] [--scale F] [--variant V]

``render`` writes ``<out>.exr`` (the Stokes image, named float32 channels
``R, G, B, S0.R ... S3.B``) and ``<out>.png`` (by default intensity and DoLP
side by side); ``<out>`` defaults to ``out/<scene stem>``. ``-D key=value``
overrides the scene's ``<default name="key" value="..."/>``. The variant
defaults to ``cuda_ad_spectral_polarized`` where a CUDA GPU is usable, else
``llvm_ad_spectral_polarized``. Long renders run in sample passes with a
progress bar. ``view`` draws the Stokes sheet of an EXR; ``plot`` draws the
model's pBRDF with the NumPy reference evaluator (no variant needed);
``gallery`` renders ``scenes/gallery`` and draws README's pictures.
Errors (missing file, bad scene, unknown variant, bad parameter) print one line
and exit with status 2.

A thin layer over :mod:`mitsuba_pbrdf.render`, :mod:`mitsuba_pbrdf.stokes_io`,
:mod:`mitsuba_pbrdf.visualize`, :mod:`mitsuba_pbrdf.plots` and
:mod:`mitsuba_pbrdf.gallery`.
"""

from __future__ import annotations

import argparse
import os
import sys
from typing import List, Optional

PROG = "pbrdf"
EXIT_ERROR = 2


class CliError(Exception):
    """An error reported to the user as one line, exit status 2."""


def _one_line(message) -> str:
    return " ".join(str(message).split())


def _parse_defines(items) -> dict:
    params = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise CliError(f"-D expects key=value, got {item!r}")
        params[key.strip()] = value
    return params


def _panels(text: str):
    from .visualize import parse_panels

    try:
        return parse_panels(text)
    except ValueError as e:
        raise CliError(str(e)) from e


def _out_stem(out: Optional[str], scene_path: str) -> str:
    stem = os.path.splitext(os.path.basename(scene_path))[0]
    if out is None:
        return os.path.join("out", stem)
    if out.endswith(("/", os.sep)) or os.path.isdir(out):
        return os.path.join(out, stem)
    base, ext = os.path.splitext(out)
    return base if ext.lower() in (".exr", ".png") else out


def _require_file(path: str, what: str):
    if not os.path.exists(path):
        raise CliError(f"{what} not found: {path}")
    if not os.path.isfile(path):
        raise CliError(f"{what} is not a file: {path}")


def _positive_int(name: str, value: Optional[int]):
    if value is not None and value < 1:
        raise CliError(f"{name} must be at least 1, got {value}")


def _show_progress(args) -> bool:
    """Progress bars go to stderr, only when it is a terminal (unless --progress)."""
    if args.progress is not None:
        return args.progress
    return sys.stderr.isatty()


def _variant(args) -> str:
    from .render import default_variant

    return args.variant or default_variant()


def cmd_render(args) -> int:
    """``pbrdf render``."""
    from .render import SceneLoadError, UnknownVariantError, render_scene_timed
    from .stokes_io import StokesChannelError, write_stokes_exr
    from .visualize import save_overview_png

    _require_file(args.scene, "scene file")
    params = _parse_defines(args.define)
    panels = _panels(args.panels)
    _positive_int("--spp", args.spp)
    _positive_int("--passes", args.passes)
    stem = _out_stem(args.out, args.scene)
    variant = _variant(args)

    try:
        image, timings = render_scene_timed(
            args.scene, spp=args.spp, variant=variant, seed=args.seed, params=params,
            passes=args.passes, progress=_show_progress(args),
        )
    except UnknownVariantError as e:
        raise CliError(str(e)) from e
    except SceneLoadError as e:
        raise CliError(f"cannot load {args.scene}: {e}") from e
    except StokesChannelError as e:
        raise CliError(
            f"{_one_line(e)} (render with a *_polarized variant and the scene's integrator "
            "wrapped in <integrator type=\"stokes\">)"
        ) from e

    name = os.path.splitext(os.path.basename(args.scene))[0]
    passes = int(image.metadata.get("passes", 1))
    image.metadata["title"] = (f"{name}: {variant}, {image.metadata['spp']} spp"
                               + (f" in {passes} passes" if passes > 1 else ""))
    exr = write_stokes_exr(stem + ".exr", image)
    png = save_overview_png(stem + ".png", image, panels=panels)
    print(f"wrote {exr} ({image.width}x{image.height}, Stokes bands {','.join(image.bands)})")
    print(f"wrote {png}")
    print(f"timings: {timings.summary()}")
    return 0


def cmd_view(args) -> int:
    """``pbrdf view``."""
    from .stokes_io import StokesChannelError, read_stokes_exr
    from .visualize import save_overview_png

    _require_file(args.exr, "EXR file")
    panels = _panels(args.panels)
    if args.dolp_max is not None and not args.dolp_max > 0:
        raise CliError(f"--dolp-max must be > 0, got {args.dolp_max}")
    try:
        image = read_stokes_exr(args.exr)
    except (StokesChannelError, ValueError) as e:
        raise CliError(_one_line(e)) from e
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


def _float_list(text: str, what: str) -> list:
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise CliError(f"{what} expects comma-separated numbers, got {text!r}") from None
    if not values:
        raise CliError(f"{what} expects at least one number")
    return values


def cmd_plot(args) -> int:
    """``pbrdf plot``."""
    from .plots import PBRDFParams, save_pbrdf_plot

    material = args.material
    if (args.eta is not None or args.k is not None) and args.material is not None:
        raise CliError("give --material or --eta and --k, not both")
    if args.eta is None and args.k is None and material is None:
        material = "Al"
    params = PBRDFParams(material=material, eta=args.eta, k=args.k, sigma=args.sigma,
                         ks=args.ks, kdd=args.kdd, sigma_dd=args.sigma_dd, kid=args.kid,
                         shadowing=args.shadowing, dd_distribution=args.dd_distribution)
    wavelengths = _float_list(args.wavelengths, "--wavelengths")
    try:
        params.validate()
        path = save_pbrdf_plot(args.out, params, args.theta_i, wavelengths)
    except ValueError as e:
        raise CliError(_one_line(e)) from e
    print(f"wrote {path} ({params.label()}, θi = {args.theta_i:g}°; "
          "computed with the NumPy reference evaluator)")
    return 0


def cmd_gallery(args) -> int:
    """``pbrdf gallery``."""
    from .gallery import GALLERY_ITEMS, run_gallery
    from .render import SceneLoadError, UnknownVariantError

    only = [i.strip() for i in args.only.split(",") if i.strip()] if args.only else None
    unknown = [i for i in only or [] if i not in GALLERY_ITEMS]
    if unknown:
        raise CliError(f"unknown gallery item(s) {', '.join(unknown)}; "
                       f"choose from {', '.join(GALLERY_ITEMS)}")
    _positive_int("--spp", args.spp)
    if not args.scale > 0:
        raise CliError(f"--scale must be > 0, got {args.scale}")
    try:
        run_gallery(out=args.out, scenes_dir=args.scenes, exr_dir=args.exr_dir or None,
                    spp=args.spp, scale=args.scale, variant=_variant(args), only=only,
                    progress=_show_progress(args))
    except (UnknownVariantError, SceneLoadError) as e:
        raise CliError(_one_line(e)) from e
    return 0


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``pbrdf`` command."""
    from .render import DEFAULT_VARIANT, GPU_VARIANT

    parser = argparse.ArgumentParser(
        prog=PROG,
        description="Render, look at and plot polarized BRDFs with the pbrdf Mitsuba plugin.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    variant_help = (f"Mitsuba variant (default: {GPU_VARIANT} if a CUDA GPU is usable, "
                    f"else {DEFAULT_VARIANT})")

    def progress_options(p):
        g = p.add_mutually_exclusive_group()
        g.add_argument("--progress", dest="progress", action="store_true", default=None,
                       help="show the progress bar even when stderr is not a terminal")
        g.add_argument("--no-progress", dest="progress", action="store_false",
                       help="never show the progress bar")

    r = sub.add_parser("render", help="render a scene to <out>.exr (Stokes) and <out>.png",
                       description="Render a Mitsuba scene to a Stokes EXR and an overview PNG.")
    r.add_argument("scene", metavar="SCENE.xml", help="Mitsuba scene file")
    r.add_argument("--spp", type=int, default=None, help="samples per pixel (default: the scene's)")
    r.add_argument("--variant", default=None, help=variant_help)
    r.add_argument("--seed", type=int, default=0, help="sampler seed (default: 0)")
    r.add_argument("--passes", type=int, default=None,
                   help="split the samples into N passes with different seeds, averaged "
                        "(default: automatic, one pass unless the render has more than "
                        "16.8 M samples, i.e. pixels × spp)")
    r.add_argument("--out", metavar="DIR_OR_STEM", default=None,
                   help="output stem (writes STEM.exr and STEM.png) or existing directory / path "
                        "ending in '/' (default: out/<scene stem>)")
    r.add_argument("-D", dest="define", action="append", metavar="key=value",
                   help="override a scene <default> parameter (repeatable)")
    r.add_argument("--panels", default="intensity,dolp",
                   help="comma-separated PNG panels: intensity, dolp, aolp, docp, hsv, s1, s2, "
                        "s3, or 'all' (default: intensity,dolp)")
    progress_options(r)
    r.set_defaults(func=cmd_render)

    v = sub.add_parser("view", help="draw the Stokes sheet (PNG) of a Stokes EXR",
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
    v.set_defaults(func=cmd_view)

    p = sub.add_parser("plot", help="plot the model's pBRDF (lobes, Mueller elements, DoP)",
                       description="Plot the pBRDF for given parameters: polar lobe, M00, "
                                   "normalized Mueller elements and DoP in the plane of "
                                   "incidence, M00 and DoP over the hemisphere. Computed with "
                                   "the NumPy float64 reference evaluator (no Mitsuba variant).")
    p.add_argument("--material", default=None,
                   help="Mitsuba conductor name (Al, Cu, Au, Ag, Cr, ...; default: Al)")
    p.add_argument("--eta", type=float, default=None, help="real part n of the complex index "
                                                            "(with --k; constant over wavelength)")
    p.add_argument("--k", type=float, default=None, help="imaginary part k of the complex index")
    p.add_argument("--sigma", type=float, default=0.1, help="RMS facet slope, > 0 (default: 0.1)")
    p.add_argument("--ks", type=float, default=1.0, help="specular weight (default: 1)")
    p.add_argument("--kdd", type=float, default=0.0, help="directional diffuse weight (default: 0)")
    p.add_argument("--sigma-dd", type=float, default=0.5,
                   help="directional diffuse RMS slope, > 0 (default: 0.5)")
    p.add_argument("--kid", type=float, default=0.0, help="ideal diffuse weight (default: 0)")
    p.add_argument("--shadowing", default="vgroove", choices=["vgroove", "smith"],
                   help="shadowing-masking G (default: vgroove)")
    p.add_argument("--dd-distribution", default="beckmann", choices=["beckmann", "ggx"],
                   help="directional diffuse distribution (default: beckmann)")
    p.add_argument("--theta-i", type=float, default=45.0,
                   help="incidence angle in degrees, in [0, 90) (default: 45)")
    p.add_argument("--wavelengths", default="550,450,650",
                   help="wavelengths in nm; the first is used for single-wavelength panels "
                        "(default: 550,450,650)")
    p.add_argument("--out", default="out/pbrdf_plot.png", metavar="PNG",
                   help="output PNG (default: out/pbrdf_plot.png)")
    p.set_defaults(func=cmd_plot)

    g = sub.add_parser("gallery", help="render scenes/gallery and draw README's pictures",
                       description="Render the gallery scenes (metals, roughness, polarizer at "
                                   "0/45/90/135 degrees), the Stokes sheet of scenes/default.xml "
                                   "and the pBRDF plot into PNGs.")
    g.add_argument("--out", default="gallery", metavar="DIR", help="folder of the PNGs "
                                                                   "(default: gallery)")
    g.add_argument("--exr-dir", default="out/gallery", metavar="DIR",
                   help="folder of the Stokes EXRs ('' for none; default: out/gallery)")
    g.add_argument("--scenes", default=None, metavar="DIR",
                   help="folder of the gallery scenes (default: scenes/gallery)")
    g.add_argument("--only", default=None, metavar="ITEM,...",
                   help="materials, roughness, polarizer, sheet, plot (default: all)")
    g.add_argument("--spp", type=int, default=None, help="samples per pixel (default: each scene's)")
    g.add_argument("--scale", type=float, default=1.0,
                   help="image size factor (default: 1, i.e. 240x180 panels)")
    g.add_argument("--variant", default=None, help=variant_help)
    progress_options(g)
    g.set_defaults(func=cmd_gallery)
    return parser


def main(argv: Optional[List[str]] = None) -> int:
    """Run the command line; returns the exit status (0, or 2 on error).
    Usage errors found by argparse exit through ``SystemExit(2)`` as usual."""
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except CliError as e:
        print(f"{PROG} {args.command}: error: {e}", file=sys.stderr)
        return EXIT_ERROR
    except FileNotFoundError as e:
        print(f"{PROG} {args.command}: error: {_one_line(e)}", file=sys.stderr)
        return EXIT_ERROR


if __name__ == "__main__":
    sys.exit(main())
