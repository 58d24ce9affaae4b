"""Loading scenes: :func:`load_scene` (a scene file as it is), and Mitsuba's
loader errors and Ctrl-C in the package's terms, shared by the scene loader of
the render modes (:mod:`.scene_setup`: a scene made ready for a Stokes render)
and the pass loop.

Mitsuba reports a scene it cannot load, and a Ctrl-C that reached Python code
it was calling (the plugin's), as ``RuntimeError``: :func:`scene_load_errors`
turns the first into :class:`SceneLoadError` (one line) and the second back
into ``KeyboardInterrupt``.
"""

from __future__ import annotations

import os
import re
from contextlib import contextmanager
from typing import Mapping, Optional

from ..interrupts import held, interrupted

__all__ = ["SceneLoadError", "interrupted", "condense", "scene_load_errors", "load_scene",
           "require_scene_file"]


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


def load_scene(scene_path, params: Optional[Mapping[str, object]] = None):
    """``mi.load_file(scene_path, **params)`` (the variant must be set).
    *params* override the scene's ``<default name="key" .../>`` values; Mitsuba
    rejects keys the scene does not use. Raises ``FileNotFoundError`` or
    :class:`SceneLoadError` (with Mitsuba's message, e.g. the XML parse error)."""
    import mitsuba as mi

    scene_path = require_scene_file(scene_path)
    kwargs = {str(k): str(v) for k, v in (params or {}).items()}
    with scene_load_errors():
        return mi.load_file(scene_path, **kwargs)


def require_scene_file(scene_path) -> str:
    """*scene_path* as a string; ``FileNotFoundError`` unless it is a file."""
    scene_path = os.fspath(scene_path)
    if not os.path.isfile(scene_path):
        raise FileNotFoundError(f"{scene_path}: no such file")
    return scene_path
