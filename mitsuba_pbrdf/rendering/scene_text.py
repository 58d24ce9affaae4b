"""Loading a scene file's XML after rewriting it (a sensor response for a
narrow band, the ``stokes`` integrator taken out for a Stokes cube), as
``mi.load_file`` would load the file itself."""

from __future__ import annotations

import os

from .mitsuba_errors import scene_load_errors

__all__ = ["load_scene_text"]


def load_scene_text(text: str, scene_path, params=None):
    """``mi.load_string(text)`` with the scene's ``$key`` *params*, resolving
    relative paths (includes, textures) from *scene_path*'s folder; Mitsuba's
    loader errors as :func:`~.mitsuba_errors.scene_load_errors` turns them."""
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
