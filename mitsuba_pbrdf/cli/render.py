"""``pbrdf render``: a scene to a Stokes EXR and a PNG."""

from __future__ import annotations

import os
from typing import Optional

from .common import (CliError, chosen_variant, one_line, parse_defines, parse_panels, positive_int,
                     progress_options, require_file, show_progress, variant_help)


def _out_stem(out: Optional[str], scene_path: str) -> str:
    stem = os.path.splitext(os.path.basename(scene_path))[0]
    if out is None:
        return os.path.join("out", stem)
    if out.endswith(("/", os.sep)) or os.path.isdir(out):
        return os.path.join(out, stem)
    base, ext = os.path.splitext(out)
    return base if ext.lower() in (".exr", ".png") else out


def run(args) -> int:
    """``pbrdf render``."""
    from ..imaging.exr import write_stokes_exr
    from ..imaging.panels import save_overview_png
    from ..imaging.render import SceneLoadError, render_scene_timed
    from ..imaging.stokes import StokesChannelError
    from ..variant import UnknownVariantError

    require_file(args.scene, "scene file")
    params = parse_defines(args.define)
    panels = parse_panels(args.panels)
    positive_int("--spp", args.spp)
    positive_int("--passes", args.passes)
    stem = _out_stem(args.out, args.scene)
    variant = chosen_variant(args)

    try:
        image, timings = render_scene_timed(
            args.scene, spp=args.spp, variant=variant, seed=args.seed, params=params,
            passes=args.passes, progress=show_progress(args),
        )
    except UnknownVariantError as e:
        raise CliError(str(e)) from e
    except SceneLoadError as e:
        raise CliError(f"cannot load {args.scene}: {e}") from e
    except StokesChannelError as e:
        raise CliError(
            f"{one_line(e)} (render with a *_polarized variant and the scene's integrator "
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


def add_parser(subparsers):
    r = subparsers.add_parser("render", help="render a scene to <out>.exr (Stokes) and <out>.png",
                              description="Render a Mitsuba scene to a Stokes EXR and an overview PNG.")
    r.add_argument("scene", metavar="SCENE.xml", help="Mitsuba scene file")
    r.add_argument("--spp", type=int, default=None, help="samples per pixel (default: the scene's)")
    r.add_argument("--variant", default=None, help=variant_help())
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
    r.set_defaults(func=run)
