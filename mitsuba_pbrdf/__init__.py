"""Three-component polarized BRDF for metals, as a Mitsuba 3 plugin.

Usage::

    import mitsuba as mi
    mi.set_variant("llvm_ad_spectral_polarized")
    import mitsuba_pbrdf            # registers the BSDF plugin "pbrdf"

    bsdf = mi.load_dict({"type": "pbrdf", "material": "Cu", "sigma": 0.15})

Importing registers the plugin for the variant that is active at that moment.
After ``mi.set_variant(...)`` to another variant, call
:func:`mitsuba_pbrdf.register` again.

The NumPy float64 reference evaluator, :mod:`mitsuba_pbrdf.reference`, needs no
variant and can be imported on its own.
"""

import sys

__version__ = "0.1.0"

SUPPORTED_MITSUBA = "3.9"

_VARIANT_HINT = (
    "mitsuba_pbrdf registers a Mitsuba plugin and needs a Mitsuba variant to be "
    "set first, e.g.\n\n"
    "    import mitsuba as mi\n"
    "    mi.set_variant('llvm_ad_spectral_polarized')\n"
    "    import mitsuba_pbrdf\n"
)


class VariantNotSetError(ImportError):
    """Raised when the plugin is registered before ``mi.set_variant``."""


def _check_mitsuba():
    import mitsuba as mi

    if not mi.__version__.startswith(SUPPORTED_MITSUBA + "."):
        raise ImportError(
            f"mitsuba_pbrdf needs Mitsuba {SUPPORTED_MITSUBA}.x, found {mi.__version__}: "
            f"pip install 'mitsuba=={SUPPORTED_MITSUBA}.*'"
        )
    if mi.variant() is None:
        raise VariantNotSetError(_VARIANT_HINT)
    return mi


def register():
    """Register the ``pbrdf`` BSDF plugin for the currently active variant.

    Returns the name of the variant it was registered for. Call it again after
    switching variants with ``mi.set_variant``.
    """
    mi = _check_mitsuba()
    from .bsdf import plugin_class

    mi.register_bsdf("pbrdf", plugin_class())
    return mi.variant()


def _importing_a_submodule():
    """True when this package is being imported only to reach one of its
    submodules (``import mitsuba_pbrdf.reference``, ``from mitsuba_pbrdf import
    reference``, the ``pbrdf`` console script, ``python -m mitsuba_pbrdf``),
    which need no variant. Read off the import machinery's frames."""
    frame = sys._getframe(2)  # skip this function and the package body
    while frame is not None:
        filename = frame.f_code.co_filename
        if filename.startswith("<frozen importlib"):
            name = frame.f_locals.get("name")
            if isinstance(name, str) and name.startswith(__name__ + "."):
                return True
        elif filename.endswith("runpy.py") or filename == "<frozen runpy>":
            return True
        else:  # the importing statement itself: `from mitsuba_pbrdf import x, y`?
            return _from_import_names(frame) <= _SUBMODULES and bool(_from_import_names(frame))
        frame = frame.f_back
    return False


_SUBMODULES = {"reference", "cli", "stokes_io", "visualize", "render", "__main__", "fit", "plots",
               "gallery"}


def _from_import_names(frame):
    """Names of the ``from ... import`` statement running in *frame* (else empty)."""
    import dis

    fromlist = None
    for ins in dis.get_instructions(frame.f_code):
        if ins.opname == "LOAD_CONST":
            fromlist = ins.argval
        if ins.offset >= frame.f_lasti:
            break
    if ins.opname == "IMPORT_NAME" and isinstance(fromlist, tuple):
        return set(fromlist)
    return set()


try:
    register()
except VariantNotSetError:
    if not _importing_a_submodule():
        raise
