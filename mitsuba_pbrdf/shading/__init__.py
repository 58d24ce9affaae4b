"""Shading-frame perturbations for polarized variants: ``polarized_normalmap``
and ``polarized_bumpmap`` (docs/normal-maps.md).

The ``normalmap`` and ``bumpmap`` modules define their BSDF classes at module
level and need a Mitsuba variant when run (``registry.register`` runs them once
per variant through ``registry.variant_module``); this package itself, and
:func:`warn_unpolarized_wrappers`, need none.
"""

from .warnings import warn_unpolarized_wrappers

__all__ = ["warn_unpolarized_wrappers"]
