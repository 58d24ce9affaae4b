"""The package's Mitsuba BSDFs, one module each, classes at module level:

* ``pbrdf`` (:mod:`.pbrdf`): the three-component polarized BRDF as a
  Dr.Jit-vectorized ``mi.BSDF``, its parameter table in the module docstring;
  its lobes as records (:mod:`.lobes`), the facet's Fresnel Mueller matrix
  (:mod:`.fresnel`), microfacet helpers (:mod:`.microfacet`), its textures'
  and widths' checks (:mod:`.pbrdf_properties`) and named conductors (:mod:`.ior`);
* ``polarized_normalmap`` (:mod:`.normalmap`) and ``polarized_bumpmap``
  (:mod:`.bumpmap`): Mitsuba's shading-frame perturbations with the Stokes
  bases rotated (docs/normal-maps.md), their shared body in
  :mod:`.perturbed`; :func:`warn_unpolarized_wrappers` says when a polarized
  render uses Mitsuba's own wrappers instead;
* ``polarized_twosided`` (:mod:`.twosided`): Mitsuba's ``twosided`` with the
  back side's Stokes bases put right.

Each plugin module's ``build_class()`` subclasses the active variant's
``mi.BSDF``; :func:`mitsuba_pbrdf.registry.plugin_class` (``plugin_class("pbrdf")``)
builds and keeps one class per variant. The modules import without a variant. The Stokes-basis rotations they share with
the integrators and emitters are in :mod:`mitsuba_pbrdf.mueller`. ``pbrdf``
never imports the NumPy reference evaluator (:mod:`mitsuba_pbrdf.reference`):
the two are independent implementations of the model that tests compare.
"""

from .unpolarized_wrappers import warn_unpolarized_wrappers

__all__ = ["warn_unpolarized_wrappers"]
