"""What ``stokes_prb`` supports: the scenes it can replay (and a
``stokes_prb`` made from a scene's ``stokes``/``path`` integrator), what it
writes (its film channels), its depth limit and the variants it needs.
Variant-independent."""

from __future__ import annotations

import re

import mitsuba as mi

from ..schema import parameter

__all__ = ["STOKES_CHANNELS", "MAX_DEPTH_LIMIT", "usable_variant", "supports_scene", "from_path",
           "integrator_class"]

#: The Stokes channels ``stokes`` adds after R, G, B (and A).
STOKES_CHANNELS = [f"S{i}.{c}" for i in range(4) for c in "RGB"]
#: Largest ``max_depth``: each vertex costs up to 92 floats of local memory per lane
#: (:class:`.replay.VertexStore`).
MAX_DEPTH_LIMIT = parameter("max_depth", "stokes_prb").upper


def usable_variant(variant):
    """Whether ``stokes_prb`` runs in Mitsuba variant *variant* (a polarized
    JIT variant)."""
    variant = variant or ""
    return "polarized" in variant and not variant.startswith("scalar")


def integrator_class():
    """The ``stokes_prb`` class of the active variant."""
    from ..registry import plugin_class

    return plugin_class("stokes_prb")


def _is_stokes_prb(integrator):
    return isinstance(integrator, integrator_class())


def supports_scene(scene):
    """``(True, "")`` if ``scene``'s integrator is ``stokes`` around ``path``
    (or already ``stokes_prb``) with a depth path replay can store, in a
    polarized JIT variant; else ``(False, why)``."""
    if not usable_variant(mi.variant()):
        return False, f"variant {mi.variant()!r} is not a polarized JIT variant"
    integrator = scene.integrator()
    if _is_stokes_prb(integrator):
        return True, ""
    nested = _nested_path(integrator)
    if nested is None:
        return False, f"the integrator is not stokes around path: {integrator.class_name()}"
    depth, _ = _path_depths(nested)
    if depth < 0 or depth > MAX_DEPTH_LIMIT:
        return False, f"path max_depth {depth} is not in [0, {MAX_DEPTH_LIMIT}]"
    film = scene.sensors()[0].film()
    if mi.has_flag(film.flags(), mi.FilmFlags.Special):
        return False, f"film {film.class_name()} is not an RGB film"
    return True, ""


def from_path(scene):
    """A ``stokes_prb`` integrator with the ``max_depth``, ``rr_depth`` and
    ``hide_emitters`` of ``scene``'s ``stokes``/``path`` integrator (check
    with :func:`supports_scene` first); the scene's own if it is one."""
    integrator = scene.integrator()
    if _is_stokes_prb(integrator):
        return integrator
    nested = _nested_path(integrator)
    depth, rr_depth = _path_depths(nested)
    return mi.load_dict({"type": "stokes_prb", "max_depth": depth, "rr_depth": rr_depth,
                         "hide_emitters": bool(nested.hide_emitters)})


def _nested_path(integrator):
    if integrator is None or integrator.class_name() != "StokesIntegrator":
        return None
    found = []

    class Callback(mi.TraversalCallback):
        def put(self, name, value, flags, *args):
            if isinstance(value, mi.Object):
                found.append(value)

    integrator.traverse(Callback())
    nested = [x for x in found if x.class_name() == "PathIntegrator"]
    return nested[0] if nested else None


def _path_depths(path):
    """``(max_depth, rr_depth)`` of a ``path`` integrator, read from its
    description (-1 for an unbounded depth)."""
    text = str(path)
    depth = int(re.search(r"max_depth = (\d+)", text).group(1))
    rr_depth = int(re.search(r"rr_depth = (\d+)", text).group(1))
    return (-1 if depth == 0xFFFFFFFF else depth), rr_depth
