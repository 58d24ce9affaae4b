"""The inputs of :func:`mitsuba_pbrdf.inverse.normals.recover_normals`,
refused before the fit starts, each by its public parameter's name
(:class:`~mitsuba_pbrdf.errors.ParameterError`):

* the options (:func:`check_options`, which the command line calls before
  loading anything): ``observables``, ``parametrization``, ``iterations``,
  ``spp``, ``smoothness``, ``lr``, ``lr_end``, ``lr_decay``, and
* ``seed``: an integer in ``[0, 2^32)`` (Mitsuba's sampler seeds are 32-bit;
  the iterations' seeds are derived from it modulo 2^32:
  :func:`mitsuba_pbrdf.inverse.driver.iteration_seeds`);
* ``max_depth``: -1 (no limit) or at least 2: with 1 a path sees only the
  emitters, with 0 nothing, and no texel would get a gradient;
* ``scene``: a file, a dict or a loaded scene (:func:`as_scene`) with exactly
  one ``polarized_normalmap`` over a raw RGB bitmap of at least 2 x 2
  (:func:`find_normalmap`, :func:`check_normal_map`); ``fit_roughness``
  needs the wrapped ``pbrdf``'s ``sigma`` to be a bitmap (:func:`roughness_key`);
* ``targets``: numeric arrays, finite, not zero everywhere (the loss divides
  by the target's mean square), with usable pixels under the rule of every
  reader of Stokes data (:func:`mitsuba_pbrdf.stokes.quality.require_usable`:
  a target with S0 < 0 everywhere is no measurement); raw polcam frames need a
  positive pixel;
* ``start`` and ``truth``: (H, W, 3) finite normals of non-zero length (an
  angular error against a zero-length normal is NaN, which JSON cannot hold).
"""

from __future__ import annotations

import os

import numpy as np

from ...errors import ParameterError
from ..driver import LR_END
from .targets import OBSERVABLES
from .texels import PARAMETRIZATIONS

__all__ = ["SEED_LIMIT", "check_options", "check_seed", "check_max_depth", "as_scene",
           "find_normalmap", "check_normal_map", "roughness_key", "check_targets",
           "check_normal_field"]

#: Seeds are 32-bit (Mitsuba's samplers).
SEED_LIMIT = 1 << 32


def check_options(observables, parametrization, iterations, spp, smoothness, lr, lr_end=LR_END,
                  lr_decay=None, seed=0, max_depth=3):
    """ParameterError naming the first bad option of
    :func:`~mitsuba_pbrdf.inverse.normals.recover_normals` (checked before
    any scene is loaded; the command line calls it first)."""
    if observables not in OBSERVABLES:
        raise ParameterError("observables", f"must be one of {', '.join(OBSERVABLES)}, "
                                            f"got {observables!r}")
    if parametrization not in PARAMETRIZATIONS:
        raise ParameterError("parametrization", f"must be one of {', '.join(PARAMETRIZATIONS)}, "
                                                f"got {parametrization!r}")
    for name, value in (("iterations", iterations), ("spp", spp)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
            raise ParameterError(name, f"must be an integer >= 1, got {value!r}")
    for name, value in (("smoothness", smoothness), ("lr", lr)):
        if not (np.isfinite(value) and value >= 0) or (name == "lr" and value == 0):
            raise ParameterError(name, f"must be a finite number {'> 0' if name == 'lr' else '>= 0'}"
                                       f", got {value!r}")
    for name, value in (("lr_end", lr_end), ("lr_decay", lr_decay)):
        if value is not None and not (np.isfinite(value) and 0 < value <= 1):
            raise ParameterError(name, f"must be a number in (0, 1], got {value!r}")
    check_seed(seed)
    check_max_depth(max_depth)


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


def as_scene(scene):
    """*scene* loaded: a ``mi.Scene`` as it is, a dict (``mi.load_dict``) or
    an XML file name (``mi.load_file``); ParameterError ``scene`` otherwise."""
    import mitsuba as mi

    if isinstance(scene, mi.Scene):
        return scene
    if isinstance(scene, dict):
        return mi.load_dict(scene)
    if isinstance(scene, (str, os.PathLike)):
        if not os.path.isfile(scene):
            raise ParameterError("scene", f"no such file: {scene}")
        return mi.load_file(os.fspath(scene))
    raise ParameterError("scene", f"must be a file name, a dict or a mitsuba Scene, "
                                  f"got {type(scene).__name__}")


def find_normalmap(scene):
    """``(key, bsdf)``: the ``mi.traverse`` key of the one ``polarized_normalmap``'s
    texels (``<...>.normalmap.data``) and that BSDF. ParameterError ``scene``
    when there is none, or more than one."""
    import mitsuba as mi

    found = []
    for shape in scene.shapes():
        bsdf = shape.bsdf()
        if type(bsdf).__name__ == "PolarizedNormalMap" and all(bsdf is not b for b in found):
            found.append(bsdf)
    if len(found) != 1:
        raise ParameterError("scene", f"needs exactly one shape whose BSDF is a "
                                      f"polarized_normalmap, found {len(found)}")
    bsdf = found[0]
    params = mi.traverse(scene)
    keys = [k for k in params.keys()
            if k.endswith("normalmap.data") and params.properties[k][2] is bsdf.normalmap]
    if len(keys) != 1:
        raise ParameterError("scene", "the polarized_normalmap's 'normalmap' must be a bitmap "
                                      "texture (raw = true)")
    return keys[0], bsdf


def check_normal_map(texels) -> tuple:
    """The shape (H, W, 3) of the normal map's texel tensor; ParameterError
    ``scene`` unless it is an RGB bitmap of at least 2 x 2."""
    shape = tuple(texels.shape)
    if len(shape) != 3 or shape[2] != 3 or min(shape[:2]) < 2:
        raise ParameterError("scene", f"the normal map must be an RGB bitmap of at least 2 x 2, "
                                      f"got shape {shape}")
    return shape


def roughness_key(params, normalmap_key: str) -> str:
    """The ``mi.traverse`` key of the texels of the ``sigma`` of the ``pbrdf``
    that the normal map *normalmap_key* wraps; ParameterError
    ``fit_roughness`` unless that ``sigma`` is a bitmap."""
    key = normalmap_key[: -len("normalmap.data")] + "nested_bsdf.sigma.data"
    if key not in params.keys():
        raise ParameterError("fit_roughness", "needs the wrapped pbrdf's sigma to be a "
                                              "bitmap texture")
    return key


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
    from ...stokes.image import from_mitsuba
    from ...stokes.quality import UnusableImageError, require_usable

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
