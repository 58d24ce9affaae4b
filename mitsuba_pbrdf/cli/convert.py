"""``pbrdf convert SCENE.xml [--out NEW.xml]``: a scene's ``conductor`` and
``roughconductor`` turned into ``pbrdf`` of the same material and roughness
(:func:`mitsuba_pbrdf.rendering.scene_convert.convert_scene`), written beside
it; prints one line per change and per thing left, then the files written."""

from __future__ import annotations

from .arguments import require_file
from .errors import CliError


def run(args) -> int:
    """``pbrdf convert``."""
    from ..rendering.scene_convert import convert_scene

    require_file(args.scene, "scene file")
    if args.out is not None and not args.out.strip():
        raise CliError("--out: an empty path")
    result = convert_scene(args.scene, args.out)
    for note in result.notes:
        print(note)
    for original, new in result.files.items():
        print(f"{'replaced' if new in result.replaced else 'wrote'} {new} (from {original})")
    return 0


def add_parser(subparsers):
    p = subparsers.add_parser(
        "convert", help="turn a scene's conductor/roughconductor into pbrdf, in a new file",
        description="Write a copy of a Mitsuba scene whose conductor and roughconductor "
                    "BSDFs are pbrdf of the same material and roughness (sigma = alpha / "
                    "sqrt(2), Smith shadowing, kdd = kid = 0; conductor: sigma = 0), which "
                    "renders as the original. Included files holding metals get converted "
                    "copies beside them (NAME_pbrdf.xml); no original is modified. Prints "
                    "what it changed and what it left, one line each.")
    p.add_argument("scene", metavar="SCENE.xml", help="Mitsuba scene file")
    p.add_argument("--out", default=None, metavar="NEW.xml",
                   help="the converted scene (default: SCENE_pbrdf.xml beside SCENE.xml); "
                        "never one of the files read")
    p.set_defaults(func=run)
