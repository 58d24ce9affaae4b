"""Command line: ``pbrdf`` (or ``python -m mitsuba_pbrdf``).

::

    pbrdf render scenes/default.xml [--spp N] [--variant V] [--out DIR_OR_STEM] [-D key=value ...]
    pbrdf view out/default.exr [--out out/default.png]

``render`` writes ``<out>.exr`` (the Stokes image, named float32 channels
``R, G, B, S0.R ... S3.B``) and ``<out>.png`` (intensity and DoLP side by side);
``<out>`` defaults to ``out/<scene stem>``. ``-D key=value`` overrides the
scene's ``<default name="key" value="..."/>``. ``view`` redraws the PNG from an
EXR. Errors (missing file, bad scene, unknown variant) print one line and exit
with status 2.

A thin layer over :mod:`mitsuba_pbrdf.render`, :mod:`mitsuba_pbrdf.stokes_io`
and :mod:`mitsuba_pbrdf.visualize`.
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
    from .visualize import PANELS

    panels = [p.strip().lower() for p in text.split(",") if p.strip()]
    unknown = [p for p in panels if p not in PANELS]
    if unknown or not panels:
        raise CliError(
            f"unknown panel(s) {', '.join(unknown) or '(none)'}; choose from {', '.join(PANELS)}"
        )
    return panels


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


def cmd_render(args) -> int:
    from .render import SceneLoadError, UnknownVariantError, render_scene_timed
    from .stokes_io import StokesChannelError, write_stokes_exr
    from .visualize import save_overview_png

    _require_file(args.scene, "scene file")
    params = _parse_defines(args.define)
    panels = _panels(args.panels)
    if args.spp is not None and args.spp < 1:
        raise CliError(f"--spp must be at least 1, got {args.spp}")
    stem = _out_stem(args.out, args.scene)

    try:
        image, timings = render_scene_timed(
            args.scene, spp=args.spp, variant=args.variant, seed=args.seed, params=params
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
    image.metadata["title"] = f"{name}: {args.variant}, {image.metadata['spp']} spp"
    exr = write_stokes_exr(stem + ".exr", image)
    png = save_overview_png(stem + ".png", image, panels=panels)
    print(f"wrote {exr} ({image.width}x{image.height}, Stokes bands {','.join(image.bands)})")
    print(f"wrote {png}")
    print(f"timings: {timings.summary()}")
    return 0


def cmd_view(args) -> int:
    from .stokes_io import StokesChannelError, read_stokes_exr
    from .visualize import save_overview_png

    _require_file(args.exr, "EXR file")
    panels = _panels(args.panels)
    try:
        image = read_stokes_exr(args.exr)
    except (StokesChannelError, ValueError) as e:
        raise CliError(_one_line(e)) from e
    out = args.out or os.path.splitext(args.exr)[0] + ".png"
    if not image.metadata.get("title"):
        image.metadata["title"] = os.path.basename(args.exr)
    print(f"wrote {save_overview_png(out, image, panels=panels)}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    from .render import DEFAULT_VARIANT

    parser = argparse.ArgumentParser(
        prog=PROG,
        description="Render and inspect Stokes images with the pbrdf Mitsuba plugin.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    r = sub.add_parser("render", help="render a scene to <out>.exr (Stokes) and <out>.png",
                       description="Render a Mitsuba scene to a Stokes EXR and an overview PNG.")
    r.add_argument("scene", metavar="SCENE.xml", help="Mitsuba scene file")
    r.add_argument("--spp", type=int, default=None, help="samples per pixel (default: the scene's)")
    r.add_argument("--variant", default=DEFAULT_VARIANT, help=f"Mitsuba variant (default: {DEFAULT_VARIANT})")
    r.add_argument("--seed", type=int, default=0, help="sampler seed (default: 0)")
    r.add_argument("--out", metavar="DIR_OR_STEM", default=None,
                   help="output stem (writes STEM.exr and STEM.png) or existing directory / path "
                        "ending in '/' (default: out/<scene stem>)")
    r.add_argument("-D", dest="define", action="append", metavar="key=value",
                   help="override a scene <default> parameter (repeatable)")
    r.add_argument("--panels", default="intensity,dolp",
                   help="comma-separated PNG panels: intensity, dolp, aolp, docp, s1, s2, s3 "
                        "(default: intensity,dolp)")
    r.set_defaults(func=cmd_render)

    v = sub.add_parser("view", help="draw the overview PNG of a Stokes EXR",
                       description="Draw the overview PNG of a Stokes EXR.")
    v.add_argument("exr", metavar="STOKES.exr", help="EXR with Stokes channels S0.<band> ... S3.<band>")
    v.add_argument("--out", metavar="PNG", default=None, help="output PNG (default: next to the EXR)")
    v.add_argument("--panels", default="intensity,dolp", help="comma-separated panels (as for render)")
    v.set_defaults(func=cmd_view)
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
