"""Mitsuba integrators that this package registers (home of the polarization-
aware path-replay integrator). Each module defines one integrator and a
``register()`` that :func:`mitsuba_pbrdf.register` calls for the active
variant; none exists yet."""
