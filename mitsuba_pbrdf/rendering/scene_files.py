"""The example scenes that ship with the package, and finding them by name.

The repository keeps its scenes in the top-level ``scenes/`` folder; an
installed package carries the same files as package data in
``mitsuba_pbrdf/scenes/`` (``setup.py`` maps the folder, so there is one copy
in the repository). :func:`scenes_dir` finds whichever is there, so commands
work from any directory::

    find_scene("scenes/default.xml")     # that file if it exists, else the packaged one
    find_scene("gallery/sphere")         # the packaged scenes/gallery/sphere.xml
    packaged_scenes()                    # ['analytic_plane.xml', 'default.xml', 'gallery/...']
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import List, Optional

__all__ = ["scenes_dir", "packaged_scenes", "packaged_scene", "find_scene"]

_PACKAGE = Path(__file__).resolve().parents[1]


def scenes_dir() -> Path:
    """The folder of the packaged scenes: ``mitsuba_pbrdf/scenes`` in an
    installed package, else the repository's ``scenes/``. Raises
    ``FileNotFoundError`` when neither holds ``default.xml``."""
    for folder in (_PACKAGE / "scenes", _PACKAGE.parent / "scenes"):
        if (folder / "default.xml").is_file():
            return folder
    raise FileNotFoundError(f"the package's scenes are missing (looked in {_PACKAGE / 'scenes'} "
                            f"and {_PACKAGE.parent / 'scenes'}); reinstall mitsuba_pbrdf")


def packaged_scenes() -> List[str]:
    """Names of the packaged scenes relative to :func:`scenes_dir` (helpers
    included by other scenes, whose names start with ``_``, left out)."""
    root = scenes_dir()
    return sorted(p.relative_to(root).as_posix() for p in root.rglob("*.xml")
                  if not p.name.startswith("_"))


def packaged_scene(name) -> Optional[Path]:
    """The packaged scene called *name* (``default``, ``default.xml``,
    ``scenes/default.xml``, ``gallery/sphere.xml``, ...), or None."""
    rel = Path(os.fspath(name)).as_posix()
    while rel.startswith("./"):
        rel = rel[2:]
    if rel.startswith("scenes/"):
        rel = rel[len("scenes/"):]
    if not rel.endswith(".xml"):
        rel += ".xml"
    try:
        path = scenes_dir() / rel
    except FileNotFoundError:
        return None
    return path if path.is_file() and not Path(rel).name.startswith("_") else None


def find_scene(path) -> Path:
    """*path* if it is a file, else the packaged scene of that name; raises
    ``FileNotFoundError`` naming the packaged scenes otherwise."""
    if os.path.isfile(os.fspath(path)):
        return Path(path)
    found = packaged_scene(path)
    if found is not None:
        return found
    if os.path.isdir(os.fspath(path)):
        raise IsADirectoryError(f"scene file {path} is a folder")
    try:
        names = ", ".join(packaged_scenes())
    except FileNotFoundError:
        names = "none"
    raise FileNotFoundError(f"scene file not found: {path} (packaged scenes: {names})")
