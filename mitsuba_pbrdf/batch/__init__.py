"""Many renders at once: parameter sweeps and datasets built from Stokes renders
(home of sweep files, polarization-camera outputs and distributed runs).
Empty so far: single renders live in :mod:`mitsuba_pbrdf.imaging`."""
