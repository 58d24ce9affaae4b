"""Mitsuba's loader errors and Ctrl-C in the package's terms, shared by the
scene loaders (:mod:`.render`, :mod:`.narrowband`) and the pass loop.

Mitsuba reports a scene it cannot load, and a Ctrl-C that reached Python code
it was calling (the plugin's), as ``RuntimeError``: :func:`scene_load_errors`
turns the first into :class:`SceneLoadError` (one line) and the second back
into ``KeyboardInterrupt``.
"""

from __future__ import annotations

import re
from contextlib import contextmanager

from ..interrupts import held, interrupted

__all__ = ["SceneLoadError", "interrupted", "condense", "scene_load_errors"]


class SceneLoadError(RuntimeError):
    """Mitsuba could not load the scene (its parser's message, on one line)."""


def condense(message: str) -> str:
    """Mitsuba's error message on one line; a Python traceback that a Python
    plugin's constructor raised is reduced to its last line (the exception)."""
    message = re.sub(r"Traceback \(most recent call last\):\n(?:[ \t].*\n)*", "", message)
    return " ".join(message.split())


@contextmanager
def scene_load_errors():
    """Around a Mitsuba scene loader: its ``RuntimeError`` becomes
    :class:`SceneLoadError`, or ``KeyboardInterrupt`` where it was Ctrl-C.
    SIGINT is held while Mitsuba loads (it calls the plugins' Python
    constructors from C++: :mod:`mitsuba_pbrdf.interrupts`) and delivered after."""
    with held():
        try:
            yield
        except RuntimeError as e:
            if interrupted(e):
                raise KeyboardInterrupt from e
            raise SceneLoadError(condense(str(e))) from e
