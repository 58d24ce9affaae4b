"""The ``pbrdf`` Mitsuba plugin: the three-component polarized BRDF as a
Dr.Jit-vectorized ``mi.BSDF`` (:mod:`.bsdf`, parameter table in its
docstring), with its lobes as records (:mod:`.lobes`), the facet's Fresnel
Mueller matrix (:mod:`.fresnel`), microfacet helpers (:mod:`.microfacet`),
parameter checks (:mod:`.params`) and named conductors (:mod:`.ior`).

It needs a Mitsuba variant to be set before :func:`plugin_class` is called
and never imports the NumPy reference evaluator (:mod:`mitsuba_pbrdf.reference`):
the two are independent implementations of the model that tests compare.
"""

from .bsdf import MIN_SIGMA, plugin_class

__all__ = ["MIN_SIGMA", "plugin_class"]
