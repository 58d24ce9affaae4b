"""Polarized light sources: Mitsuba emitters whose light carries a Stokes
vector (docs/polarized-light.md).

* ``polarized_sky`` (:mod:`.polarized_sky`): a clear sky, partially linearly
  polarized by single (Rayleigh) scattering or with the neutral points of the
  real sky; its intensity is Mitsuba's ``sunsky`` (or a given radiance).
* ``stokes_envmap`` (:mod:`.stokes_envmap`): an environment map of Stokes
  vectors read from a Stokes EXR in latitude-longitude layout.
* ``polarized_emitter`` (:mod:`.polarized_emitter`): any Mitsuba emitter seen
  through an ideal linear polarizer of a given angle and degree.

Each plugin module defines its class at module level for the active variant;
:func:`mitsuba_pbrdf.registry.variant_module` runs it once per variant and
:data:`mitsuba_pbrdf.registry.PLUGINS` registers it. :mod:`mitsuba_pbrdf.mueller`
(emitted Stokes vectors as Mueller matrices, the Stokes basis of emitted
light), :mod:`.sky_models` (the sky's polarization pattern) and :mod:`.params`
(reading and checking parameters) are plain modules shared by the plugins.
"""
