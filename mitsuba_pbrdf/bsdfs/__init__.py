"""The package's Mitsuba BSDFs, one module each, classes at module level:

* ``pbrdf`` (:mod:`.pbrdf`): the three-component polarized BRDF as a
  Dr.Jit-vectorized ``mi.BSDF``, its parameter table in the module docstring;
  its lobes as records (:mod:`.lobes`), the facet's Fresnel Mueller matrix
  (:mod:`.fresnel`), microfacet helpers (:mod:`.microfacet`), parameter
  checks (:mod:`.params`) and named conductors (:mod:`.ior`);
* ``polarized_normalmap`` (:mod:`.normalmap`) and ``polarized_bumpmap``
  (:mod:`.bumpmap`): Mitsuba's shading-frame perturbations with the Stokes
  bases rotated (docs/normal-maps.md), their shared body in
  :mod:`.perturbed`; :func:`warn_unpolarized_wrappers` says when a polarized
  render uses Mitsuba's own wrappers instead;
* ``polarized_twosided`` (:mod:`.twosided`): Mitsuba's ``twosided`` with the
  back side's Stokes bases put right.

The plugin modules subclass the active variant's ``mi.BSDF`` when they run, so
they are loaded per variant by :func:`mitsuba_pbrdf.registry.variant_module`
(``mitsuba_pbrdf.registry.plugin_class("pbrdf")`` gives the class); this
package itself needs no variant. The Stokes-basis rotations they share with
the integrators and emitters are in :mod:`mitsuba_pbrdf.mueller`. ``pbrdf``
never imports the NumPy reference evaluator (:mod:`mitsuba_pbrdf.reference`):
the two are independent implementations of the model that tests compare.
"""

from .unpolarized_wrappers import warn_unpolarized_wrappers

__all__ = ["warn_unpolarized_wrappers"]
