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


def warn_unpolarized_wrappers(scene):
    """In a polarized variant, log ONE warning line if ``scene`` uses
    Mitsuba's ``normalmap`` or ``bumpmap``, naming the replacements; returns
    the line (None when there is nothing to say)."""
    import mitsuba as mi

    if not mi.is_polarized:
        return None
    found = mitsuba_wrappers(scene)
    if not found:
        return None
    replacements = dict(REPLACEMENTS.values())
    line = (f"{' and '.join(repr(p) for p in found)} (Mitsuba's) "
            f"{'give' if len(found) > 1 else 'gives'} a wrong angle of linear polarization "
            f"in polarized variants; use {' and '.join(repr(replacements[p]) for p in found)} "
            "(docs/normal-maps.md)")
    log.warning(line)
    return line
