"""Mitsuba integrators that this package registers in every variant
(:func:`mitsuba_pbrdf.registry.register` registers them):

* ``stokes_prb`` (:mod:`.stokes_prb`, loops in :mod:`.replay`, splatting in
  :mod:`.film`): polarization-aware path replay. Renders what ``stokes``
  around ``path`` renders (same film channels, same random numbers) and gives
  the gradients of ``path`` differentiated by AD at the memory of a primal
  render (docs/path-replay.md). Usable in the polarized JIT variants; loading
  it in another variant says which to use. :func:`supports_scene` and
  :func:`from_path` (:mod:`.support`) turn a scene's ``stokes``/``path``
  integrator into one.
"""

from .support import MAX_DEPTH_LIMIT, STOKES_CHANNELS
from .support import from_path, integrator_class, supports_scene

__all__ = ["MAX_DEPTH_LIMIT", "STOKES_CHANNELS", "from_path", "integrator_class",
           "supports_scene"]
