"""What every ``pbrdf`` subcommand shares: the one error type (one line, exit
status 2), argument checks, the progress and variant options."""

from __future__ import annotations

import os
import sys
from typing import Optional

PROG = "pbrdf"
EXIT_ERROR = 2


class CliError(Exception):
    """An error reported to the user as one line, exit status 2."""


def one_line(message) -> str:
    """A message (an exception's, possibly over several lines) on one line."""
    return " ".join(str(message).split())


def parse_defines(items) -> dict:
    """``-D key=value`` items as a dict (values as strings)."""
    params = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise CliError(f"-D expects key=value, got {item!r}")
        params[key.strip()] = value
    return params


def parse_panels(text: str):
    """``--panels`` as panel names, or a :class:`CliError` naming unknown ones."""
    from ..imaging.panels import parse_panels as parse

    try:
        return parse(text)
    except ValueError as e:
        raise CliError(str(e)) from e


def require_file(path: str, what: str):
    """A :class:`CliError` unless *path* is an existing file."""
    if not os.path.exists(path):
        raise CliError(f"{what} not found: {path}")
    if not os.path.isfile(path):
        raise CliError(f"{what} is not a file: {path}")


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


def show_progress(args) -> bool:
    """Progress bars go to stderr, only when it is a terminal (unless --progress)."""
    if args.progress is not None:
        return args.progress
    return sys.stderr.isatty()


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
                   help="show the progress bar even when stderr is not a terminal")
    g.add_argument("--no-progress", dest="progress", action="store_false",
                   help="never show the progress bar")
