"""Errors in the package's own terms and their one-line description.

The library names what was wrong by its *parameter* (``wavelength``, ``spp``,
``grid``): :class:`ParameterError`. The command line, where it catches one,
names the option instead (``--wavelength``; :func:`mitsuba_pbrdf.cli.errors.run_command`).
:func:`describe_error` is the one-line text of any error, shared by the command
line and by ``pbrdf batch`` (whose workers report failures without raising);
both sit above this module, and it imports neither.
"""

from __future__ import annotations

__all__ = ["ParameterError", "one_line", "describe_error"]


class ParameterError(ValueError):
    """A bad value of the named parameter of a library function; the message is
    ``"<parameter>: <detail>"``."""

    def __init__(self, parameter: str, detail: str):
        super().__init__(f"{parameter}: {detail}")
        self.parameter = parameter
        self.detail = detail


def one_line(message) -> str:
    """A message (an exception's, possibly over several lines) on one line."""
    return " ".join(str(message).split())


def describe_error(error: BaseException) -> str:
    """The one-line message of an error: ``cannot write PATH: REASON`` for an
    output (:class:`mitsuba_pbrdf.outputs.OutputError`), ``PATH: REASON`` for
    other ``OSError`` s naming a file, else the message; a file name's line
    breaks and control characters escaped (:func:`mitsuba_pbrdf.outputs.escape_text`),
    so it stays one line on a terminal."""
    from .outputs import OutputError, escape_text

    if isinstance(error, OSError) and error.filename is not None:
        reason = error.strerror or one_line(error)
        path = escape_text(error.filename, "line")
        if isinstance(error, OutputError):
            return f"cannot write {path}: {reason}"
        return f"{path}: {reason}"
    return escape_text(one_line(error), "line") or type(error).__name__
