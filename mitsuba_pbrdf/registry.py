"""Registering the package's Mitsuba plugins (:data:`PLUGINS`: the BSDFs,
emitters and integrators) in the active variant, and
keeping them registered when the variant changes.

::

    import mitsuba_pbrdf
    mitsuba_pbrdf.use_variant("llvm_ad_spectral_polarized")   # set it, register the plugins

A plugin class derives from the active variant's Mitsuba base class
(``mi.BSDF``, ``mi.Emitter``, Mitsuba's ``ADIntegrator``), so there is one per
variant. Each plugin module defines it in a factory, ``build_class()``, that
:func:`plugin_class` calls once per variant and keeps; the modules themselves
import without a variant, and no module is run twice. Variants used side by
side (threads, Dask workers) and switched back and forth each keep their own
classes, the same objects however often the variant changes.

Mitsuba's Python plugins are registered per variant. Importing
``mitsuba_pbrdf`` registers them in the variant already set (if any) and,
through Mitsuba's variant callbacks, in every variant set afterwards with
``mi.set_variant``; :func:`register` does it by hand. The package ``__init__``
calls :func:`install_hook`, which imports Mitsuba only where it is installed
(the NumPy reference evaluator works without it).
"""

from __future__ import annotations

import importlib
import importlib.util
import logging
import sys

from .interrupts import held
from .variant import UnknownVariantError, _mitsuba, require_variant

__all__ = ["PLUGINS", "register", "use_variant", "install_hook", "plugin_class"]

log = logging.getLogger(__name__)


#: Every Mitsuba plugin the package registers: (plugin kind, name in scene
#: files, module, class). Each module's ``build_class()`` defines the class.
PLUGINS = (
    ("bsdf", "pbrdf", "mitsuba_pbrdf.bsdfs.pbrdf", "PolarizedBRDF"),
    ("integrator", "stokes_prb", "mitsuba_pbrdf.integrators.stokes_prb", "StokesPRBIntegrator"),
    ("bsdf", "polarized_normalmap", "mitsuba_pbrdf.bsdfs.normalmap", "PolarizedNormalMap"),
    ("bsdf", "polarized_bumpmap", "mitsuba_pbrdf.bsdfs.bumpmap", "PolarizedBumpMap"),
    ("bsdf", "polarized_twosided", "mitsuba_pbrdf.bsdfs.twosided", "PolarizedTwoSided"),
    ("emitter", "polarized_sky", "mitsuba_pbrdf.emitters.polarized_sky", "PolarizedSky"),
    ("emitter", "stokes_envmap", "mitsuba_pbrdf.emitters.stokes_envmap", "StokesEnvmap"),
    ("emitter", "polarized_emitter", "mitsuba_pbrdf.emitters.polarized_emitter",
     "PolarizedEmitter"),
)

#: (plugin name, variant) -> the plugin's class for that variant.
_classes = {}


def plugin_class(name: str):
    """The class of plugin *name* (``"pbrdf"``, ``"stokes_prb"``) for the
    active variant, built by its module's ``build_class()`` the first time.

    No lock: threads that build the same variant's class at once each get the
    one that ``dict.setdefault`` (atomic) kept, so a variant has one class."""
    for _, plugin, module, _ in PLUGINS:
        if plugin == name:
            break
    else:
        raise KeyError(f"no plugin {name!r}; plugins: {', '.join(p[1] for p in PLUGINS)}")
    key = (name, require_variant().variant())
    cls = _classes.get(key)
    if cls is None:
        cls = _classes.setdefault(key, importlib.import_module(module).build_class())
    return cls


def _factory(name):
    return lambda props: plugin_class(name)(props)


def register():
    """Register the package's plugins (every one of :data:`PLUGINS`) in the
    active variant, each built on first use; returns the variant's name. Raises :class:`VariantNotSetError` if none is set."""
    mi = require_variant()
    for kind, name, _, _ in PLUGINS:
        getattr(mi, f"register_{kind}")(name, _factory(name))
    return mi.variant()


def use_variant(name: str) -> None:
    """Set Mitsuba's variant *name* and register the package's plugins in it.

    Raises :class:`UnknownVariantError`, listing the variants this Mitsuba
    build has, for a variant it lacks or that cannot start here.
    """
    mi = _mitsuba()
    available = list(mi.variants())
    if name not in available:
        raise UnknownVariantError(
            f"unknown Mitsuba variant {name!r}; available: {', '.join(available)}"
        )
    # held: set_variant imports the variant's extension and calls the hook from C++
    with held():
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
