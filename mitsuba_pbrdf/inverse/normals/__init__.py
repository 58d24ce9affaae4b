"""Shape from polarization: the normal map of a ``polarized_normalmap`` (and
optionally the roughness map of the ``pbrdf`` it wraps) fitted to target
images by polarized path replay (``stokes_prb``): :func:`recover_normals`
(a scene and images), :func:`recover_from_files` (a scene file and EXRs, as
``pbrdf recover-normals``).

Modules: :mod:`.recover` (the fit), :mod:`.texels` (the fitted texels and
their parametrization), :mod:`.targets` (the targets and their losses),
:mod:`.inputs` (the inputs' checks), :mod:`.result` (:class:`NormalRecovery`
and the files it writes), :mod:`.scenes` (a bumpy metal plate to recover
normals from).
"""

from .recover import SIGMA_BOUNDS, recover_from_files, recover_normals
from .result import NormalRecovery

__all__ = ["SIGMA_BOUNDS", "recover_normals", "recover_from_files", "NormalRecovery"]
