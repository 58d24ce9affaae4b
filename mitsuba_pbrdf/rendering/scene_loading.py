"""Loading scenes: :func:`load_scene` (a scene file as it is), Mitsuba's loader
errors and Ctrl-C in the package's terms, shared by the scene loaders (of the
render modes, :mod:`.modes`, :mod:`.narrowband`, :mod:`.cube`) and the pass
loop, and :func:`load_scene_text`, a scene file's XML loaded after rewriting it (a sensor response for a narrow band, the
``stokes`` integrator taken out for a Stokes cube) as ``mi.load_file`` would
load the file itself.

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
           "load_scene_text"]


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


def load_scene_text(text: str, scene_path, params=None):
    """``mi.load_string(text)`` with the scene's ``$key`` *params*, resolving
    relative paths (includes, textures) from *scene_path*'s folder; Mitsuba's
    loader errors as :func:`scene_load_errors` turns them."""
    import mitsuba as mi

    resolver = mi.file_resolver()
    saved = [resolver[i] for i in range(len(resolver))]
    resolver.prepend(os.path.dirname(os.path.abspath(os.fspath(scene_path))))
    try:
        with scene_load_errors():
            return mi.load_string(text, **{str(k): str(v) for k, v in (params or {}).items()})
    finally:
        resolver.clear()
        for p in saved:
            resolver.append(p)
