"""Does a converted scene render as its original? (``pbrdf convert``'s oracle.)

:func:`compare_scenes` renders two scene files (an original with Mitsuba's
``conductor``/``roughconductor`` and its ``pbrdf`` conversion,
:mod:`mitsuba_pbrdf.rendering.scene_convert`) in a polarized variant at the
same seeds and samples per pixel, and measures:

* ``mean_s0_ratio``: mean S0 of the converted render over the original's;
* ``tile_difference``: the 95th percentile over 4x4-pixel tiles of
  |S0 converted - S0 original| (tile means, every band), in units of the
  original's mean S0, at the same seed;
* ``seed_to_seed``: the same statistic between two renders of the original at
  different seeds: the Monte Carlo noise the first is measured against.
  With sigma = alpha / sqrt(2), Smith shadowing and no diffuse lobes, ``pbrdf``
  draws its random numbers as ``roughconductor`` does, so at matched seeds the
  tile difference is far below the seed-to-seed value;
* ``worst_tile``: the largest |S0 converted - S0 original| of a tile at the
  same seed in units of that tile's own S0 (plus 1e-3 of the mean S0, so that
  black tiles do not divide by zero): where a per-tile bound is known (the
  two BSDFs' pdfs differing by a known factor), this is what it bounds;
* whether DoLP and AoLP are finite in every pixel of the converted render.

The renders are the package's own (:func:`~mitsuba_pbrdf.rendering.render.render_scene`,
in one pass): a scene whose integrator is not ``stokes`` is rendered with it
wrapped in one, as Mitsuba's published scenes need. Units: S0 as the film
records it; ratios dimensionless.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, Optional, Sequence

import numpy as np

__all__ = ["SceneMatch", "render_stokes", "tile_means", "compare_scenes"]


@dataclass
class SceneMatch:
    """The figures of :func:`compare_scenes` (see the module docstring)."""

    mean_s0_ratio: float
    tile_difference: float
    seed_to_seed: float
    worst_tile: float
    polarization_finite: bool
    mean_dolp: float
    shape: tuple


def render_stokes(scene_path, seed: int, spp: int, params: Optional[Mapping] = None,
                  size=None):
    """The :class:`~mitsuba_pbrdf.stokes.image.StokesImage` of *scene_path*
    rendered by :func:`~mitsuba_pbrdf.rendering.render.render_scene` in the
    active (polarized) variant, in one pass at *seed* and *spp* (its integrator
    wrapped in ``stokes`` where it has none; *size* ``(width, height)`` or None)."""
    import mitsuba as mi

    from ..rendering.render import render_scene

    return render_scene(scene_path, spp=spp, variant=mi.variant(), seed=seed, params=params,
                        passes=1, size=size)


def tile_means(image, tile: int = 4) -> np.ndarray:
    """A render, (H, W, channels), as the means of its tile x tile pixel blocks,
    float64 (rows, columns, channels); the last partial row and column of
    tiles are dropped. The unit in which matched-seed renders are compared."""
    image = np.asarray(image, dtype=np.float64)
    h, w = image.shape[0] // tile * tile, image.shape[1] // tile * tile
    return image[:h, :w].reshape(h // tile, tile, w // tile, tile, -1).mean(axis=(1, 3))


def _tile_p95(a: np.ndarray, b: np.ndarray, scale: float) -> float:
    return float(np.percentile(np.abs(tile_means(a) - tile_means(b)), 95) / scale)


def compare_scenes(original, converted, spp: int, seeds: Sequence[int] = (1, 2),
                   params: Optional[Mapping] = None, size=None) -> SceneMatch:
    """Render *original* at ``seeds[0]`` and ``seeds[1]``, *converted* at
    ``seeds[0]``, all at *spp* and *size* (``(width, height)``; None: the
    scenes' own), and measure them (module docstring). *params* are both
    scenes' ``$key`` values. The variant must be polarized and set."""
    from ..stokes.image import aolp, dolp

    reference = render_stokes(original, seeds[0], spp, params, size)
    other_seed = render_stokes(original, seeds[1], spp, params, size)
    result = render_stokes(converted, seeds[0], spp, params, size)
    s0_ref, s0_new = reference.s0, result.s0
    scale = float(s0_ref.mean())
    if not scale > 0:
        raise ValueError(f"{original}: the render is black (mean S0 {scale:g}): nothing to "
                         "compare")
    ref_tiles, new_tiles = tile_means(s0_ref), tile_means(s0_new)
    worst = float(np.max(np.abs(new_tiles - ref_tiles) / (ref_tiles + 1e-3 * scale)))
    finite = bool(np.all(np.isfinite(dolp(result))) and np.all(np.isfinite(aolp(result))))
    return SceneMatch(mean_s0_ratio=float(s0_new.mean()) / scale,
                      tile_difference=_tile_p95(s0_new, s0_ref, scale),
                      seed_to_seed=_tile_p95(other_seed.s0, s0_ref, scale),
                      worst_tile=worst,
                      polarization_finite=finite,
                      mean_dolp=float(np.mean(dolp(result))),
                      shape=tuple(s0_ref.shape[:2]))
