"""The one error path of every ``pbrdf`` subcommand (:func:`run_command`:
one line, exit status 2; Ctrl-C: ``interrupted``, exit status 130).

Every command, present and future, reports through :func:`run_command`:

* :class:`CliError`, ``OSError`` (``cannot write PATH: REASON``), ``ValueError``
  (bad values, unusable files), ``RuntimeError`` and ``MemoryError`` (Mitsuba,
  Dr.Jit): ``pbrdf COMMAND: error: MESSAGE`` on one line, exit status 2; the
  library's errors name its parameters (:class:`mitsuba_pbrdf.errors.ParameterError`),
  and where the command has that parameter as an option the message names the
  option instead (``--wavelength: ...``);
* ``KeyboardInterrupt`` (Ctrl-C, SIGINT), also one that a library wrapped in
  another exception: ``pbrdf COMMAND: interrupted``, exit
  status 130 (128 + SIGINT, as shells report it). Outputs are written
  atomically (:mod:`mitsuba_pbrdf.outputs`), so nothing partial is left;
* anything else is a bug: ``pbrdf COMMAND: internal error: ...``, exit status 1.

``PBRDF_TRACEBACK=1`` in the environment shows Python's traceback instead.
"""

from __future__ import annotations

import os
import sys

from ..errors import ParameterError, describe_error, one_line
from ..interrupts import discard, hold, interrupted, pending, release, settle

__all__ = ["PROG", "EXIT_ERROR", "EXIT_INTERNAL", "EXIT_INTERRUPTED", "TRACEBACK_VARIABLE",
           "CliError", "option_message", "run_command"]

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
        pass
    except Exception as e:
        # Ctrl-C that Dr.Jit or Mitsuba wrapped (dr.while_loop, a plugin) or an
        # extension's import did (pybind11's "ImportError: initialization failed")
        # is an interruption; anything else is reported here
        if not interrupted(e):
            settle()
            if isinstance(e, (CliError, OSError, ValueError, RuntimeError, MemoryError)):
                print(f"{prefix}: error: {option_message(e, args)}", file=sys.stderr)
                return EXIT_ERROR
            # a bug: still one line, and how to see more
            print(f"{prefix}: internal error: {type(e).__name__}: {describe_error(e)} "
                  f"(set {TRACEBACK_VARIABLE}=1 for the traceback)", file=sys.stderr)
            return EXIT_INTERNAL
    finally:
        settle()  # also for SystemExit and the like, which pass through
    sys.stdout.flush()
    print(f"{prefix}: interrupted", file=sys.stderr)
    return EXIT_INTERRUPTED
