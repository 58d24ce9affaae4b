"""Shading-frame perturbations for polarized variants: ``polarized_normalmap``
and ``polarized_bumpmap`` (docs/normal-maps.md).

``normalmap`` and ``bumpmap`` modules define their BSDF classes at module level
and need a Mitsuba variant when imported (``registry.register`` imports them);
this package itself, and :func:`warn_unpolarized_wrappers`, need none.
"""

from .warnings import warn_unpolarized_wrappers

#: Plugin name -> (module, class) of the wrappers this package registers.
PLUGINS = {
    "polarized_normalmap": ("mitsuba_pbrdf.shading.normalmap", "PolarizedNormalMap"),
    "polarized_bumpmap": ("mitsuba_pbrdf.shading.bumpmap", "PolarizedBumpMap"),
}

__all__ = ["PLUGINS", "warn_unpolarized_wrappers"]
