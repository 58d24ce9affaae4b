"""The inputs of :func:`mitsuba_pbrdf.inverse.normals.recover_normals` that
the fit cannot survive, refused before it starts, each by its public
parameter's name (:class:`~mitsuba_pbrdf.errors.ParameterError`):

* ``seed``: an integer in ``[0, 2^32)`` (Mitsuba's sampler seeds are 32-bit;
  the iterations' seeds are derived from it modulo 2^32:
  :func:`mitsuba_pbrdf.inverse.driver.iteration_seeds`);
* ``max_depth``: -1 (no limit) or at least 2: with 1 a path sees only the
  emitters, with 0 nothing, and no texel would get a gradient;
* ``targets``: numeric arrays, finite, not zero everywhere (the loss divides
  by the target's mean square), with usable pixels under the rule of every
  reader of Stokes data (:func:`mitsuba_pbrdf.stokes.quality.require_usable`:
  a target with S0 < 0 everywhere is no measurement); raw polcam frames need a
  positive pixel;
* ``start`` and ``truth``: (H, W, 3) finite normals of non-zero length (an
  angular error against a zero-length normal is NaN, which JSON cannot hold).
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError

__all__ = ["SEED_LIMIT", "check_seed", "check_max_depth", "check_targets", "check_normal_field"]

#: Seeds are 32-bit (Mitsuba's samplers).
SEED_LIMIT = 1 << 32


def check_seed(seed) -> int:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) \
            or not 0 <= int(seed) < SEED_LIMIT:
        raise ParameterError("seed", f"must be an integer in [0, 2^32 - 1], got {seed!r}")
    return int(seed)


def check_max_depth(max_depth) -> int:
    if isinstance(max_depth, bool) or not isinstance(max_depth, (int, np.integer)) \
            or not (int(max_depth) == -1 or int(max_depth) >= 2):
        raise ParameterError("max_depth", f"must be -1 (no limit) or an integer >= 2 (1 sees "
                                          f"only the emitters, 0 nothing: no texel would get a "
                                          f"gradient), got {max_depth!r}")
    return int(max_depth)


def _array(value, name: str, what: str) -> np.ndarray:
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ParameterError(name, f"{what} must be an array of numbers, got "
                                   f"{type(value).__name__}") from None
    if not np.all(np.isfinite(array)):
        raise ParameterError(name, f"{what} has non-finite values")
    return array


def check_targets(targets, sensors: int, observables: str, channels) -> list:
    """The targets as float64 arrays, checked (module docstring); *channels*:
    ``channels(i)``, the film channel names of sensor *i*."""
    from ..stokes.image import from_mitsuba
    from ..stokes.quality import UnusableImageError, require_usable

    if not isinstance(targets, (list, tuple)) or len(targets) != sensors:
        got = len(targets) if isinstance(targets, (list, tuple)) else type(targets).__name__
        raise ParameterError("targets", f"needs one image per sensor ({sensors}), got {got}")
    out = []
    for i, target in enumerate(targets):
        array = _array(target, "targets", f"target {i}")
        if not np.any(array):
            raise ParameterError("targets", f"target {i} is zero everywhere: nothing to fit "
                                            "(the loss is relative to the target's brightness)")
        if observables == "polcam":
            if not np.any(array > 0):
                raise ParameterError("targets", f"target {i}: no pixel of the raw frame is "
                                                "positive")
        elif array.ndim == 3 and array.shape[2] == len(channels(i)):
            try:
                require_usable(from_mitsuba(array.astype(np.float32), list(channels(i))),
                               f"target {i}", bands=None)
            except UnusableImageError as e:
                raise ParameterError("targets", str(e)) from None
        out.append(array)
    return out


def check_normal_field(value, name: str, shape) -> np.ndarray:
    """*value* as (H, W, 3) float64 normals of the normal map's *shape*, finite
    and of non-zero length; ParameterError naming *name* otherwise."""
    array = _array(value, name, name)
    if array.shape != tuple(shape):
        raise ParameterError(name, f"must have the normal map's shape {tuple(shape)}, got "
                                   f"{array.shape}")
    lengths = np.linalg.norm(array, axis=-1)
    if np.any(lengths < 1e-3):
        raise ParameterError(name, f"{int(np.sum(lengths < 1e-3))} normals have zero length "
                                   "(no direction)")
    return array
