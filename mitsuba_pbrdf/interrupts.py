"""Ctrl-C at any instant: SIGINT is *held* (recorded, not raised) while
Python code runs inside Mitsuba, Dr.Jit or an extension's import, and
delivered as ``KeyboardInterrupt`` at the next clean point.

A ``KeyboardInterrupt`` raised in the middle of ``import mitsuba``, of
``mi.set_variant`` (whose callbacks Mitsuba calls from C++) or of a scene
load (which runs the plugins' Python constructors from C++) does not come back
as a ``KeyboardInterrupt``: depending on the instant it is swallowed (the
command then runs on and replaces its output), becomes a ``SystemError``, a
half-imported module (``AttributeError: Module 'mitsuba' has no attribute
...``) or an abort (``terminate called after throwing nanobind::python_error``).
So these phases run under :func:`held`, and the command line holds SIGINT
from the package's import until its command releases it where long work
starts (:func:`release`: the render's passes, a fit, a recovery's
iterations), so a Ctrl-C at any instant ends as ``pbrdf COMMAND:
interrupted``, exit status 130.

Where Dr.Jit or Mitsuba wrapped a ``KeyboardInterrupt`` raised in Python code
they were calling (``dr.while_loop``, ``drjit.custom``, a plugin), the
``RuntimeError`` they raise is recognised by :func:`interrupted`.

An output is never replaced while an interrupt is pending
(:func:`mitsuba_pbrdf.outputs.atomic_path` calls :func:`before_replace`), and
outputs that belong together are replaced together, after the last is
written, or not at all (:func:`mitsuba_pbrdf.outputs.together`).

Once the command's outcome is decided (:func:`settle`: its outputs written
together, or its error or interruption being reported), the command line
ignores SIGINT to the end of the process, so that a late Ctrl-C during the
interpreter's shutdown changes neither the outputs nor the exit status.

Signal handlers belong to the main thread: elsewhere (Dask workers' threads)
every function here does nothing. A SIGINT that Python ignores (``SIG_IGN``,
e.g. a background job) stays ignored. Standard library only.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
from contextlib import contextmanager

__all__ = ["hold", "release", "held", "pending", "discard", "is_held", "before_replace", "interrupted",
           "hold_for_command_line", "is_command_line", "settle"]

_state = {"held": False, "previous": None, "pending": False, "command_line": False}

#: The names the command line runs under (console scripts, ``python -m``).
_COMMANDS = ("pbrdf", "pbrdf-fit")


def _main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


def _record(signum, frame):
    _state["pending"] = True


def hold():
    """From now on a SIGINT is recorded instead of raised, until :func:`release`
    (idempotent)."""
    if _state["held"] or not _main_thread():
        return
    current = signal.getsignal(signal.SIGINT)
    if current in (signal.SIG_IGN, None):
        return
    _state["previous"] = current
    signal.signal(signal.SIGINT, _record)
    _state["held"] = True


def release():
    """Restore SIGINT's handler and deliver a SIGINT that came while it was
    held (``KeyboardInterrupt`` raised here, with Python's handler)."""
    if not _state["held"] or not _main_thread():
        return
    previous = _state["previous"]
    signal.signal(signal.SIGINT, previous)
    _state["held"] = False
    if _state["pending"]:
        _state["pending"] = False
        if previous is signal.default_int_handler:
            raise KeyboardInterrupt
        signal.raise_signal(signal.SIGINT)


def discard():
    """Forget a SIGINT that came while held (the work it would have stopped is done)."""
    _state["pending"] = False


def pending() -> bool:
    """Whether a SIGINT came while held and is not yet delivered."""
    return _state["pending"]


def is_held() -> bool:
    """Whether SIGINT is held now."""
    return _state["held"]


def before_replace():
    """Called before an output replaces a file
    (:mod:`mitsuba_pbrdf.outputs`): ``KeyboardInterrupt`` if a SIGINT came
    while held, so that an interrupted command replaces nothing."""
    if _state["pending"]:
        _state["pending"] = False
        raise KeyboardInterrupt


@contextmanager
def held():
    """SIGINT held inside (see the module docstring); a SIGINT that came is
    delivered on leaving, unless an outer hold is still on."""
    outer = _state["held"]
    hold()
    try:
        yield
    finally:
        if not outer:
            release()


def hold_for_command_line() -> bool:
    """Hold SIGINT when this process is the ``pbrdf`` command line (the
    console scripts, or ``python -m mitsuba_pbrdf``), so that the package's
    import (Mitsuba's, Dr.Jit's) happens held; the command releases it
    (:func:`mitsuba_pbrdf.cli.errors.run_command`). Returns whether it holds."""
    argv = list(getattr(sys, "orig_argv", None) or sys.argv)
    by_module = any(a == "-m" and b in ("mitsuba_pbrdf", "mitsuba_pbrdf.cli")
                    for a, b in zip(argv, argv[1:]))
    script = bool(sys.argv) and os.path.basename(sys.argv[0]) in _COMMANDS
    if by_module or script:
        hold()
        _state["command_line"] = _state["held"]
        return _state["held"]
    return False


def is_command_line() -> bool:
    """Whether this process is the ``pbrdf`` command line and holds SIGINT
    for it (:func:`hold_for_command_line`)."""
    return _state["command_line"]


def settle():
    """The command's outcome is decided (its outputs are written, or its error
    or interruption is being reported). On the command line a SIGINT from now
    on is ignored (``SIG_IGN``), to the end of the process: the interpreter's
    shutdown (Dr.Jit's and Mitsuba's, a second or more on a busy machine)
    restores the default action for a Python handler, and a SIGINT then would
    kill a command that has finished, with the shell's status 130 and its new
    outputs in place. Elsewhere (a Python session): :func:`release`, a SIGINT
    that came meanwhile forgotten. Idempotent.

    Also clears CPython's record of an unhandled Ctrl-C: a
    ``KeyboardInterrupt`` that passed through an ``exec`` of a string (SciPy's
    array-API shim imports NumPy that way) sets it even when the exception is
    caught later, and under ``python -m`` the interpreter then kills itself
    with SIGINT after its shutdown (status -2 to a parent, where the command
    reported ``interrupted`` and returned 130). Running any code string
    resets it."""
    _state["pending"] = False
    exec("pass", {})
    if _state["command_line"] and _main_thread():
        if signal.getsignal(signal.SIGINT) is not signal.SIG_IGN:
            signal.signal(signal.SIGINT, signal.SIG_IGN)
        _state["held"] = False
        return
    release()


def interrupted(error: BaseException) -> bool:
    """Whether *error* is Ctrl-C that Mitsuba or Dr.Jit wrapped (it was raised
    inside Python code they were calling: a plugin, a ``dr.while_loop`` body,
    a ``drjit.custom`` operation)."""
    seen = set()
    while error is not None and id(error) not in seen:
        if isinstance(error, KeyboardInterrupt) or "KeyboardInterrupt" in str(error):
            return True
        seen.add(id(error))
        error = error.__cause__ or error.__context__
    return False
