"""Command line: ``pbrdf`` (or ``python -m mitsuba_pbrdf``).

::

    pbrdf render SCENE.xml [--spp N] [--variant V] [--seed S] [--passes N] [--out DIR_OR_STEM]
                           [-D key=value ...] [--panels P,...] [--no-progress]
    pbrdf params SCENE.xml
    pbrdf convert SCENE.xml [--out NEW.xml]
    pbrdf view STOKES.exr [--out PNG] [--panels all|P,...] [--band B] [--dolp-cmap gray]
                          [--dolp-limit X] [--min-dolp X] [--exposure EV]
    pbrdf polcam STOKES.exr --out DIR [--sensor mono|colour] [--band B] [--exposure X]
                 [--full-well E] [--read-noise E] [--bits N] [--seed S]
    pbrdf plot [--material M | --eta N --k K] [--sigma S] [--ks W] [--kdd W] [--sigma-dd S]
               [--kid W] [--shadowing vgroove|smith] [--dd-distribution beckmann|ggx]
               [--theta-i DEG] [--wavelengths NM,...] [--out PNG]
    pbrdf gallery [--out DIR] [--only ITEM,...] [--spp N] [--scale F] [--variant V]
    pbrdf fit DATA.csv|TABLE.pbsdf [--material M] [--model three|two|both] [--backend reference|drjit] ...
    pbrdf export --out FILE.pbsdf [--material M | --eta N --k K] [--sigma S] ... [--grid default|kaist|PxDxH]
    pbrdf batch SWEEP.toml [--workers N | --scheduler ADDRESS] [--drjit-threads N]
    pbrdf recover-normals SCENE.xml --targets EXR... --out DIR [--observables intensity|stokes|polcam]
                          [--parametrization normals|height] [--smoothness W] [--iterations N]
                          [--spp N] [--fit-roughness] [--truth NORMALS.exr]

``render`` writes ``<out>.exr`` (the Stokes image, named float32 channels
``R, G, B, S0.R ... S3.B``) and ``<out>.png`` (by default intensity and DoLP
side by side); ``<out>`` defaults to ``out/<scene stem>``. ``-D key=value``
overrides the scene's ``<default name="key" value="..."/>``. The variant
defaults to ``cuda_ad_spectral_polarized`` where a CUDA GPU is usable, else
``llvm_ad_spectral_polarized``. Long renders run in sample passes with a
progress bar. ``convert`` writes a copy of a scene whose ``conductor`` and
``roughconductor`` are ``pbrdf`` (:mod:`mitsuba_pbrdf.rendering.scene_convert`).
``view`` draws the Stokes sheet of an EXR; ``polcam`` computes a
polarization camera's four polarizer images and raw mosaic of one; ``plot`` draws the
model's pBRDF with the NumPy reference evaluator (no variant needed);
``gallery`` renders ``scenes/gallery`` and draws README's pictures; ``fit``
fits the model to measurements (CSV) or a ``.pbsdf`` table; ``export``
tabulates the model into a ``.pbsdf`` table for ``measured_polarized``;
``batch`` renders a sweep file's parameter grid on Dask (``docs/batch.md``);
``recover-normals`` fits a ``polarized_normalmap``'s normals to target images
(``docs/inverse-rendering.md``).
Errors (missing file, bad scene, unknown variant, bad parameter, unwritable
output) print one line and exit with status 2; Ctrl-C prints ``interrupted``
and exits with status 130, leaving no partial file (:mod:`.errors`).

One module per subcommand (``run(args)`` and ``add_parser(subparsers)``), each a
thin layer over functions users can call from Python; what they share is the
error path (:mod:`.errors`), the shared arguments' checks (:mod:`.arguments`) and
the picture options of ``render`` and ``view`` (:mod:`.pictures`).
"""

from __future__ import annotations

import argparse
import sys
from typing import List, Optional

from . import (batch, convert, export, fit, gallery, params, plot, polcam, recover_normals, render,
               view)
from ..numbers import check_int_option
from .errors import PROG, CliError, run_command

#: The subcommands, in the order ``pbrdf --help`` lists them.
COMMANDS = (render, params, convert, view, polcam, plot, gallery, fit, export, batch,
            recover_normals)


def version_text() -> str:
    """``pbrdf --version``: this package's version and the Mitsuba it finds
    (read from the installed distribution, without importing Mitsuba)."""
    from importlib import metadata

    from .. import __version__

    try:
        mitsuba = f"Mitsuba {metadata.version('mitsuba')}"
    except metadata.PackageNotFoundError:
        mitsuba = "Mitsuba not installed"
    return f"{PROG} {__version__} ({mitsuba}, Python {sys.version.split()[0]})"


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``pbrdf`` command."""
    parser = argparse.ArgumentParser(
        prog=PROG,
        description="Render, look at, plot and fit polarized BRDFs with the pbrdf Mitsuba plugin.",
    )
    parser.add_argument("--version", action="version", version=version_text())
    subparsers = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for command in COMMANDS:
        command.add_parser(subparsers)
    return parser


def _bounded_integers(func, parser, command):
    """``func`` preceded by the bounds of every integer option of *command*
    (:func:`mitsuba_pbrdf.numbers.check_int_option`: 2^63 - 1 samples,
    workers or starts never reach the work)."""
    sub = next(a for a in parser._actions
               if isinstance(a, argparse._SubParsersAction)).choices[command]
    integers = [a for a in sub._actions if a.type is int]

    def run(args):
        for action in integers:
            name = action.option_strings[-1] if action.option_strings else action.dest
            try:
                check_int_option(name, action.dest, getattr(args, action.dest, None))
            except ValueError as e:
                raise CliError(str(e)) from None
        return func(args)

    return run


def main(argv: Optional[List[str]] = None) -> int:
    """Run the command line; returns the exit status: 0, 2 on error
    (:func:`~.errors.run_command`), 130 when interrupted (Ctrl-C). Usage
    errors found by argparse exit through ``SystemExit(2)`` as usual, with the
    subcommand's usage (also for an option no parser knows: ``render --varient``)."""
    parser = build_parser()
    args, unknown = parser.parse_known_args(argv)
    if unknown:  # argparse would print the top-level usage; the subcommand's helps more
        subcommand_parser(parser, args.command).error(unrecognized_message(
            subcommand_parser(parser, args.command), unknown))
    return run_command(_bounded_integers(args.func, parser, args.command), args, args.command)


def subcommand_parser(parser: argparse.ArgumentParser, name: str) -> argparse.ArgumentParser:
    """The parser of subcommand *name* (for its usage line in errors)."""
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return sub.choices[name]


def unrecognized_message(parser: argparse.ArgumentParser, unknown: List[str]) -> str:
    """``unrecognized arguments: --varient x (did you mean --variant?)``."""
    import difflib

    options = [s for a in parser._actions for s in a.option_strings if s.startswith("--")]
    guesses = [difflib.get_close_matches(w.split("=")[0], options, n=1)
               for w in unknown if w.startswith("--")]
    hints = [g[0] for g in guesses if g]
    return (f"unrecognized arguments: {' '.join(unknown)}"
            + (f" (did you mean {', '.join(hints)}?)" if hints else ""))


if __name__ == "__main__":
    sys.exit(main())
