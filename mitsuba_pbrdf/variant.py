"""Mitsuba variants: the supported release, which variant to use by default,
and the errors that say what to type when none (or a wrong one) is set.

Registering the package's plugins in a variant is :mod:`mitsuba_pbrdf.registry`
(``mitsuba_pbrdf.use_variant``); this module sits below it and below the
plugin, which calls :func:`require_variant`. Nothing here imports Mitsuba at
import time.
"""

from __future__ import annotations

__all__ = [
    "SUPPORTED_MITSUBA",
    "DEFAULT_VARIANT",
    "GPU_VARIANT",
    "VariantNotSetError",
    "UnknownVariantError",
    "require_variant",
    "cuda_available",
    "default_variant",
]

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
