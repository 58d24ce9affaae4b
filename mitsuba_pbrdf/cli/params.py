"""``pbrdf params SCENE.xml``: the parameters a scene takes as ``-D key=value``,
each with its ``<default>`` value and what it sets (for a property of a
``pbrdf`` BSDF, the model parameter's doc line from :mod:`mitsuba_pbrdf.schema`;
:func:`mitsuba_pbrdf.rendering.scene_params.scene_parameters`)."""

from __future__ import annotations

import os
import textwrap

from .arguments import scene_file
from .errors import CliError


def format_parameters(scene: str, parameters, width: int = 100) -> str:
    """The listing ``pbrdf params`` prints."""
    count = len(parameters)
    lines = [f"{scene}: {count} parameter{'s' if count != 1 else ''} "
             f"(pbrdf render {scene} -D key=value ...)" if parameters
             else f"{scene} takes no -D parameters"]
    name_width = max([len(p.name) for p in parameters], default=0)
    value_width = min(max([len(p.default or "(none)") for p in parameters], default=0), 20)
    for p in parameters:
        value = p.default if p.default is not None else "(none)"
        head = f"  {p.name:<{name_width}}  {value:<{value_width}}  "
        text = p.doc() + ("" if p.default is not None else " (no default: -D must give it)")
        lines.append(textwrap.fill(text, width=max(width, len(head) + 30), initial_indent=head,
                                   subsequent_indent=" " * len(head)))
    if not any(p.name == "spp" for p in parameters):
        lines.append("  (no spp parameter: set the samples per pixel with pbrdf render --spp N)")
    return "\n".join(lines)


def run(args) -> int:
    """``pbrdf params``."""
    from ..rendering.scene_params import scene_parameters

    if os.path.isdir(args.scene):
        raise CliError(f"{args.scene} is a folder, not a scene file")
    scene = scene_file(args.scene, "params", "listing")
    print(format_parameters(args.scene, scene_parameters(scene)))
    return 0


def add_parser(subparsers):
    p = subparsers.add_parser(
        "params", help="list a scene's -D parameters, their defaults and what they set",
        description="List the parameters a scene takes as -D key=value (pbrdf render, "
                    "render_scene(params=...), a sweep's [params]): each <default> with its "
                    "value and what it sets; for the pbrdf BSDF's properties, the model "
                    "parameter's doc line.")
    p.add_argument("scene", metavar="SCENE.xml", help="Mitsuba scene file, or a packaged scene")
    p.set_defaults(func=run)
