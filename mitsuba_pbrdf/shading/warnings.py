"""A one-line warning when a polarized render uses Mitsuba's ``normalmap`` or
``bumpmap``, whose Mueller matrices are in the wrong Stokes bases (AoLP off by
up to 45°; docs/normal-maps.md)."""

from __future__ import annotations

import logging

log = logging.getLogger(__name__)

#: Mitsuba's class name -> (its plugin name, the replacement).
REPLACEMENTS = {
    "NormalMap": ("normalmap", "polarized_normalmap"),
    "BumpMap": ("bumpmap", "polarized_bumpmap"),
}


def mitsuba_wrappers(scene):
    """The plugin names of Mitsuba's ``normalmap``/``bumpmap`` found among the
    BSDFs of ``scene``'s shapes, nested BSDFs included (sorted, no repeats)."""
    found, seen, todo = set(), set(), [shape.bsdf() for shape in scene.shapes()]
    while todo:
        obj = todo.pop()
        if obj is None or id(obj) in seen:
            continue
        seen.add(id(obj))
        name = obj.class_name().split("[")[0]
        if name in REPLACEMENTS:
            found.add(REPLACEMENTS[name][0])
        todo.extend(_children(obj))
    return sorted(found)


def _children(obj):
    """The Mitsuba objects ``obj`` exposes through ``traverse``."""
    import mitsuba as mi

    children = []

    class Collect(mi.TraversalCallback):
        def put(self, name, value, flags):
            if isinstance(value, mi.Object):
                children.append(value)

    try:
        obj.traverse(Collect())
    except (TypeError, AttributeError, RuntimeError):
        pass
    return children


def warn_unpolarized_wrappers(scene) -> list:
    """Log one warning line per Mitsuba wrapper ``scene`` uses in a polarized
    variant, naming the replacement; returns the lines (empty when there is
    nothing to say)."""
    import mitsuba as mi

    if not mi.is_polarized:
        return []
    lines = []
    for plugin in mitsuba_wrappers(scene):
        replacement = dict(REPLACEMENTS.values())[plugin]
        lines.append(f"the scene uses Mitsuba's '{plugin}', whose polarization (AoLP) is "
                     f"wrong in polarized variants; use '{replacement}' instead")
        log.warning(lines[-1])
    return lines
