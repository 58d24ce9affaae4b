"""What every ``pbrdf`` subcommand shares: the one error path (:func:`run_command`:
one line, exit status 2; Ctrl-C: ``interrupted``, exit status 130), argument
checks, output checks, the progress and variant options.

Every command, present and future, reports through :func:`run_command`:

* :class:`CliError`, ``OSError`` (``cannot write PATH: REASON``), ``ValueError``
  (bad values, unusable files), ``RuntimeError`` and ``MemoryError`` (Mitsuba,
  Dr.Jit): ``pbrdf COMMAND: error: MESSAGE`` on one line, exit status 2; the
  library's errors name its parameters (:class:`mitsuba_pbrdf.errors.ParameterError`),
  and where the command has that parameter as an option the message names the
  option instead (``--wavelength: ...``);
* ``KeyboardInterrupt`` (Ctrl-C, SIGINT): ``pbrdf COMMAND: interrupted``, exit
  status 130 (128 + SIGINT, as shells report it). Outputs are written
  atomically (:mod:`mitsuba_pbrdf.outputs`), so nothing partial is left;
* anything else is a bug: ``pbrdf COMMAND: internal error: ...``, exit status 1.

``PBRDF_TRACEBACK=1`` in the environment shows Python's traceback instead.
"""

from __future__ import annotations

import math
import os
import sys
from typing import Optional

from ..errors import ParameterError, describe_error, one_line
from ..interrupts import discard, hold, interrupted, pending, release, settle

PROG = "pbrdf"
EXIT_ERROR = 2
EXIT_INTERNAL = 1
#: 128 + SIGINT, what a shell reports for a command stopped by Ctrl-C.
EXIT_INTERRUPTED = 130
#: Set to 1 to get Python's traceback instead of the one-line error.
TRACEBACK_VARIABLE = "PBRDF_TRACEBACK"


class CliError(Exception):
    """An error reported to the user as one line, exit status 2."""


def option_message(error: BaseException, args) -> str:
    """The one-line message of *error* in the command line's terms: a
    :class:`~mitsuba_pbrdf.errors.ParameterError` of a parameter that the
    command has as an option (``wavelength`` -> ``--wavelength``) names the option."""
    if isinstance(error, ParameterError) and hasattr(args, error.parameter):
        return f"--{error.parameter.replace('_', '-')}: {one_line(error.detail)}"
    return describe_error(error)


def run_command(func, args, command: str) -> int:
    """Run ``func(args)`` with the command line's one error path (see the module
    docstring); returns the exit status."""
    if os.environ.get(TRACEBACK_VARIABLE, "") not in ("", "0"):
        release()
        return func(args)
    prefix = f"{PROG} {command}"
    try:
        # SIGINT is held from the package's import (mitsuba_pbrdf.interrupts)
        # until the command's long work starts
        try:
            status = func(args)
        except BaseException:
            hold()               # the outcome is decided: a SIGINT from now on is recorded
            if pending():        # one that came while held wins over the error
                discard()
                raise KeyboardInterrupt from None
            raise
        settle()                 # done: every output is written, a late SIGINT changes nothing
        return status
    except KeyboardInterrupt:
        settle()
        sys.stdout.flush()
        print(f"{prefix}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except (CliError, OSError, ValueError, RuntimeError, MemoryError) as e:
        settle()
        if interrupted(e):  # Ctrl-C that Dr.Jit or Mitsuba wrapped (dr.while_loop ...)
            sys.stdout.flush()
            print(f"{prefix}: interrupted", file=sys.stderr)
            return EXIT_INTERRUPTED
        print(f"{prefix}: error: {option_message(e, args)}", file=sys.stderr)
        return EXIT_ERROR
    except Exception as e:  # a bug: still one line, and how to see more
        settle()
        print(f"{prefix}: internal error: {type(e).__name__}: {describe_error(e)} "
              f"(set {TRACEBACK_VARIABLE}=1 for the traceback)", file=sys.stderr)
        return EXIT_INTERNAL
    finally:
        settle()  # also for SystemExit and the like, which pass through


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
    from ..visualization.panels import parse_panels as parse

    try:
        return parse(text)
    except ValueError as e:
        raise CliError(f"--panels: {e}") from e


def require_file(path: str, what: str):
    """A :class:`CliError` unless *path* is an existing file."""
    if not path:
        raise CliError(f"{what} not found: '' (an empty path)")
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


def scale_value(name: str, text: str):
    """A picture scale option: ``auto`` or a finite number > 0 (as a float)."""
    if text is None or text.strip().lower() == "auto":
        return "auto"
    try:
        value = float(text)
    except ValueError:
        raise CliError(f"{name} must be a number > 0 or 'auto', got {text!r}") from None
    finite_float(name, value, low=0.0, low_open=True)
    return value


def check_outputs(*outputs, create_folders: bool = True):
    """Before any long work: each output can be written
    (:func:`mitsuba_pbrdf.outputs.check_writable`). *outputs* are paths or
    ``(option, path)`` pairs (the option then opens the message); None is
    skipped. With ``create_folders=False`` the output's folder must exist.
    Raises :class:`CliError`."""
    from ..outputs import check_writable

    for item in outputs:
        option, path = item if isinstance(item, tuple) else (None, item)
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


def picture_options(parser, panels_default: str):
    """The options of the Stokes pictures that ``render`` and ``view`` draw
    (defaults: :data:`~mitsuba_pbrdf.visualization.defaults.PICTURE_DEFAULTS`, as in Python)."""
    from ..visualization.defaults import PICTURE_DEFAULTS as D

    parser.add_argument("--panels", default=panels_default,
                        help="comma-separated panels: intensity, dolp, aolp, docp, hsv, s1, s2, "
                             f"s3, or 'all' (the 2 x 4 sheet) (default: {panels_default})")
    parser.add_argument("--band", default=None,
                        help="draw one band (e.g. R, or a wavelength band's name) instead of the "
                             "luminance combination of the bands")
    parser.add_argument("--dolp-max", default=D["dolp_max"], metavar="X|auto",
                        help="top of the DoLP scale (and of the saturation of the hsv panel); "
                             "auto: the image's 99.5th percentile rounded up "
                             f"(default: {D['dolp_max']})")
    parser.add_argument("--dolp-cmap", default=D["dolp_cmap"], choices=["viridis", "gray"],
                        help=f"colour map of the DoLP panel (default: {D['dolp_cmap']})")
    parser.add_argument("--min-dolp", type=float, default=D["min_dolp"],
                        help=f"AoLP is grey where DoLP is below this (default: {D['min_dolp']})")
    parser.add_argument("--stokes-scale", default=D["stokes_scale"],
                        choices=["shared", "separate"],
                        help="one symmetric scale for S1/S0, S2/S0, S3/S0, or one each "
                             f"(default: {D['stokes_scale']})")
    parser.add_argument("--exposure", type=float, default=D["exposure"], metavar="EV",
                        help="intensity exposure in stops (default: automatic)")


def picture_kwargs(args, image=None) -> dict:
    """Checked keyword arguments of :func:`~mitsuba_pbrdf.visualization.panels.save_overview_png`
    from the picture options (and *image*'s bands, for ``--band``)."""
    panels = parse_panels(args.panels)
    finite_float("--min-dolp", args.min_dolp, 0.0, 1.0)
    finite_float("--exposure", args.exposure)
    options = dict(panels=panels, band=args.band, dolp_cmap=args.dolp_cmap,
                   dolp_max=scale_value("--dolp-max", args.dolp_max), min_dolp=args.min_dolp,
                   stokes_scale=args.stokes_scale)
    if args.exposure is not None:
        options["exposure"] = 2.0 ** args.exposure
    if image is not None and args.band is not None and args.band not in image.bands:
        raise CliError(f"no band {args.band!r}; bands are {', '.join(image.bands)}")
    return options


def report_quality(image, band, source: str, command: str, bands=None):
    """Warn (one line on stderr) about unusable pixels of *image*; a
    :class:`CliError` when none is usable in *band* (None: the luminance
    vector) or in any of *bands* (:func:`~mitsuba_pbrdf.stokes.quality.require_usable`).
    Returns the assessment of *band*."""
    from ..stokes.quality import UnusableImageError, require_usable

    try:
        quality = require_usable(image, source, bands=bands, band=band)
    except UnusableImageError as e:
        raise CliError(str(e)) from None
    if quality.count:
        print(f"{PROG} {command}: warning: {source}: {quality.summary()}; marked in the "
              "picture (see its legend)", file=sys.stderr)
    elif quality.black:
        print(f"{PROG} {command}: warning: {source}: the image is black (S0 = 0 everywhere)",
              file=sys.stderr)
    return quality


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
