"""Registering the package's Mitsuba plugins (the ``pbrdf`` BSDF and the
integrators of :mod:`mitsuba_pbrdf.integrators`) in the active variant, and
keeping them registered when the variant changes.

::

    import mitsuba_pbrdf
    mitsuba_pbrdf.use_variant("llvm_ad_spectral_polarized")   # set it, register the plugins

Mitsuba's Python plugins are registered per variant. Importing
``mitsuba_pbrdf`` registers them in the variant already set (if any) and,
through Mitsuba's variant callbacks, in every variant set afterwards with
``mi.set_variant``; :func:`register` does it by hand. The package ``__init__``
calls :func:`install_hook`, which imports Mitsuba only where it is installed
(the NumPy reference evaluator works without it).
"""

from __future__ import annotations

import importlib.util
import logging
import sys

from .variant import UnknownVariantError, _mitsuba, require_variant

__all__ = ["register", "use_variant", "install_hook"]

log = logging.getLogger(__name__)


def register():
    """Register the ``pbrdf`` BSDF plugin and the package's integrators
    (``stokes_prb``, :mod:`mitsuba_pbrdf.integrators`) in the active variant;
    returns the variant's name. Raises :class:`VariantNotSetError` if none is
    set."""
    mi = require_variant()
    from .integrators import register as register_integrators
    from .plugin import plugin_class

    mi.register_bsdf("pbrdf", plugin_class())
    register_integrators()
    return mi.variant()


def use_variant(name: str) -> None:
    """Set Mitsuba's variant *name* and register the ``pbrdf`` plugin in it.

    Raises :class:`UnknownVariantError`, listing the variants this Mitsuba
    build has, for a variant it lacks or that cannot start here.
    """
    mi = _mitsuba()
    available = list(mi.variants())
    if name not in available:
        raise UnknownVariantError(
            f"unknown Mitsuba variant {name!r}; available: {', '.join(available)}"
        )
    try:
        mi.set_variant(name)
    except (ImportError, RuntimeError) as e:
        raise UnknownVariantError(
            f"Mitsuba variant {name!r} cannot be used here: {' '.join(str(e).split())}"
        ) from e
    register()  # the variant hook has done it already, unless the variant did not change


def _on_variant_change(old, new):
    if new is None:
        return
    try:
        register()
    except Exception as e:  # never break mi.set_variant itself
        log.warning("could not register the pbrdf plugins in %s: %s", new, e)


_hooked = False


def install_hook():
    """Register the plugin in the active variant (if any) and in every variant
    set from now on. Does nothing where Mitsuba is not installed or is not the
    supported release (then :func:`use_variant` says why)."""
    global _hooked
    if _hooked:
        return
    if "mitsuba" not in sys.modules and importlib.util.find_spec("mitsuba") is None:
        return
    try:
        mi = _mitsuba()
    except ImportError:
        return
    mi.detail.add_variant_callback(_on_variant_change)
    _hooked = True
    if mi.variant() is not None:
        register()
