"""Deprecated: use :mod:`mitsuba_pbrdf.rendering` (rendering),
:mod:`mitsuba_pbrdf.rendering.passes` (passes) and :mod:`mitsuba_pbrdf.variant`
(variants). Kept so that old imports still work."""

import warnings

from .rendering.passes import MAX_AUTO_PASSES, SAMPLES_PER_PASS, pass_seeds, plan_passes
from .rendering.render import (RenderTimings, SceneLoadError, load_scene, render_scene,
                               render_scene_timed)
from .registry import use_variant
from .variant import (DEFAULT_VARIANT, GPU_VARIANT, UnknownVariantError, cuda_available,
                      default_variant)

__all__ = ["DEFAULT_VARIANT", "GPU_VARIANT", "SAMPLES_PER_PASS", "MAX_AUTO_PASSES",
           "cuda_available", "default_variant", "plan_passes", "pass_seeds", "RenderTimings",
           "UnknownVariantError", "SceneLoadError", "set_variant", "load_scene", "render_scene",
           "render_scene_timed"]


def set_variant(variant: str):
    """``use_variant(variant)``, returning the ``mitsuba`` module (the old behaviour)."""
    import mitsuba as mi

    use_variant(variant)
    return mi


warnings.warn("mitsuba_pbrdf.render is deprecated; use mitsuba_pbrdf.rendering "
              "(and mitsuba_pbrdf.use_variant)", DeprecationWarning, stacklevel=2)
