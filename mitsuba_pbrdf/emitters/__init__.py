"""Polarized light sources: Mitsuba emitters whose light carries a Stokes
vector (docs/polarized-light.md).

* ``polarized_sky`` (:mod:`.polarized_sky`): a clear sky, partially linearly
  polarized by single (Rayleigh) scattering or with the neutral points of the
  real sky; its intensity is Mitsuba's ``sunsky``, at a sun direction or a
  date, time and place (or a given radiance: a spectrum or a texture).
* ``stokes_envmap`` (:mod:`.stokes_envmap`): an environment map of Stokes
  vectors read from a Stokes EXR in latitude-longitude layout.
* ``polarized_emitter`` (:mod:`.polarized_emitter`): any Mitsuba emitter seen
  through an ideal linear polarizer of a given angle and degree.

Each plugin module's ``build_class()`` defines its class for the active
variant; :func:`mitsuba_pbrdf.registry.plugin_class` keeps one per variant and
:data:`mitsuba_pbrdf.registry.PLUGINS` registers it. :mod:`mitsuba_pbrdf.mueller`
(emitted Stokes vectors as Mueller matrices, the Stokes basis of emitted
light), :mod:`.sky_models` (the sky's polarization pattern), :mod:`mitsuba_pbrdf.properties`
(reading and checking every plugin's parameters) and :mod:`.wrapped` (the
base class that hands the wrapped emitter's sampling on) are shared by the
plugins.
"""
