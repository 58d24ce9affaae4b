"""Three-component polarized BRDF for metals, as a Mitsuba 3 plugin.

Usage::

    import mitsuba as mi
    import mitsuba_pbrdf                      # registers the BSDF plugin "pbrdf"

    mitsuba_pbrdf.use_variant("llvm_ad_spectral_polarized")   # or mi.set_variant(...)
    bsdf = mi.load_dict({"type": "pbrdf", "material": "Cu", "sigma": 0.15})

Importing the package needs neither Mitsuba nor a variant. Where Mitsuba is
installed, the plugins are registered in the active variant and in every
variant set afterwards (:mod:`mitsuba_pbrdf.registry`). Anything that needs a
variant (the plugin, rendering) says what to type when none is set.

Sub-packages, one concern each:

* :mod:`~mitsuba_pbrdf.bsdfs`: the Dr.Jit BSDF ``pbrdf`` (never imports the reference);
* :mod:`~mitsuba_pbrdf.reference`: the NumPy float64 reference evaluator (NumPy only);
* :mod:`~mitsuba_pbrdf.frames`: any Mitsuba BSDF in the reference's frames;
* :mod:`~mitsuba_pbrdf.rendering`: rendering a scene file in passes, narrow bands;
* :mod:`~mitsuba_pbrdf.stokes`: Stokes images and their EXR files;
* :mod:`~mitsuba_pbrdf.visualization`: pictures of Stokes images (panels, PNG);
* :mod:`~mitsuba_pbrdf.camera`: what a polarization camera records;
* :mod:`~mitsuba_pbrdf.visualization`: pBRDF plots and the scene gallery;
* :mod:`~mitsuba_pbrdf.measured`: measured-data files (goniometer CSV);
* :mod:`~mitsuba_pbrdf.fitting`: least-squares fits of the model to measurements;
* :mod:`~mitsuba_pbrdf.inverse`: gradients of rendered Stokes images, Adam fits;
* :mod:`~mitsuba_pbrdf.integrators`: Mitsuba integrators the package registers;
* :mod:`~mitsuba_pbrdf.batch`: many renders (sweeps, datasets);
* :mod:`~mitsuba_pbrdf.diagnostics`: physical checks of any polarized BSDF (realizability,
  reciprocity, albedo);
* :mod:`~mitsuba_pbrdf.errors`: errors in the library's terms, one-line descriptions;
* :mod:`~mitsuba_pbrdf.cli`: the ``pbrdf`` command line;
* :mod:`~mitsuba_pbrdf.schema`: every plugin's parameters, each declared once (name, kind, default, bounds, flags),
  written as tables by :mod:`~mitsuba_pbrdf.schema_tables`;
* :mod:`~mitsuba_pbrdf.variant`, :mod:`~mitsuba_pbrdf.registry`: Mitsuba variants, and
  registering the plugins in them.
"""

# Ctrl-C while Mitsuba and Dr.Jit are imported cannot come back as a clean
# KeyboardInterrupt: SIGINT is held meanwhile (mitsuba_pbrdf.interrupts), and
# for the pbrdf command line until its command releases it.
from . import interrupts as _interrupts

_interrupts.hold_for_command_line()
with _interrupts.held():  # for the command line: already held, kept held
    from .registry import install_hook, register, use_variant
    from .variant import SUPPORTED_MITSUBA, UnknownVariantError, VariantNotSetError

    install_hook()

__version__ = "0.1.0"

__all__ = ["__version__", "SUPPORTED_MITSUBA", "VariantNotSetError", "UnknownVariantError",
           "use_variant", "register"]

