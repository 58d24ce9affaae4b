"""The ``pbrdf`` Mitsuba plugin: the three-component polarized BRDF as a
Dr.Jit-vectorized ``mi.BSDF`` (:mod:`.bsdf`, a module-level class with its
parameter table in the docstring), with its lobes as records (:mod:`.lobes`),
the facet's Fresnel Mueller matrix (:mod:`.fresnel`), microfacet helpers
(:mod:`.microfacet`), parameter checks (:mod:`.params`) and named conductors
(:mod:`.ior`).

:mod:`.bsdf` subclasses the active variant's ``mi.BSDF`` when it runs, so it is
loaded per variant by :func:`mitsuba_pbrdf.registry.variant_module`
(``mitsuba_pbrdf.registry.plugin_class("pbrdf")`` gives the class). The
plugin never imports the NumPy reference evaluator
(:mod:`mitsuba_pbrdf.reference`): the two are independent implementations of
the model that tests compare.
"""
