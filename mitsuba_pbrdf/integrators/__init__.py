"""Mitsuba integrators that this package registers in every variant
(:func:`mitsuba_pbrdf.register` calls :func:`register`):

* ``stokes_prb`` (:mod:`.stokes_prb`, loops in :mod:`.replay`): polarization-
  aware path replay. Renders what ``stokes`` around ``path`` renders (same
  film channels, same random numbers) and gives the gradients of ``path``
  differentiated by AD at the memory of a primal render (docs/path-replay.md).
  Usable in the polarized JIT variants; loading it in another variant says
  which to use.
"""

from . import stokes_prb

__all__ = ["register", "stokes_prb"]


def register():
    """Register the package's integrators in the active Mitsuba variant."""
    stokes_prb.register()
