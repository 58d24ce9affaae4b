"""Arguments that several ``pbrdf`` subcommands share, checked after parsing:
files (:func:`require_file`, :func:`scene_file`), counts (:func:`positive_int`), numbers
(:func:`finite_float`, :func:`float_list`), ``-D key=value``
(:func:`parse_defines`), the outputs (:func:`check_outputs`), and the
``--variant`` and ``--progress`` options, and an option's former spelling
kept working (:class:`RenamedOption`). Each raises :class:`~.errors.CliError`
with a message that opens with the option (``--starts must be at least 1, got 0``).

They are checks after parsing rather than argparse ``type=`` callables on
purpose: argparse would report ``argument --starts: ...`` after a usage line,
and before the command's own checks in the order it wants them (the scene
file first, the outputs last)."""

from __future__ import annotations

import argparse
import math
import os
import sys
from typing import Optional

from ..errors import describe_error
from .errors import PROG, CliError

__all__ = ["parse_defines", "require_file", "scene_file", "positive_int", "float_list",
           "finite_float",
           "check_outputs", "show_progress", "progress_options", "chosen_variant",
           "variant_help", "RenamedOption", "typed_option"]


def parse_defines(items) -> dict:
    """``-D key=value`` items as a dict (values as strings)."""
    params = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise CliError(f"-D expects key=value, got {item!r}")
        params[key.strip()] = value
    return params


def require_file(path: str, what: str):
    """A :class:`CliError` unless *path* is an existing file."""
    if not path:
        raise CliError(f"{what} not found: '' (an empty path)")
    if not os.path.exists(path):
        raise CliError(f"{what} not found: {path}")
    if not os.path.isfile(path):
        raise CliError(f"{what} is not a file: {path}")


def scene_file(path: str, command: str, doing: str) -> str:
    """The scene file *path*, or the packaged scene of that name with a line
    on stderr that says so (``pbrdf render: x is not here; rendering the
    packaged scene ...``; *doing*: ``rendering``); ``FileNotFoundError``
    naming the packaged scenes when there is neither
    (:func:`mitsuba_pbrdf.rendering.scene_files.find_scene`)."""
    from ..rendering.scene_files import find_scene

    if os.path.isfile(path):
        return path
    found = str(find_scene(path))
    print(f"{PROG} {command}: {path} is not here; {doing} the packaged scene {found}",
          file=sys.stderr)
    return found


def positive_int(name: str, value: Optional[int]):
    """A :class:`CliError` unless *value* is None or at least 1."""
    if value is not None and value < 1:
        raise CliError(f"{name} must be at least 1, got {value}")


def float_list(text: str, what: str) -> list:
    """Comma-separated numbers."""
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise CliError(f"{what} expects comma-separated numbers, got {text!r}") from None
    if not values:
        raise CliError(f"{what} expects at least one number")
    return values


def show_progress(args):
    """The ``progress`` argument of the rendering functions: ``"bar"`` with
    ``--progress``, ``"off"`` with ``--no-progress``, else ``"auto"`` (a bar
    when stderr is a terminal, a line every few seconds of long work otherwise;
    :mod:`mitsuba_pbrdf.rendering.progress`)."""
    if args.progress is None:
        return "auto"
    return "bar" if args.progress else "off"


def finite_float(name: str, value: Optional[float], low: Optional[float] = None,
                 high: Optional[float] = None, low_open: bool = False):
    """A :class:`CliError` unless *value* is None or a finite number in range."""
    if value is None:
        return
    bad = not math.isfinite(value) or (low is not None and (value <= low if low_open
                                                            else value < low)) \
        or (high is not None and value > high)
    if bad:
        rng = ""
        if low is not None and high is not None:
            rng = f" in {'(' if low_open else '['}{low:g}, {high:g}]"
        elif low is not None:
            rng = f" {'>' if low_open else '>='} {low:g}"
        raise CliError(f"{name} must be a finite number{rng}, got {value:g}")


def check_outputs(*outputs, inputs=(), create_folders: bool = True):
    """Before any work, the one rule of every command's outputs: each has a
    format its writer gives and is a file of its own, neither one of *inputs*
    nor another output (:func:`mitsuba_pbrdf.outputs.check_plan`), and can be
    written (:func:`mitsuba_pbrdf.outputs.check_writable`). *outputs* are
    paths, ``(option, path)`` or ``(option, path, formats)`` (extensions
    without the dot; the option opens the message); *inputs* are ``(name,
    path)`` pairs (``FILE``, ``--nk``); None paths are skipped. With
    ``create_folders=False`` the output's folder must exist. Raises
    :class:`CliError`."""
    from ..outputs import OutputPlanError, check_plan, check_writable

    items = [(None,) + (item,) if not isinstance(item, tuple) else item for item in outputs]
    items = [(option, path, item_formats[0] if item_formats else None)
             for option, path, *item_formats in items]
    try:
        check_plan([(option or "output", path, formats) for option, path, formats in items],
                   inputs=inputs)
    except OutputPlanError as e:
        raise CliError(str(e)) from None
    for option, path, _ in items:
        if path is None:
            continue
        prefix = f"{option}: " if option else ""
        folder = os.path.dirname(os.path.abspath(path))
        if not create_folders and not os.path.isdir(folder):
            raise CliError(f"{prefix}folder {folder} does not exist")
        try:
            check_writable(path)
        except OSError as e:
            raise CliError(prefix + describe_error(e)) from None


def chosen_variant(args) -> str:
    """``--variant``, else the default (CUDA if usable, else LLVM)."""
    from ..variant import default_variant

    return args.variant or default_variant()


def variant_help() -> str:
    from ..variant import DEFAULT_VARIANT, GPU_VARIANT

    return (f"Mitsuba variant (default: {GPU_VARIANT} if a CUDA GPU is usable, "
            f"else {DEFAULT_VARIANT})")


def progress_options(parser):
    """``--progress`` / ``--no-progress``."""
    g = parser.add_mutually_exclusive_group()
    g.add_argument("--progress", dest="progress", action="store_true", default=None,
                   help="show the progress bar even when stderr is not a terminal (default: a "
                        "bar on a terminal, else a line every 10 s of long renders)")
    g.add_argument("--no-progress", dest="progress", action="store_false",
                   help="never show progress")


class RenamedOption(argparse.Action):
    """An option whose former spelling still works:
    ``add_argument("--new", "--old", action=RenamedOption)``. The former
    spelling (any after the first) prints one warning line naming the new
    one; the spelling typed is kept (:func:`typed_option`), so that errors
    and warnings name what the user typed."""

    def __call__(self, parser, namespace, values, option_string=None):
        setattr(namespace, self.dest, values)
        setattr(namespace, f"_{self.dest}_typed", option_string)
        if option_string != self.option_strings[0]:
            print(f"{parser.prog}: warning: {option_string} is deprecated, use "
                  f"{self.option_strings[0]}", file=sys.stderr)


def typed_option(args, dest: str, option: str) -> str:
    """The spelling of option *dest* the user typed (:class:`RenamedOption`), else *option*."""
    return getattr(args, f"_{dest}_typed", None) or option
