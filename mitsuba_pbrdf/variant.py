"""Choosing the Mitsuba variant and registering the ``pbrdf`` plugin (and the
package's integrators, ``stokes_prb``) in it.

::

    import mitsuba_pbrdf
    mitsuba_pbrdf.use_variant("llvm_ad_spectral_polarized")   # set it, register pbrdf

Mitsuba's Python plugins are registered per variant. This module keeps the
``pbrdf`` plugin and the integrators of :mod:`mitsuba_pbrdf.integrators`
registered in whatever variant is active: importing
``mitsuba_pbrdf`` registers it in the variant already set (if any) and, through
Mitsuba's variant callbacks, in every variant set afterwards with
``mi.set_variant``. :func:`register` does it by hand.

Nothing here imports Mitsuba at import time of this module; the package
``__init__`` calls :func:`install_hook`, which imports Mitsuba only where it
is installed (the NumPy reference evaluator works without it).
"""

from __future__ import annotations

import importlib.util
import logging
import sys

__all__ = [
    "SUPPORTED_MITSUBA",
    "DEFAULT_VARIANT",
    "GPU_VARIANT",
    "VariantNotSetError",
    "UnknownVariantError",
    "use_variant",
    "register",
    "require_variant",
    "cuda_available",
    "default_variant",
    "install_hook",
]

log = logging.getLogger(__name__)

#: The Mitsuba release series this package is written and tested for.
SUPPORTED_MITSUBA = "3.9"
#: The CPU variant: the default where no CUDA GPU can be used.
DEFAULT_VARIANT = "llvm_ad_spectral_polarized"
#: The variant chosen when a CUDA GPU is present and usable.
GPU_VARIANT = "cuda_ad_spectral_polarized"

_VARIANT_HINT = (
    "no Mitsuba variant is set; set one first, e.g.\n\n"
    "    import mitsuba_pbrdf\n"
    "    mitsuba_pbrdf.use_variant('llvm_ad_spectral_polarized')\n\n"
    "or mi.set_variant('llvm_ad_spectral_polarized') (the plugin is registered in every "
    "variant set after importing mitsuba_pbrdf)"
)


class VariantNotSetError(ImportError):
    """Something that needs a Mitsuba variant was used before one was set."""


class UnknownVariantError(ValueError):
    """The requested Mitsuba variant is not in this build, or cannot start here
    (e.g. a ``cuda_*`` variant without a GPU)."""


def _mitsuba():
    """The ``mitsuba`` module, checked to be the supported release."""
    try:
        import mitsuba as mi
    except ImportError as e:
        raise ImportError(f"mitsuba_pbrdf needs Mitsuba {SUPPORTED_MITSUBA}.x: "
                          f"pip install 'mitsuba=={SUPPORTED_MITSUBA}.*' ({e})") from None
    if not mi.__version__.startswith(SUPPORTED_MITSUBA + "."):
        raise ImportError(
            f"mitsuba_pbrdf needs Mitsuba {SUPPORTED_MITSUBA}.x, found {mi.__version__}: "
            f"pip install 'mitsuba=={SUPPORTED_MITSUBA}.*'"
        )
    return mi


def require_variant():
    """The ``mitsuba`` module, with a variant set; else :class:`VariantNotSetError`
    saying what to type."""
    mi = _mitsuba()
    if mi.variant() is None:
        raise VariantNotSetError(_VARIANT_HINT)
    return mi


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
    register()  # already done by the variant hook; kept for Mitsubas without callbacks


def cuda_available() -> bool:
    """True when Mitsuba has :data:`GPU_VARIANT` and it can be set here
    (a CUDA driver and GPU are present).

    Sets :data:`GPU_VARIANT` to find out; puts the previous variant back if
    one was set."""
    mi = _mitsuba()
    if GPU_VARIANT not in mi.variants():
        return False
    try:
        import drjit as dr

        if not dr.has_backend(dr.JitBackend.CUDA):
            return False
    except Exception:  # an older Dr.Jit without has_backend: try the variant
        pass
    previous = mi.variant()
    try:
        mi.set_variant(GPU_VARIANT)
    except Exception:
        return False
    if previous is not None and previous != GPU_VARIANT:
        mi.set_variant(previous)
    return True


def default_variant(probe=None) -> str:
    """:data:`GPU_VARIANT` if *probe* (default :func:`cuda_available`) says a
    GPU can be used, else :data:`DEFAULT_VARIANT`. A probe that raises counts
    as no GPU."""
    probe = cuda_available if probe is None else probe
    try:
        return GPU_VARIANT if probe() else DEFAULT_VARIANT
    except Exception:
        return DEFAULT_VARIANT


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
