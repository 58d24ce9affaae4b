"""Registering the package's Mitsuba plugins (the ``pbrdf`` BSDF and the
integrators of :mod:`mitsuba_pbrdf.integrators`) in the active variant, and
keeping them registered when the variant changes.

::

    import mitsuba_pbrdf
    mitsuba_pbrdf.use_variant("llvm_ad_spectral_polarized")   # set it, register the plugins

Each plugin class is defined at module level, in a module that subclasses the
active variant's Mitsuba base class (``mi.BSDF``, Mitsuba's ``ADIntegrator``)
when it runs, as Mitsuba's own Python integrators do; :func:`variant_module`
runs such a module once per variant and keeps each variant's copy, so a
variant's classes stay the same objects however often the variant changes.

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
import threading

from .interrupts import held
from .variant import UnknownVariantError, _mitsuba, require_variant

__all__ = ["PLUGINS", "register", "use_variant", "install_hook", "variant_module", "plugin_class"]

log = logging.getLogger(__name__)


#: Every Mitsuba plugin the package registers: (plugin kind, name in scene
#: files, module, class). Each module sets ``VARIANT = mi.variant()``.
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

_modules = {}
#: Held while a module is looked up or run: Mitsuba builds a scene's plugins on
#: several threads, and another thread must not take a module whose body is
#: still running (its VARIANT set, its classes not yet: CI, "no attribute
#: 'PolarizedBRDF'"). Reentrant: a module may import another one.
_modules_lock = threading.RLock()


def variant_module(name: str):
    """Module *name* as run under the active variant (its classes derive from
    that variant's Mitsuba base classes): run once per variant, then reused."""
    mi = require_variant()
    variant = mi.variant()
    with _modules_lock:
        return _variant_module(name, variant)


def _variant_module(name: str, variant: str):
    module = _modules.get((name, variant))
    if module is None:
        current = sys.modules.get(name)
        if current is not None and getattr(current, "VARIANT", None) == variant:
            module = current
        else:
            spec = importlib.util.find_spec(name)
            module = importlib.util.module_from_spec(spec)
            sys.modules[name] = module
            try:
                spec.loader.exec_module(module)
            except BaseException:
                sys.modules.pop(name, None)
                raise
        _modules[(name, variant)] = module
    sys.modules[name] = module
    return module


def plugin_class(name: str):
    """The class of plugin *name* (``"pbrdf"``, ``"stokes_prb"``) for the
    active variant."""
    for _, plugin, module, cls in PLUGINS:
        if plugin == name:
            return getattr(variant_module(module), cls)
    raise KeyError(f"no plugin {name!r}; plugins: {', '.join(p[1] for p in PLUGINS)}")


def _factory(name):
    return lambda props: plugin_class(name)(props)


def register():
    """Register the package's plugins (:data:`PLUGINS`: the ``pbrdf`` BSDF and
    the ``stokes_prb`` integrator) in the active variant; returns the
    variant's name. Raises :class:`VariantNotSetError` if none is set."""
    mi = require_variant()
    for kind, name, _, _ in PLUGINS:
        getattr(mi, f"register_{kind}")(name, _factory(name))
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
